"""Study files expanded into cases: self-contained tasks keyed by a hash of their inputs.

A case carries the train and track documents themselves (not paths), the stops, the timing,
objective and grid. Its key is a hash of all of that and of the code (:func:`case_key`), so a
result stored under a key is valid for exactly those inputs and that code, on any worker, and a
rerun after a change of any input (or of ecostudy) recomputes only the cases it affects.
"""
import functools
import hashlib
import itertools
import json
import warnings
from collections.abc import Mapping
from pathlib import Path

from ecostudy.io.writers import default_output
from ecostudy import __version__
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.grid import too_long_named
from ecostudy.io import schemas
from ecostudy.io.documents import named_file, overlaid, split_selector
from ecostudy.io.timetable import segment_timing
from ecostudy.io.loaders import (
    chosen_stops,
    load_timetable,
    load_study,
    read_document,
    read_track,
    read_train,
    train_from_schema,
    validate,
)
from ecostudy.studies.library import library_units


def source_fingerprint(root):
    """12 hex digits of the SHA-256 of every ``.py`` file under ``root`` (names and contents, in
    sorted order): any change to the code gives another fingerprint."""
    digest = hashlib.sha256()
    for file in sorted(Path(root).rglob("*.py")):
        digest.update(file.relative_to(root).as_posix().encode() + b"\0" + file.read_bytes() + b"\0")
    return digest.hexdigest()[:12]


@functools.cache
def code_version():
    """The code a result is computed by: ecostudy's version and the fingerprint of its source
    (``0.2.0+3f9a1c0b7d2e``). Being part of every case's key (:func:`case_key`), it keeps a study
    from resuming with results stored by other code, whose checks and statuses may differ."""
    return f"{__version__}+{source_fingerprint(Path(__file__).resolve().parents[1])}"


def case_key(case):
    """16 hex digits of the SHA-256 of the case's inputs (everything but its key and labels) and of
    the code that computes it (:func:`code_version`): the one place a key is made, for every kind."""
    payload = [code_version(), {k: v for k, v in case.items() if k not in ("key", "labels")}]
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:16]


class Files:
    """``read(file, reader)``: each train and track file of a study read once by each reader
    (``reader``: :func:`~ecostudy.io.loaders.read_train` or :func:`~ecostudy.io.loaders.read_track`;
    one path given as both is read as both, and the wrong one refused), its warnings shown then;
    ``said[file, reader]``: what it warned of (after its name), which a scenario overriding its
    fields does not repeat."""

    def __init__(self):
        self.read, self.said = {}, {}

    def __call__(self, file, reader):
        if (file, reader) not in self.read:
            with warnings.catch_warnings(record=True) as seen:
                warnings.simplefilter("always")
                self.read[file, reader] = reader(file)
            for w in seen:
                warnings.warn(w.message, w.category, stacklevel=2)
            self.said[file, reader] = {str(w.message).removeprefix(f"{split_selector(file)[0]}: ") for w in seen}
        return self.read[file, reader]


MERGED = ("(train_overrides merge a block into the train file's field by field: to give it another form, set "
          "the file's other fields of it to null, e.g. traction: {table: null, max_force_kN: 150})")


def _overridden(train_doc, where, said, blocks):
    """The train of a scenario's train document, its overrides laid over its file's (``where`` names
    the scenario), warning of what they change: the warnings of its train that its file (``said``) did
    not give. A train the overrides make invalid is refused; where they give a block (``blocks``), the
    line says how one is merged."""
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        try:
            train = train_from_schema(validate(schemas.TrainFile, train_doc, f"{where} train"), where)
        except InputError as exc:
            if not blocks:
                raise
            raise InputError([*exc.problems[:-1], f"{exc.problems[-1]} {MERGED}"]) from None
    for w in seen:
        if str(w.message).removeprefix(f"{where}: ") not in said:
            warnings.warn(w.message, w.category, stacklevel=3)
    return train


def _scenario_units(s, path, read):
    """(name, labels, train document, track document, from, to, scenario) of each scenario, each file
    read once by ``read`` (:class:`Files`)."""
    for i, sc in enumerate([schemas.Scenario(name="base")] + list(s.scenarios)):
        where = f"{path}: scenarios[{i - 1}] ({sc.name})" if i else str(path)
        field = f"scenarios[{i - 1}]." if i else ""
        train_file = named_file(path, field + "train" if sc.train else "train", sc.train or s.train)
        train_doc, train = read(train_file, read_train)
        track_doc, track = read(named_file(path, field + "track" if sc.track else "track", sc.track or s.track),
                                read_track)
        if sc.train_overrides:
            train_doc = overlaid(train_doc, sc.train_overrides)
            train = _overridden(train_doc, where, read.said[train_file, read_train],
                                any(isinstance(v, Mapping) for v in sc.train_overrides.values()))
        too = too_long_named(train, track)  # refused here, before any case of the study is computed
        if too is not None:
            given = "train_overrides.length_m" if "length_m" in (sc.train_overrides or {}) else "train"
            raise InputError(problem(path, field + given, (f"scenario '{sc.name}': " if i else "") + too))
        from_stop, to_stop = chosen_stops(track, s.from_stop, s.to_stop, path)
        yield sc.name, {"scenario": sc.name}, train_doc, track_doc, from_stop, to_stop, sc


def expand(path, skipped=None, read=None, windows=False, warn=True):
    """(study schema, output folder, cases) for a study file; inputs are validated here, once.
    A library study's pairs left out are appended to ``skipped`` (track, train, reason); ``read``:
    the :class:`Files` of the study, when its base case was read before; ``windows``: whether the
    command keeps the timing windows on the way (``solve``), else they are refused (``run``)."""
    path = Path(path)
    s = validate(schemas.StudyFile, read_document(path), path)
    if not windows:
        refuse_windows(path, {"windows": s.windows}, "`ecostudy run`")
    base = path.parent
    sweep = s.sweep.model_dump(exclude_none=True) if s.sweep else {}
    if s.library is not None:
        units, left_out = library_units(s.library, base, path)
        units = [u + (schemas.Scenario(name=u[0]),) for u in units]
        if not units:
            why = ("every track and train pair is left out (" + "; ".join(
                f"{x['track']}/{x['train']}: {x['reason']}" for x in left_out[:3])
                + (f"; and {len(left_out) - 3} more" if len(left_out) > 3 else "")
                + "): choose other tracks or trains, or lower min_speed_share") if left_out else \
                "its tracks/ or trains/ folder holds no .json file"
            raise InputError(problem(path, "library", f"no case to run: {why}"))
        if skipped is not None:
            skipped.extend(left_out)
    else:
        units = _scenario_units(s, path, read or Files())
    cases, keys, fastest = [], set(), {}
    for name, labels, train_doc, track_doc, from_stop, to_stop, sc in units:
        timing = {"running_time_s": s.running_time_s, "supplement_percent": s.supplement_percent,
                  "window_s": list(s.window_s) if s.window_s else None}
        if s.timetable is not None:
            timetable = named_file(path, "timetable", s.timetable)
            t, passing = segment_timing(load_timetable(timetable), from_stop, to_stop, timetable)
            if not windows:
                refuse_windows(timetable, {"windows": passing}, "`ecostudy run`")
            timing = {"running_time_s": t.running_time, "window_s": list(t.window) if t.window else None,
                      "supplement_percent": None if t.supplement is None else 100 * t.supplement}
        for field in ("running_time_s", "supplement_percent"):
            if getattr(sc, field) is not None:
                timing = {"running_time_s": None, "supplement_percent": None, "window_s": None,
                          field: getattr(sc, field)}
        common = {"study": s.name, "scenario": name, "train": train_doc, "track": track_doc,
                  "from": from_stop, "to": to_stop, **timing, "objective": sc.objective or s.objective,
                  "weights": [s.weights.time, s.weights.energy], "points": sc.points or s.points}
        names = list(sweep)
        for values in itertools.product(*(sweep[n] for n in names)) if names else [()]:
            case = dict(common)
            for n, v in zip(names, values):
                if n in ("running_time_s", "supplement_percent"):
                    case.update(running_time_s=None, supplement_percent=None, window_s=None)
                case[n] = v
            timed = [k for k in ("running_time_s", "supplement_percent", "window_s") if case[k] is not None]
            if case["objective"] == "time" and timed:  # the fastest run keeps no running time: not read as kept
                fastest.setdefault(f"scenario '{name}': objective 'time' finds the fastest run: its "
                                   f"{', '.join(timed)} does not apply (left out)", None)
                case.update(running_time_s=None, supplement_percent=None, window_s=None)
            if case["objective"] not in ("time", "mixed") and not any(
                    case[k] is not None for k in ("running_time_s", "supplement_percent", "window_s")):
                raise InputError(problem(path, "running_time_s", f"scenario '{name}' has no running time, "
                                         "supplement, window or timetable"))
            fixed = [k for k in ("running_time_s", "supplement_percent") if case[k] is not None]
            refuse_mixed_fixed(case["objective"], fixed and f"{fixed[0]} ({case[fixed[0]]:g})", path,
                               "sweep.objective" if "objective" in names else
                               f"scenarios[{s.scenarios.index(sc)}].objective" if sc.objective else "objective")
            refuse_mixed_weights(case["objective"], case["weights"], case["window_s"] is not None, path,
                                 ("weights.time", "weights.energy"))
            das = sc.das or s.das  # every objective's run is advised, as `ecostudy solve --das` advises it
            if das is not None:  # the all-out run's advice: the least energy a driver keeps its time with
                case.update(das=das, das_time_limit_s=s.das_time_limit_s)  # only then: other keys unchanged
            case["labels"] = {**labels, **{n: (None if case[n] is None and n in timed else v)
                                           for n, v in zip(names, values)}}
            case["key"] = case_key(case)
            if case["key"] not in keys:  # the fastest run once, whatever running times are swept beside it
                keys.add(case["key"])
                cases.append(case)
    idle = [name for name, used in (("weights", any(c["objective"] == "mixed" for c in cases)),
                                     ("das_time_limit_s", any(c.get("das") == "minlp" for c in cases)))
            if not used and name in s.model_fields_set]  # given, even as its default
    notes = [("objective", line) for line in fastest] + [
        (name, "read but not used: no case " + ("has objective mixed" if name == "weights" else "has das: minlp"))
        for name in idle]
    for field, line in notes if warn else ():
        warnings.warn(problem(path, field, line), EcostudyWarning, stacklevel=2)
    output = Path(s.output) if s.output else default_output(s.name)
    return s, output, cases


# the fields of a study file each base-case command reads but does not use (``run`` uses them all)
UNUSED = {"solve": ("das", "das_time_limit_s", "scenarios", "sweep"),
          "compare": ("objective", "weights", "das", "das_time_limit_s", "scenarios", "sweep"),
          "pareto": ("objective", "weights", "das", "das_time_limit_s", "scenarios", "sweep")}  # its timing: a point
WHO = {"solve": "`ecostudy solve`", "compare": "`ecostudy compare` (or `run --kind compare`)",
       "pareto": "`ecostudy pareto` (or `run --kind pareto`)"}


def refuse_mixed_fixed(objective, fixed, where, field):
    """Refuse the mixed objective w_t T + w_e E / Ms (Yazhemsky 2017 eq. 4.1a) on a run whose running
    time ``fixed`` (what fixes it: an option or a field; None: nothing) fixes: its time term is then a
    constant, so its weights change nothing (the energy optimum), or leave no objective at all (an
    energy weight of 0). An arrival window, or no running time, leaves the time free to weigh."""
    if objective == "mixed" and fixed:
        raise InputError(problem(where, field, f"mixed weighs the running time against energy, but {fixed} fixes the "
                                 "running time: the weights would change nothing (the energy optimum; with an energy "
                                 "weight of 0, no optimum at all): use objective energy, or an arrival window or no "
                                 "running time for the weights to act"))


def refuse_mixed_weights(objective, weights, timed, where, fields):
    """Refuse, before computing, mixed weights (w_t, w_e) with which no run can be ok: both 0; an energy
    weight of 0 leaves the running time alone to minimise, without the all-out run's regularisation
    (``--objective time``: traction and braking at once, flagged at -31 % energy error); a time
    weight of 0 with no arrival window (``timed``: False) the least energy, a crawl of days.
    ``fields``: how the time and the energy weight are named in ``where``."""
    if objective != "mixed":
        return
    if weights[0] == weights[1] == 0:  # as the command line refuses --weights 0,0
        raise InputError(problem(where, fields[0].split(".")[0], "must be two weights >= 0, not both 0 (the objective "
                                 "would weigh nothing)"))
    if weights[1] == 0:
        raise InputError(problem(where, fields[1], "an energy weight of 0 leaves the running time alone to minimise, "
                                 "without the all-out run's regularisation (traction and braking at once): use objective "
                                 "time for the fastest run"))
    if weights[0] == 0 and not timed:
        raise InputError(problem(where, fields[0], "a time weight of 0 with no running time leaves the least energy "
                                 "run free to crawl (days): give a positive time weight, or an arrival window"))


WINDOW_KINDS = {"windows": "timing windows on the way", "window_s": "an arrival window"}


def refuse_windows(path, given, who):
    """Refuse a study's (file ``path``) timing windows where ``who`` would ignore them (``given``:
    {field: its value}; the fields given are named)."""
    fields = [name for name, value in given.items() if value]
    if fields:
        what = " or ".join(WINDOW_KINDS.get(name, name) for name in fields)
        raise InputError(problem(path, ", ".join(fields), f"{who} does not keep {what} yet; use "
                                 "`ecostudy solve` (or remove them)"))


def load_checked_study(path, command=None):
    """:func:`~ecostudy.io.loaders.load_study` (the base case), after every scenario and sweep value of
    the file is checked as ``ecostudy run`` checks them (:func:`expand`): a command that runs only the
    base case never leaves a bad scenario unnoticed. For ``command`` (a key of :data:`UNUSED`), one
    warning names the fields the file gives (other than their defaults) that the command does not use."""
    read = Files()  # each file read once, for the base case and the study's cases
    study = load_study(path, read)
    s = expand(path, read=read, windows=True, warn=False)[0]  # the file as validated there (its cases' warnings are run's)
    if command is not None:
        if command not in UNUSED:  # a new command or study kind that reads a base case: its author's step
            raise ValueError(f"load_checked_study: {command!r} has no entry in studies.cases.UNUSED (the study fields "
                             f"it does not use) and WHO (how a warning names it); add both (docs/architecture.md)")
        fields = schemas.StudyFile.model_fields
        unused = [name for name in UNUSED[command]  # given, and not the value the command uses anyway
                  if getattr(s, name) != fields[name].get_default(call_default_factory=True)]
        if unused:
            warnings.warn(problem(path, ", ".join(unused), f"read but not used by {WHO[command]}, which runs the "
                                  "study's base case with its own options; `ecostudy run` of its cases uses them"),
                          EcostudyWarning, stacklevel=2)
    return study
