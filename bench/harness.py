"""The benchmark harness: named cases, repeats, medians and spreads, ratios, one table.

A *case* is a name (``group.case``: the group is the script ``bench/bench_<group>.py`` that
registers it), default parameters, an optional ``setup(params) -> state`` run once and never
timed, and the timed callable ``run(state) -> reports`` (``state`` is ``params`` when there is no
setup). ``reports`` is a mapping of numbers and strings (Ipopt iterations, energy in kWh, a
status); a nested mapping under ``"stages"`` gives per-stage seconds, reported as ``<stage>_s``.
The harness times every call itself: ``wall_s`` (``time.perf_counter``) and ``cpu_s`` (this process
and its waited-for children, ``os.times``: on a busy machine the wall clock measures the load, the
CPU time the work). Repeats are alternated across the cases of one call (a machine that gets
busier slows them all alike), and every numeric column is summarised by its median and its
spread (smallest and largest). A case may name a ``reference`` case: both run in the same
process and the table gives the ratio of the medians (wall and CPU).

Ideas from pyperf and airspeed velocity (named benchmarks, repeats, medians), no dependency::

    PYTHONPATH=$PWD .venv/bin/python -m bench list [PATTERN]
    PYTHONPATH=$PWD .venv/bin/python -m bench run solve.energy lean.* --repeat 3 --set points=500 \\
        [--csv FILE] [--json FILE]

The scripts ``bench/bench_*.py`` keep their own command lines; they register their cases here and
time, summarise and print through this module.
"""
import argparse
import csv
import fnmatch
import importlib
import json
import os
import shlex
import statistics
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
TIMES = ("wall_s", "cpu_s")


@dataclass(frozen=True)
class Case:
    """A named benchmark: ``run(setup(params))`` timed, ``setup`` once and untimed."""

    name: str
    run: Callable[[Any], Mapping[str, Any] | None]
    params: Mapping[str, Any] = field(default_factory=dict)
    setup: Callable[[dict], Any] | None = None
    reference: str | None = None
    doc: str = ""


CASES: dict[str, Case] = {}


def register(name: str, run: Callable, *, params: Mapping[str, Any] | None = None, setup: Callable | None = None,
             reference: str | None = None, doc: str | None = None) -> Case:
    """Add (or replace: a script run as ``__main__`` and imported again registers twice) a case."""
    text = doc if doc is not None else (run.__doc__ or "")
    CASES[name] = Case(name, run, dict(params or {}), setup, reference, " ".join(text.split()))
    return CASES[name]


def case(name: str, **options) -> Callable:
    """Decorator form of :func:`register`: ``@case("solve.energy", params={"points": 1000})``."""
    def wrap(run):
        register(name, run, **options)
        return run
    return wrap


def cpu() -> float:
    """CPU seconds of this process and its waited-for children (Ipopt processes, workers) so far."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def timed(work: Callable[[], Any]) -> tuple[Any, float, float]:
    """(what ``work()`` returns, CPU seconds, wall seconds)."""
    c0, w0 = cpu(), time.perf_counter()
    out = work()
    return out, cpu() - c0, time.perf_counter() - w0


class stage:
    """``with stage() as t: ...``, then ``t.seconds``: the wall seconds of one stage of a case."""

    seconds = float("nan")

    def __enter__(self):
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.seconds = time.perf_counter() - self.start


def sample(run: Callable[[Any], Mapping | None], state: Any, errors: str = "raise") -> dict:
    """One timed call: ``wall_s``, ``cpu_s`` and the case's reports (stages as ``<stage>_s``);
    with ``errors="report"`` an exception becomes ``status`` ``failed: <reason>``."""
    try:
        reports, c, w = timed(lambda: run(state) or {})
    except Exception as error:  # a benchmark reports a failure, it does not stop the others
        if errors == "raise":
            raise
        traceback.print_exc(file=sys.stderr)
        return {"status": f"failed: {type(error).__name__}: {error}"}
    out = {"wall_s": w, "cpu_s": c}
    for key, value in reports.items():
        if key == "stages":
            out.update({f"{stage}_s": seconds for stage, seconds in value.items()})
        else:
            out[key] = value
    return out


class Samples(list):
    """The samples (dicts) of one case; numeric columns summarised by median and spread."""

    def __init__(self, name: str, params: Mapping[str, Any], items=()):
        super().__init__(items)
        self.name, self.params = name, dict(params)

    def values(self, key: str) -> list[float]:
        return [s[key] for s in self if isinstance(s.get(key), (int, float)) and not isinstance(s.get(key), bool)]

    def median(self, key: str, default: float = float("nan")) -> float:
        values = self.values(key)
        return statistics.median(values) if values else default

    def spread(self, key: str) -> tuple[float, float]:
        values = self.values(key) or [float("nan")]
        return min(values), max(values)

    def last(self, key: str, default: Any = None) -> Any:
        return next((s[key] for s in reversed(self) if key in s), default)

    @property
    def status(self) -> str:
        """``ok``, or the first sample's ``failed: ...``/``flagged: ...``."""
        return next((str(s["status"]) for s in self if str(s.get("status", "ok")).split(":")[0] != "ok"), "ok")

    def summary(self) -> dict:
        """One row: the case, its repeats and status, the median of every numeric column (and the
        smallest and largest wall and CPU seconds), the last value of every other column."""
        row: dict[str, Any] = {"case": self.name, "repeats": len(self), "status": self.status}
        for key in dict.fromkeys(k for s in self for k in s):
            if key == "status":
                continue
            if self.values(key):
                row[key] = self.median(key)
                if key in TIMES:
                    row[f"{key}_min"], row[f"{key}_max"] = self.spread(key)
            else:
                row[key] = self.last(key)
        return row


def parameters(case: Case, overrides: Mapping[str, Any]) -> dict:
    """The case's parameters with ``overrides`` (only those it has) cast to its defaults' types."""
    out = dict(case.params)
    for key, value in overrides.items():
        if key in out:
            out[key] = cast(value, out[key])
    return out


def cast(value: Any, like: Any) -> Any:
    """``value`` (a string from the command line, or already typed) as the type of ``like``."""
    if not isinstance(value, str) or isinstance(like, str) or like is None:
        return value
    if isinstance(like, bool):
        return value.lower() in ("1", "true", "yes", "on")
    if isinstance(like, (list, tuple)):
        kind = type(like[0]) if like else str
        return [cast(v, kind()) for v in value.split(",") if v]
    return type(like)(value)


def measure(names: Sequence[str], repeat: int = 1, overrides: Mapping[str, Any] | None = None,
            errors: str = "raise", references: bool = True) -> dict[str, Samples]:
    """Each named case (and, with ``references``, the references they name) set up once, then
    ``repeat`` rounds of one timed call each, alternating the cases; name -> samples. ``errors``:
    ``raise`` (a script's table needs every sample) or ``report`` (a failed sample says why)."""
    overrides = overrides or {}
    order = list(dict.fromkeys(n for name in names for n in (name, CASES[name].reference if references else None) if n))
    states, results = {}, {}
    for name in order:
        params = parameters(CASES[name], overrides)
        results[name] = Samples(name, params)
        setup = CASES[name].setup
        states[name] = setup(params) if setup else params
    for _ in range(repeat):
        for name in order:
            results[name].append(sample(CASES[name].run, states[name], errors))
    return results


def summarise(results: Mapping[str, Samples]) -> list[dict]:
    """One row a case, with ``ratio_wall`` and ``ratio_cpu`` against its reference's medians."""
    rows = []
    for name, samples in results.items():
        row = samples.summary()
        ref = CASES[name].reference if name in CASES else None
        if ref in results:
            row["reference"] = ref
            for key in TIMES:
                row[f"ratio_{key[:-2]}"] = samples.median(key) / results[ref].median(key)
        rows.append(row)
    return rows


def cell(value: Any, digits: int = 4) -> str:
    """A table cell: floats to ``digits`` significant digits, the rest as text."""
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return "" if value is None else str(value)


def markdown(rows: Sequence[Mapping[str, Any]], columns: Sequence[str] | None = None, digits: int = 4) -> str:
    """A markdown table of ``rows`` (every column that any row has, in order, unless given)."""
    columns = list(columns or dict.fromkeys(k for r in rows for k in r))
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(cell(r.get(c), digits) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


class Table:
    """A markdown table printed as it grows (a long benchmark shows each row when it is done)."""

    def __init__(self, columns: Sequence[str], file=None, show: bool = True):
        self.columns, self.rows, self.file, self.show = list(columns), [], file, show
        if show:
            print("\n".join(markdown([], self.columns).splitlines()), file=self.file or sys.stdout, flush=True)

    def add(self, *cells: Any) -> str:
        """Print and keep one row (cells formatted by the caller, or by :func:`cell`)."""
        line = "| " + " | ".join(cell(c) for c in cells) + " |"
        self.rows.append(line)
        if self.show:
            print(line, file=self.file or sys.stdout, flush=True)
        return line

    def text(self) -> str:
        return markdown([], self.columns) + "".join("\n" + line for line in self.rows)


def command(program: str, argv: Sequence[str] | None = None) -> str:
    """The command line a table was made with, as tables are headed: "`python bench/X.py ...`"
    (``program`` a script's ``__file__`` or ``-m bench``; ``argv`` by default this process's)."""
    args = list(sys.argv[1:] if argv is None else argv)
    words = ["bench/" + Path(program).name] if program.endswith(".py") else program.split()
    return f"`{shlex.join(['python'] + words + args)}`"


def modules() -> list[str]:
    """The scripts that may register cases: ``bench/bench_*.py``."""
    return sorted(p.stem for p in BENCH.glob("bench_*.py"))


def load(patterns: Sequence[str] = ("*",)) -> dict[str, str]:
    """Import the scripts whose group a pattern can match (all for ``*``); script -> why it did not load."""
    for path in (str(ROOT), str(BENCH)):
        if path not in sys.path:
            sys.path.insert(0, path)
    failed = {}
    for name in modules():
        group = name[len("bench_"):]
        if not any(fnmatch.fnmatch(group, p.split(".")[0]) for p in patterns):
            continue
        try:
            importlib.import_module(f"bench.{name}")
        except ImportError as error:  # an optional dependency (CasADi, ECOS) missing: its cases are not listed
            failed[name] = f"{type(error).__name__}: {error}"
    return failed


def chosen(patterns: Sequence[str]) -> list[str]:
    """Registered names matching the patterns (``fnmatch``), in registration order."""
    return [n for n in CASES if any(fnmatch.fnmatch(n, p) for p in patterns)]


def write(rows: Sequence[Mapping[str, Any]], csv_path: str | None, json_path: str | None) -> None:
    """The rows for machines: CSV (every column) and JSON (a list of objects)."""
    if csv_path:
        columns = list(dict.fromkeys(k for r in rows for k in r))
        with open(csv_path, "w", newline="") as f:
            writer = csv.DictWriter(f, columns)
            writer.writeheader()
            writer.writerows(rows)
    if json_path:
        Path(json_path).write_text(json.dumps(list(rows), indent=1, default=str) + "\n")


def refused(args: argparse.Namespace, names: Sequence[str], overrides: Mapping[str, str]) -> str | None:
    """Why ``run`` cannot start (checked before anything is computed), or None."""
    for name in args.names:
        if not chosen([name]):
            return f"{name}: no such case (see `python -m bench list`)"
    for text in args.set:
        if "=" not in text:
            return f"--set {text}: not KEY=VALUE"
    for key, value in overrides.items():
        if not any(key in CASES[n].params for n in names):
            return f"--set {key}: no chosen case has this parameter"
        for name in names:
            try:
                parameters(CASES[name], {key: value})
            except ValueError:
                return f"--set {key}={value}: not of type {type(CASES[name].params[key]).__name__} ({name})"
    return None if args.repeat >= 1 else f"--repeat {args.repeat}: must be at least 1"


def main(argv: Sequence[str] | None = None) -> int:
    """``list [PATTERN...]`` or ``run NAME... [--repeat N] [--set KEY=VALUE ...]``; exit 1 if a case is not ok."""
    p = argparse.ArgumentParser(prog="python -m bench", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    ls = sub.add_parser("list", help="the registered cases, their parameters and what they measure")
    ls.add_argument("patterns", nargs="*", default=["*"])
    run = sub.add_parser("run", help="run cases; a markdown table of medians on stdout")
    run.add_argument("names", nargs="+", help="case names or patterns (solve.*)")
    run.add_argument("--repeat", type=int, default=3)
    run.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE", help="parameter overrides (where a case has the key)")
    run.add_argument("--csv")
    run.add_argument("--json")
    args = p.parse_args(argv)
    failed = load(args.patterns if args.command == "list" else args.names)
    for script, reason in failed.items():
        print(f"bench/{script}.py: not loaded ({reason})", file=sys.stderr)
    if args.command == "list":
        rows = [{"case": n, "parameters": ", ".join(f"{k}={str(v).replace(f'{ROOT}/', '')}"
                                                    for k, v in CASES[n].params.items()),
                 "reference": CASES[n].reference or "", "measures": CASES[n].doc} for n in chosen(args.patterns)]
        print(markdown(rows, ["case", "parameters", "reference", "measures"]))
        return 0
    names, overrides = chosen(args.names), dict(s.split("=", 1) for s in args.set if "=" in s)
    problem = refused(args, names, overrides)
    if problem:
        print(f"python -m bench run: {problem}", file=sys.stderr)
        return 2
    print(command("-m bench", argv) + "\n")
    rows = summarise(measure(names, args.repeat, overrides, errors="report"))
    print(markdown(rows))
    write(rows, args.csv, args.json)
    return int(any(r["status"] != "ok" for r in rows))
