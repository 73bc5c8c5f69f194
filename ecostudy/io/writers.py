"""Writing results: every file goes to a temporary name first and is renamed into place."""
import errno
import fcntl
import json
import math
import os
import re
import tempfile
from pathlib import Path
from typing import Any, Callable, Iterable, Union

import pandas as pd

from ecostudy.core.errors import InputError, problem
from ecostudy.core.interrupt import held


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


FILE_MODE = 0o666 & ~_umask()  # what open() would give: the user's umask, not mkstemp's 0600


SUMMARY = "summary.json"  # every output folder's (:mod:`ecostudy.io.folder`)
REPORT = "report.html"  # written beside it by ``report.html.write_html``


STORE = "results.sqlite"  # a study's store: a folder holding one is a study's, resumable before its summary
LOCK = STORE + ".lock"  # beside it while a study writes the folder (``io.store``)

# the hidden temporary files of :func:`atomic_write` (``.NAME`` + tempfile's 8 random characters + ``.tmp``)
# and of :func:`check_output_dir`'s probe: one that a command killed (SIGKILL, a power cut) left is removed
# by the next command that writes the folder (:func:`remove_temporary`)
TEMPORARY = re.compile(r"\.(?:write-test|.+\.[A-Za-z0-9]+)[a-z0-9_]{8}\.tmp")
SUBFOLDERS = ("steps",)  # the folders commands write inside an output folder (a closed-loop study's steps/)


# the commands that write an output folder, by the kind their summary.json gives; a study kind registered
# beyond them runs as ``ecostudy run --kind KIND`` (tests/test_study_kinds.py checks these against the CLI)
COMMANDS = frozenset({"solve", "pareto", "compare", "journey", "network", "simulate", "heavyhaul", "calibrate",
                      "validate", "run"})


def command_of(kind: str) -> str:
    """How a user runs the command or study kind ``kind``: ``ecostudy pareto``, ``ecostudy run --kind X``."""
    return f"ecostudy {kind}" if kind in COMMANDS else f"ecostudy run --kind {kind}"


def _kind_of(folder: Path) -> str | None:
    """The ``kind`` in a folder's summary.json, None where there is none or it cannot be read."""
    try:
        data = json.loads((folder / SUMMARY).read_text())
    except (OSError, ValueError):
        return None
    kind = data.get("kind") if isinstance(data, dict) else None
    return kind if isinstance(kind, str) else None


def default_output(name: str) -> Path:
    """``out/<name>``, the folder a command writes to when neither ``--out`` nor the study file's
    ``output`` says where: ``name`` (a study's name, or track and stop names) made a single folder
    name of letters, digits, '.', '_' and '-' (a stop named '/../../x' wrote outside ``out/``, a
    '/' in a name made nested folders)."""
    safe = re.sub(r"[^\w.-]+", "_", str(name)).strip("._") or "run"
    return Path("out") / safe


def check_name_length(path: Union[str, Path], option: str = "") -> None:
    """Refuse a path the system cannot look up because a name in it, or the whole of it, is longer
    than the file system allows (ENAMETOOLONG, which ``Path.exists`` and ``is_dir`` raise): one line
    naming ``option`` (``--out``; :func:`name_too_long`), exit 2."""
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise InputError(name_too_long(path, option)) from None


def name_too_long(path: Union[str, Path], option: str = "") -> str:
    """The line of a ``path`` too long to look up: shown shortened, with its longest name's length."""
    text = str(path)
    longest = max((len(os.fsencode(name)) for name in Path(text).parts), default=0)
    return problem(text if len(text) <= 80 else f"{text[:60]}...{text[-12:]}", option, f"File name too long: its "
                   f"longest name is {longest} bytes (the path {len(os.fsencode(text))}), more than the file system "
                   "allows; give a shorter one")


def check_output_dir(path: Union[str, Path], files: Iterable[str] = (), kind: str | None = None) -> Path:
    """Refuse, before any computation, an output folder that is a file, cannot be created or
    written, or holds a folder where one of ``files`` (or :data:`SUMMARY`, :data:`REPORT`) goes, or
    (``kind`` given) holds the results
    of another kind of command (its ``summary.json``'s ``kind``: this command's tables and
    summary would be written beside the other's, and read as one): one line naming it (exit 2). The
    folders this check creates to try are removed again: a command refused later (an infeasible
    running time) leaves nothing behind; the first file written creates the folder
    (:func:`atomic_write`, the store). A folder accepted loses the temporary files a killed command
    left (:func:`remove_temporary`), unless the command keeps a store there (``files`` names
    :data:`STORE`: the store removes them once it holds the folder's lock) or a study holds it now. A
    command that keeps no store is refused while a study writes the folder (its lock held)."""
    path = Path(path)
    check_name_length(path, "--out")
    if path.exists() and not path.is_dir():
        raise InputError(problem(path, "", "the output folder is a file"))
    for name in (*files, SUMMARY, REPORT):
        if (path / name).is_dir():
            raise InputError(problem(path / name, "", "is a folder where an output file goes"))
    other = _kind_of(path)
    if kind is not None and other is not None and other != kind:
        raise InputError(problem(path, "--out", f"holds the results of `{command_of(other)}` (its summary.json), "
                                 f"not of `{command_of(kind)}`: give another --out, or remove the folder"))
    theirs = sorted({n for n in (*files, SUMMARY, REPORT) if (path / n).is_file()})
    if kind is not None and other is None and theirs and not (path / STORE).is_file():  # no ecostudy folder
        raise InputError(problem(path, "--out", f"holds {', '.join(theirs)} that no ecostudy command wrote (no "
                                 "summary.json naming one): this command would replace them; give another --out, "
                                 "or remove them"))
    created = [p for p in (path, *path.parents) if not p.exists()]  # deepest first
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".write-test", suffix=".tmp", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(problem(path, "", f"cannot write the output folder ({exc.strerror})"))
    finally:
        for level in created:
            try:
                level.rmdir()
            except OSError:  # not made here after all, or something came into it meanwhile
                break
    if STORE not in files and (path / LOCK).exists() and locked_by_another(path / LOCK):
        raise InputError(problem(path, "--out", "another ecostudy command is writing this folder: wait for it to "
                                 "finish, or give another --out"))
    if STORE not in files and not (path / LOCK).exists():
        remove_temporary(path)
    return path


def locked_by_another(lock: Path) -> bool:
    """Whether a study's lock file (:data:`LOCK`, ``io.store``) is held now: by another process, for a
    command that keeps no store and so holds none itself (a lock left by a killed run is free)."""
    try:
        with open(lock, "r") as probe:
            try:
                fcntl.flock(probe, fcntl.LOCK_SH | fcntl.LOCK_NB)
            except BlockingIOError:
                return True
            return False  # closing the file lets go of the shared lock at once
    except OSError:  # removed meanwhile: the run finished
        return False


def remove_temporary(folder: Union[str, Path]) -> None:
    """Remove the hidden temporary files (:data:`TEMPORARY`) that a command killed while writing
    left in ``folder`` and its :data:`SUBFOLDERS`; every other file stays. Called as a command
    starts writing the folder, when no other ecostudy command writes it."""
    for where in (Path(folder), *(Path(folder) / name for name in SUBFOLDERS)):
        try:
            entries = list(os.scandir(where))
        except OSError:  # no such folder (yet)
            continue
        for entry in entries:
            if TEMPORARY.fullmatch(entry.name) and entry.is_file(follow_symlinks=False):
                Path(entry.path).unlink(missing_ok=True)


def atomic_write(path: Union[str, Path], write: Callable[[str], Any]) -> None:
    """Call ``write(tmp_path)`` then rename onto ``path``: readers never see half a file. The
    temporary file (``.NAME<random>.tmp`` beside ``path``) is gone however the write ends, stopped
    by SIGINT or SIGTERM too: a signal while it is created is raised once its name is known
    (:func:`~ecostudy.core.interrupt.held`), and its removal comes before any call of Python code,
    where a signal that came meanwhile is raised."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = ""
    try:
        with held([]):
            fd, tmp = tempfile.mkstemp(prefix="." + path.name, suffix=".tmp", dir=path.parent)
            os.close(fd)
        write(tmp)
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, path)
    finally:
        if tmp:
            try:
                os.unlink(tmp)
            except FileNotFoundError:  # renamed into place
                pass


def _clean(obj: Any) -> Any:
    """JSON-safe copy: NaN/inf -> None, numpy scalars -> Python numbers."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, "item"):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_json(path: Union[str, Path], data: Any) -> None:
    def write(tmp: str) -> None:
        with open(tmp, "w") as fh:
            json.dump(_clean(data), fh, indent=2)
            fh.write("\n")
    atomic_write(path, write)


def write_csv(path: Union[str, Path], frame: pd.DataFrame) -> None:
    atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))


