"""Reading a file into Python data and validating it against a schema: every problem one line
``file: field: what is wrong`` (:class:`ecostudy.core.errors.InputError`)."""
import difflib
import hashlib
import json
import re
from os import PathLike
from pathlib import Path
from typing import Any, Mapping, Sequence, TypeAlias, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from ecostudy.core.errors import InputError, problem
from ecostudy.core.types import SOURCE, Track, Train
from ecostudy.io.schemabase import Strict
from ecostudy.io.yamlsafe import MAX_DEPTH, MAX_FILE_BYTES, DocumentError, check_depth, load_yaml, unique_keys

Model = TypeVar("Model", bound=BaseModel)
Value = TypeVar("Value")
Where: TypeAlias = str | PathLike[str]  # a file, or what names an input in messages


def given(value: Value | None) -> Value:
    """A schema field that the schema's own checks guarantee where it is read (one of the forms of a
    field is complete, a study that is no library names its track): never None there."""
    if value is None:
        raise ValueError("a field the schema guarantees is missing (a schema check was dropped?)")
    return value


def overlaid(document: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``document`` with ``overrides`` laid over it: a mapping merged key by key (a scenario's
    ``regenerative_braking: {efficiency: 0.8}`` changes that field and keeps the block's others),
    any other value (a number, a list, null) replacing the document's."""
    merged = dict(document)
    for key, value in overrides.items():
        below = merged.get(key)
        merged[key] = (overlaid(below, value) if isinstance(value, Mapping) and isinstance(below, Mapping)
                       else value)
    return merged


def split_selector(path: Where) -> tuple[Path, str | None]:
    """(file path, selector or None) of ``file#selector``; a file whose name holds '#' stays whole."""
    text = str(path)
    if "#" in text and not Path(text).is_file():
        text, selector = text.rsplit("#", 1)
        return Path(text), selector
    return Path(text), None


FILE_ARGUMENTS = ("study", "track", "train", "timetable")  # the arguments that name an input file by its kind


def not_a_path(name: str, value: object) -> str:
    """Why ``value`` given for the path argument ``name`` is none: 'a path to a train file, not Train
    Train(...)' (a loaded train or track where its file belongs: the functions that take loaded ones
    said), 'a path, not NoneType None'."""
    what = f"a path to a {name} file" if name in FILE_ARGUMENTS else "a path (str or pathlib.Path)"
    loaded = " (api.solve takes loaded ones)" if isinstance(value, (Track, Train)) else ""
    return f"{what}, not {type(value).__name__} {value!r:.60}{loaded}"


def file_digest(path: Where) -> str:
    """SHA-256 of a file's bytes (of ``file#selector``: of the file), to tell whether it changed."""
    return hashlib.sha256(split_selector(path)[0].read_bytes()).hexdigest()


def read_from(value: Any, path: Where) -> Any:
    """``value`` (a ``Track`` or ``Train``), remembering the file it was read from,
    resolved, and that file's digest as it was read (:func:`ecostudy.core.types.source_file`). An object built in code,
    or changed with ``dataclasses.replace``, is a new object that remembers none."""
    object.__setattr__(value, SOURCE, (str(Path(path).resolve()), file_digest(path)))
    return value


def not_a_file(path: Path) -> str:
    """Why ``path`` cannot be read as a file: a folder, a symbolic link that leads nowhere (to a
    missing target, or round in a loop), something that is not a regular file (a device, a pipe),
    or nothing there."""
    if path.is_dir():
        return "a folder, not a file"
    if path.is_symlink():
        return "a symbolic link that leads nowhere (its target is missing, or the links form a loop)"
    if path.exists():
        return "not a regular file (a device, a pipe or a socket)"
    return "file not found"


def named_file(study: Where, field: str, name: Where) -> Path:
    """The file ``name`` that the study file ``study`` gives in ``field`` (relative to the study file's
    folder; ``file#selector`` keeps its selector); one that is not there is refused in one line naming
    the study file and the field."""
    if not str(name).strip():
        raise InputError(problem(study, field, "an empty file name"))
    path = Path(study).parent / name
    file = split_selector(path)[0]
    if not file.is_file():
        raise InputError(problem(study, field, f"'{name}': {not_a_file(file)}" + ("" if Path(name).is_absolute() else f" ({file})")))
    return path


def check_path(path: object, kind: str) -> None:
    """Refuse a ``path`` to a ``kind`` file (``train``) that is no path (``api.load_track(5)``: Path()
    raised TypeError), naming the argument."""
    if not isinstance(path, (str, PathLike)):
        raise InputError(problem("arguments", "path", not_a_path(kind, path)))


def read_document(path: str | PathLike[str]) -> dict[str, Any]:
    """Parse a YAML or JSON file into Python data; malformed files raise one-line errors.

    Refused by name: files that are not UTF-8, too large or nested too deeply, duplicate keys,
    and YAML 1.1 readings that surprise (``0100`` as octal 64, ``yes``/``on`` as true): see
    :mod:`ecostudy.io.yamlsafe`."""
    path = Path(path)
    if not path.is_file():
        raise InputError(problem(path, "", not_a_file(path)))
    if path.stat().st_size > MAX_FILE_BYTES:
        raise InputError(problem(path, "", f"file of {path.stat().st_size / 1e6:.0f} MB is larger than the "
                                 f"{MAX_FILE_BYTES / 1e6:.0f} MB ecostudy reads"))
    try:
        text = path.read_bytes().decode("utf-8-sig")  # a byte order mark (Windows editors) is dropped
    except UnicodeDecodeError as exc:
        raise InputError(problem(path, "", f"not UTF-8 text (byte {exc.start}: {exc.reason})"))
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(text, object_pairs_hook=unique_keys)
        else:
            data = load_yaml(text)
        check_depth(data)
    except (DocumentError, RecursionError) as exc:
        message = str(exc) if isinstance(exc, DocumentError) else f"nested more than {MAX_DEPTH} levels deep"
        raise InputError(problem(path, getattr(exc, "field", ""), message))
    except json.JSONDecodeError as exc:
        raise InputError(problem(path, "", f"malformed JSON at line {exc.lineno} column {exc.colno}: {exc.msg}"))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1} column {mark.column + 1}" if mark else ""
        raise InputError(problem(path, "", f"malformed YAML{where}: {getattr(exc, 'problem', exc)}"))
    if not isinstance(data, dict):
        kind = path.suffix.lower()
        hint = "" if kind in (".yaml", ".yml", ".json") else f" (this file is read as YAML or JSON, not {kind or 'text'})"
        raise InputError(problem(path, "", f"expected a mapping of fields at the top level{hint}"))
    return data


def _field_path(loc: Sequence[int | str]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


# difflib's similarity at or above which an unknown field is taken for a known one misspelt
# (tracks 0.91, power_sampling_mode 0.85, start_position_km 0.97, speed_sigma 0.85; vehicle,
# train_id 0.77, source_file 0.71 are not)
NEAR_MISS = 0.8


def _near(schema: type[BaseModel], loc: Sequence[object], data: object) -> list[str]:
    """The fields of ``schema`` the document does not give that the unknown top-level field at
    ``loc`` is taken for: a near miss (:data:`NEAR_MISS`), or the same name in another unit
    (``mass_kg`` for ``mass_t``: equal but for the part after the last underscore)."""
    if len(loc) != 1 or not isinstance(data, Mapping):
        return []
    given, names = str(loc[0]), sorted(_names(schema))
    stem = given.rpartition("_")[0]
    near = difflib.get_close_matches(given, names, n=3, cutoff=NEAR_MISS)
    near += [k for k in names if stem and k.rpartition("_")[0] == stem and k not in near]
    return [k for k in near if k not in data]


def _near_miss(schema: type[BaseModel], loc: Sequence[object], data: object) -> str:
    """'; did you mean X?' for the fields :func:`_near` finds, with the unit X is in where only the
    unit differs ('; did you mean mass_t (in t, not kg)?'); else ''."""
    given = str(loc[0]) if loc else ""
    said = [k + (f" (in {k.rpartition('_')[2]}, not {given.rpartition('_')[2]})"
                 if given.rpartition("_")[0] and k.rpartition("_")[0] == given.rpartition("_")[0] else "")
            for k in _near(schema, loc, data)]
    return f"; did you mean {' or '.join(said)}?" if said else ""


def _names(schema: type[BaseModel]) -> set[str]:
    """The top-level field names of ``schema`` as a file spells them (aliases too)."""
    names = set(schema.model_fields)
    for f in schema.model_fields.values():
        if f.alias:
            names.add(f.alias)
    return names


def _file_kinds() -> dict[str, type[BaseModel]]:
    """Every whole-file schema imported, by its ``file_kind`` (``io.schemabase.Strict``)."""
    kinds: dict[str, type[BaseModel]] = {}
    todo: list[type[Strict]] = list(Strict.__subclasses__())
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        if cls.file_kind:
            kinds[cls.file_kind] = cls
    return kinds


def _other_kind(schema: type[BaseModel], data: object, exc: ValidationError) -> str:
    """'a track file (stops, gradients), not a train file' when ``data`` misses fields ``schema``
    requires and every field it gives that ``schema`` does not know is a field of one other kind of
    file (a track file named where a train file is meant); else ''."""
    own = getattr(schema, "file_kind", None)
    if not own or not isinstance(data, Mapping) or not any(e["type"] == "missing" for e in exc.errors()):
        return ""
    keys = {str(k) for k in data}
    foreign = sorted(keys - _names(schema))
    if not foreign:
        return ""
    kinds = [kind for kind, cls in _file_kinds().items() if cls is not schema and keys <= _names(cls)]
    if len(kinds) != 1:
        return ""
    return f"{_article(kinds[0])} {kinds[0]} file ({', '.join(foreign)}), not {_article(own)} {own} file"


def _article(word: str) -> str:
    return "an" if word[0] in "aeiou" else "a"


def validate(schema: type[Model], data: object, path: str | PathLike[str],
             aliases: Mapping[str, str] | None = None) -> Model:
    """Validate ``data`` against a schema; every pydantic error becomes one problem line.
    ``aliases`` maps a schema field path to the name the file gives it (a TTOBench key)."""
    try:
        return schema.model_validate(data)
    except ValidationError as exc:
        other = _other_kind(schema, data, exc)
        if other:  # a whole file of another kind: one line, not one per field
            raise InputError(problem(path, "", other)) from None
        lines: list[str] = []
        errors = exc.errors()
        meant = {k for err in errors if err["type"] == "extra_forbidden" for k in _near(schema, err["loc"], data)}
        for err in errors:
            loc = [p for p in err["loc"] if not (isinstance(p, str) and p.startswith("function-"))]
            if err["type"] == "missing" and len(loc) == 1 and loc[0] in meant:
                continue  # said with the unknown field taken for it: one line for one slip
            msg = err["msg"].removeprefix("Value error, ")
            if err["type"] == "extra_forbidden":
                msg = "unknown field" + _near_miss(schema, loc, data)
            elif err["type"] == "missing":
                msg = "missing field"
            field = _field_path(loc) or "(top level)"
            head, _, rest = msg.partition(": ")
            if not loc and rest and head.split("[")[0].split(".")[0] in _names(schema):  # a check across fields naming its field
                field, msg = head, rest
            lines.append(problem(path, aliased(field, aliases or {}), _INDEXED.sub(
                lambda m: aliased(m.group(0), aliases or {}), msg)))  # another row it names, named as the file does
        raise InputError(lines)


_INDEXED = re.compile(r"\b[a-z_]+(?:\[\d+\])+(?:\.[a-z_0-9A-Z]+)?")  # a schema field with its index: speed_limits[1]


def aliased(field: str, aliases: Mapping[str, str]) -> str:
    """``field`` (a schema path, ``speed_limits[1].speed_kmh``) as the file names it: ``aliases`` maps a
    schema path, or one with its indices left out (``speed_limits[].speed_kmh``: ``speed limits.values[].velocity``,
    the indices put back in order), to the file's name; else the field itself. Fields joined by
    ", " (``stops[0].departure_s, stops[1].latest_s``) are each named so, each name once."""
    if ", " in field:
        return ", ".join(dict.fromkeys(aliased(f, aliases) for f in field.split(", ")))
    if field in aliases:
        return aliases[field]
    key = re.sub(r"\[\d+\]", "[]", field)
    if key not in aliases:
        return field
    name = aliases[key]
    for index in re.findall(r"\[\d+\]", field):
        name = name.replace("[]", index, 1)
    return name
