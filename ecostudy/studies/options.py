"""A command's options checked and expanded before anything is computed: numeric ranges, pairs
'a,b', options that exclude each other, the case a study file or ``--track``/``--train`` give.

Every refusal is one line naming ``command line`` and the option (exit status 2, as a bad field of
an input file); the functions of :mod:`ecostudy.api` call them first.
"""
import math
import numbers
import os
import re
import socket
import warnings
from pathlib import Path
from typing import Any, Mapping, NamedTuple, Optional, Sequence, get_args

from ecostudy.core import units
from ecostudy.core.defaults import DAS_TIME_LIMIT_S, MAX_SUPPLEMENT_PERCENT
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.types import Timing, Track, Train
from ecostudy.io.documents import not_a_file, not_a_path, split_selector
from ecostudy.io.loaders import check_fits, chosen_stops, read_track, read_train
from ecostudy.io.schemas import StudyFile
from ecostudy.studies.cases import load_checked_study, refuse_windows

# the ranges of numeric options: the same as the study schema's where a field exists (io/schemas.py);
# (lowest, highest, lowest allowed itself)
OPTION_RANGES = {
    "points": (10, 100000, True), "workers": (1, 256, True), "count": (2, 10000, True),
    "weighted": (0, 1000, True), "time": (0.0, None, False), "supplement": (0.0, MAX_SUPPLEMENT_PERCENT, True),
    "supplement_max": (0.0, MAX_SUPPLEMENT_PERCENT, False), "dwell": (0.0, 86400.0, True),
    "das_time_limit": (0.0, None, False),
    "energy_tolerance": (0.0, 1000.0, True), "time_tolerance": (0.0, 1000.0, True),  # validate's [%]
    "bootstrap": (0, 10000, True), "savings": (0, 100, True),  # calibrate's draws
}


def check_choices(files: Mapping[str, Any] | None = None, **choices: tuple[Any, Sequence[str]]) -> None:
    """Refuse, before anything is read or solved, a choice ``name=(value, allowed)`` that is not one
    of its ``allowed`` words (None: not given) and a file option (``files``: name -> value) that is
    not a path (a loaded Train where its file belongs, say): one line each, naming the option as the
    command line spells it (the Python API renames them to its arguments)."""
    lines = [problem("command line", f"--{name.replace('_', '-')}", f"expected one of {', '.join(allowed)}, not "
                     f"{value!r}") for name, (value, allowed) in choices.items() if value is not None and value not in allowed]
    lines += [problem("command line", f"--{name}", not_a_path(name, value))
              for name, value in (files or {}).items() if value is not None and not isinstance(value, (str, os.PathLike))]
    if lines:
        raise InputError(lines)


def das_limit(das: Optional[str], das_time_limit: Optional[float]) -> float:
    """The MINLP search's time limit [s]: ``--das-time-limit`` or :data:`DAS_TIME_LIMIT_S`; given for
    advice other than ``minlp`` (or none), warned of as unused."""
    if das_time_limit is None:
        return DAS_TIME_LIMIT_S
    if das != "minlp":
        warnings.warn(problem("command line", "--das-time-limit", "bounds the minlp search only: unused with "
                              + (f"--das {das}" if das else "no --das: give it with --das minlp")), EcostudyWarning, stacklevel=3)
    return float(das_time_limit)


OBJECTIVES = get_args(StudyFile.model_fields["objective"].annotation)  # energy, net_energy, time, mixed


DASK_ADDRESS = re.compile(r"(tcp|tls|ucx)://[^\s:/]+:\d{1,5}")  # a Dask scheduler's address


DASK_CONNECT_S = 5.0  # how long a scheduler's address is tried before the command computes anything


def unreachable(address: str) -> Optional[str]:
    """Why nothing answers at the Dask scheduler ``address`` (tcp://host:port), or None: a TCP
    connection tried once, before a study computes anything (a network study's first runs took
    minutes before Dask's own client found the address dead)."""
    host, port = address.split("://", 1)[1].rsplit(":", 1)
    try:
        socket.create_connection((host, int(port)), timeout=DASK_CONNECT_S).close()
    except OSError as exc:
        return f"cannot reach the Dask scheduler at {address} ({exc})"
    return None


def check_options(*, where: str = "command line", spelled: Optional[Mapping[str, str]] = None,
                  dask: Optional[str] = None, **values: Any) -> None:
    """Refuse numeric options that are not numbers, not finite or out of their range
    (:data:`OPTION_RANGES`), and a ``dask`` that is not a scheduler address (:data:`DASK_ADDRESS`):
    one line each, naming the option, before anything is computed or written (exit status 2).
    ``where`` and ``spelled`` (range name -> the name a caller gives it) name them as the Python API
    does (``arguments: running_time: ...``)."""
    lines = []
    if dask is not None and not (isinstance(dask, str) and DASK_ADDRESS.fullmatch(dask)
                                 and int(dask.rsplit(":", 1)[1]) <= 65535):
        option = spelled.get("dask", "dask") if spelled is not None else "--dask"
        lines.append(problem(where, option, f"expected a scheduler address tcp://host:port, got {dask!r}"))
    elif dask is not None and (trouble := unreachable(dask)) is not None:
        lines.append(problem(where, spelled.get("dask", "dask") if spelled is not None else "--dask", trouble))
    for name, value in values.items():
        if value is None:
            continue
        option = spelled.get(name, name) if spelled is not None else "--" + name.replace("_", "-")
        low, high, closed = OPTION_RANGES[name]
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            lines.append(problem(where, option, f"must be a number, not {value!r}"))
        elif isinstance(value, float) and not math.isfinite(value):
            lines.append(problem(where, option, f"must be a finite number, not {value}"))
        elif isinstance(low, int) and not isinstance(value, numbers.Integral):
            lines.append(problem(where, option, f"must be a whole number, not {value}"))
        elif (x := float(value)) < low or (x == low and not closed) or (high is not None and x > high):
            bound = f"at least {low}" if closed else f"more than {low}"
            lines.append(problem(where, option, f"must be {bound}" + (f" and at most {high}" if high else "")
                                 + f", not {value}"))
    if lines:
        raise InputError(lines)


def parse_pair(text: str, option: str, ordered: bool = False, nonnegative: bool = False) -> tuple[float, float]:
    """Two finite numbers 'a,b'; ``ordered``: a <= b; ``nonnegative``: both >= 0, not both 0."""
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise InputError(problem("command line", option, f"expected two numbers 'a,b', got {text!r}"))
    return checked_pair(a, b, option, ordered, nonnegative)


def checked_pair(a: float, b: float, option: str, ordered: bool = False, nonnegative: bool = False,
                 where: str = "command line") -> tuple[float, float]:
    """``(a, b)`` refused as :func:`parse_pair` refuses it, named ``where: option``."""
    text = f"{a},{b}"
    if not (isinstance(a, numbers.Real) and isinstance(b, numbers.Real) and math.isfinite(a) and math.isfinite(b)):
        raise InputError(problem(where, option, f"must be finite numbers, not '{text}'"))
    if ordered and not 0 <= a <= b:
        raise InputError(problem(where, option, f"must be 'earliest,latest' with 0 <= earliest <= latest, "
                                 f"not '{text}'"))
    if nonnegative and (a < 0 or b < 0 or a == b == 0):
        raise InputError(problem(where, option, f"must be two weights >= 0, not both 0, not '{text}'"))
    return float(a), float(b)


def only_one(**options: Any) -> None:
    """Refuse two options that each set the same thing (one would be ignored)."""
    given = ["--" + name.replace("_", "-") for name, value in options.items() if value is not None]
    if len(given) > 1:
        raise InputError(problem("command line", "/".join(given), "give only one: each sets the running time"))


def no_windows(st: Any, command: str, path: Any) -> None:
    """Refuse a study's (file ``path``) timing windows where ``command`` would ignore them."""
    if st is not None:
        refuse_windows(path, {"windows": st.windows, "window_s": st.timing.window}, command)


class Case(NamedTuple):
    """One run's inputs as a command gives them: a study file or ``--track``/``--train``."""

    track: Track
    train: Train
    from_stop: str
    to_stop: str
    points: Optional[int]
    study: Any  # the loaded study file, or None
    documents: tuple[Any, ...]  # (train, track) as their files give them


def no_stops_with_study(from_stop: Optional[str], to_stop: Optional[str]) -> None:
    """Refuse ``--from``/``--to`` beside a study file: its stops and its timing for them (a running time,
    a timetable's times between those stops) come together from the file."""
    given = [name for name, value in (("--from", from_stop), ("--to", to_stop)) if value is not None]
    if given:
        raise InputError(problem("command line", "/".join(given), "a study file sets its stops (from:, to:) and "
                                 "its timing for them: edit the study, or give --track and --train"))


def case_from(study: Optional[Path], track: Optional[Path], train: Optional[Path], from_stop: Optional[str],
              to_stop: Optional[str], points: Optional[int], command: Optional[str] = None) -> Case:
    """The case of a study file (``points`` overrides its K; the fields ``command`` does not use named
    in a warning) or of a track and a train file."""
    if study is not None:
        if track or train:
            raise InputError(problem("command line", "--track/--train",
                                     "give a study file or --track and --train, not both"))
        no_stops_with_study(from_stop, to_stop)
        st = load_checked_study(study, command)
        return Case(st.track, st.train, st.from_stop, st.to_stop, points or st.points, st, st.documents)
    if not (track and train):
        raise InputError(problem("command line", "--track/--train", "give a study file, or both --track and --train"))
    for option, path in (("--track", track), ("--train", train)):  # the option that names a file not there
        file = split_selector(path)[0]
        if not file.is_file():
            raise InputError(problem("command line", option, f"{path}: {not_a_file(file)}"))
    (trk_doc, trk), (trn_doc, trn) = read_track(track), read_train(train)  # each file once
    check_fits(train, trn, trk)
    f, t = chosen_stops(trk, from_stop, to_stop, "command line", ("--from", "--to"))
    return Case(trk, trn, f, t, points, None, (trn_doc, trk_doc))


def study_name(st, command: str, track: Optional[Path], train: Optional[Path], from_stop: str, to_stop: str) -> str:
    """The name a ``command``'s cases carry as their study: a study file's ``name``, else (built
    from --track and --train) the command, the two files resolved and the stops: another segment is
    another study, whose folder is refused (:func:`~ecostudy.io.store.check_one_study`)."""
    if st is not None:
        return st.name
    return f"{command} of {Path(train or '').resolve()} on {Path(track or '').resolve()}, {from_stop} to {to_stop}"


def timing_of(time: Optional[float], supplement_pct: Optional[float], window: Optional[str] = None) -> Timing:
    """The timing the options give: a running time [s], a supplement [%] or a window 'earliest,latest' [s]."""
    return Timing(running_time=time, supplement=None if supplement_pct is None else supplement_pct * units.PERCENT,
                  window=parse_pair(window, "--window", ordered=True) if window else None)


def output_folder(out: Optional[Path], default: Path) -> Path:
    """The output folder: ``--out`` if given, else ``default``; a relative one is relative to the
    working directory in every command (the study file's own ``output`` too)."""
    return Path(out) if out else Path(default)
