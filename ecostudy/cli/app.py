"""The Typer application and what every command shares: one-line errors and exit codes.

Exit status: 0 verified optimal result, 1 result written but flagged (not optimal or failed
verification), 2 bad input or infeasible request, 3 solver failure or internal error, 130
interrupted. ``--debug`` shows tracebacks.
"""
import functools
import math
import os
import traceback
import warnings
from contextlib import contextmanager
from enum import Enum
from pathlib import Path

import typer

from ecostudy.core.budget import forced
from ecostudy.core.errors import EcostudyError, InputError, problem

app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,  # "[s]" is a unit, not markup
                  help="Energy-efficient train control studies (Pyomo + Ipopt).")


def _print_version(value: bool) -> None:
    if value:
        from ecostudy import __version__
        typer.echo(f"ecostudy {__version__}")
        raise typer.Exit(0)


@app.callback()
def _main(version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                       help="Print the version and exit.")) -> None:
    """Energy-efficient train control studies (Pyomo + Ipopt)."""
    from ecostudy.ocp.solver import configure

    configure()  # once, before any command imports the solver chain


class DasMethod(str, Enum):
    round = "round"
    phases = "phases"
    minlp = "minlp"


class Objective(str, Enum):
    energy = "energy"
    net_energy = "net_energy"
    time = "time"
    mixed = "mixed"


def fail(lines, code):
    for line in str(lines).splitlines():
        typer.secho(f"error: {line}", fg=typer.colors.RED, err=True)
    raise typer.Exit(code)


def guarded(debug, fn, *args, **kwargs):
    """Run ``fn``; turn ecostudy errors into one-line messages and exit codes."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            return fn(*args, **kwargs)
        except EcostudyError as exc:
            if debug:
                traceback.print_exc()
            fail(exc, exc.exit_code)
        except (KeyboardInterrupt, typer.Exit):
            raise
        except Exception as exc:  # an unexpected failure still gets one line by default
            if debug:
                traceback.print_exc()
            fail(f"internal error: {type(exc).__name__}: {exc}" + ("" if debug else " (rerun with --debug for the "
                                                                     "traceback)"), 3)
        finally:
            for w in caught:
                typer.secho(f"warning: {w.message}", fg=typer.colors.YELLOW, err=True)


FORCE_HELP = "Run work estimated too big (over 2 h for one run, half the memory, a 10^6-point table) anyway."


def with_force(force, fn):
    """``fn`` run with the size guards of :mod:`ecostudy.core.budget` lifted when ``force``."""
    @functools.wraps(fn)
    def run(*args, **kwargs):
        with forced(force):
            return fn(*args, **kwargs)
    return run


# the ranges of numeric options: the same as the study schema's where a field exists (io/schemas.py);
# (lowest, highest, lowest allowed itself)
OPTION_RANGES = {
    "points": (10, 100000, True), "workers": (1, 256, True), "count": (2, 10000, True),
    "weighted": (0, 1000, True), "time": (0.0, None, False), "supplement": (0.0, None, True),
    "supplement_max": (0.0, None, False), "dwell": (0.0, None, True), "das_time_limit": (0.0, None, False),
}


def every_core(workers):
    """``--workers`` as given, else every core this process may run on: a study's default (its
    results are the same bit for bit with any number of workers: tests/test_workers.py)."""
    return workers if workers is not None else len(os.sched_getaffinity(0))


def check_options(**values):
    """Refuse numeric options that are not finite or out of their range (:data:`OPTION_RANGES`):
    one line each, naming the option, before anything is computed (exit status 2)."""
    lines = []
    for name, value in values.items():
        if value is None:
            continue
        option = "--" + name.replace("_", "-")
        low, high, closed = OPTION_RANGES[name]
        if isinstance(value, float) and not math.isfinite(value):
            lines.append(problem("command line", option, f"must be a finite number, not {value}"))
        elif value < low or (value == low and not closed) or (high is not None and value > high):
            bound = f"at least {low}" if closed else f"more than {low}"
            lines.append(problem("command line", option, f"must be {bound}" + (f" and at most {high}" if high else "")
                                 + f", not {value}"))
    if lines:
        raise InputError(lines)


def parse_pair(text, option, ordered=False, nonnegative=False):
    """Two finite numbers 'a,b'; ``ordered``: a <= b; ``nonnegative``: both >= 0, not both 0."""
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise InputError(problem("command line", option, f"expected two numbers 'a,b', got '{text}'"))
    if not (math.isfinite(a) and math.isfinite(b)):
        raise InputError(problem("command line", option, f"must be finite numbers, not '{text}'"))
    if ordered and not 0 <= a <= b:
        raise InputError(problem("command line", option, f"must be 'earliest,latest' with 0 <= earliest <= latest, "
                                 f"not '{text}'"))
    if nonnegative and (a < 0 or b < 0 or a == b == 0):
        raise InputError(problem("command line", option, f"must be two weights >= 0, not both 0, not '{text}'"))
    return a, b


def only_one(**options):
    """Refuse two options that each set the same thing (one would be ignored)."""
    given = ["--" + name.replace("_", "-") for name, value in options.items() if value is not None]
    if len(given) > 1:
        raise InputError(problem("command line", "/".join(given), "give only one: each sets the running time"))


def listed(out_dir, names=()):
    """``DIR/ (a, b)``: the files this run left in ``out_dir``: its tables and files as its
    ``summary.json`` lists them, else those of ``names`` that exist (a figure skipped with
    ``--no-plot`` is not listed)."""
    import json
    try:
        summary = json.loads((Path(out_dir) / "summary.json").read_text())
        names = list(dict.fromkeys([*summary["tables"].values(), *summary["files"]]))
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return f"{out_dir}/ ({', '.join(n for n in names if (Path(out_dir) / n).is_file())})"


def counts_line(counts, noun):
    """The one-line summary of a resumable study's counts (``studies.batch.execute``)."""
    return (f"{counts['total']} {noun}: {counts['stored_before']} already stored, {counts['computed']} computed now "
            f"({counts['failed']} failed); not ok: {counts['not_ok']}")


@contextmanager
def case_progress(label, disabled):
    """A progress bar over a study's cases: yields ``progress(done, failed, remaining, total)``.
    Ctrl-C inside ends with exit status 130 and says that the finished cases are kept."""
    import sys

    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    # progress goes to stderr, and only to a terminal: piped results on stdout stay clean
    disabled = disabled or not sys.stderr.isatty()
    columns = [TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("failed {task.fields[failed]}, remaining {task.fields[remaining]}"), TimeRemainingColumn()]
    with Progress(*columns, console=Console(stderr=True), disable=disabled, transient=False) as bar:
        task = bar.add_task(label, total=None, failed=0, remaining="?")

        def progress(done, failed, remaining, total):
            bar.update(task, completed=done, total=total, failed=failed, remaining=remaining)

        try:
            yield progress
        except KeyboardInterrupt:
            typer.secho(f"interrupted: every finished {label[:-1]} is stored; run the same command again to continue",
                        fg=typer.colors.YELLOW, err=True)
            raise typer.Exit(130)


def flag_folder(out_dir, shown=20):
    """Exit status 1 when the folder's ``summary.json`` has cases that are not ok, naming each
    (at most ``shown``, then how many more) with its status, one line on stderr each."""
    import json
    summary = json.loads((Path(out_dir) / "summary.json").read_text())
    bad = summary.get("not_ok", [])
    for case in bad[:shown]:
        typer.secho(f"{case['status'].split(':')[0]}: {case['case']}: {case['status'].partition(':')[2].strip()}",
                    fg=typer.colors.YELLOW, err=True)
    if len(bad) > shown:
        typer.secho(f"... and {len(bad) - shown} more cases not ok (summary.json, report.html)",
                    fg=typer.colors.YELLOW, err=True)
    if bad:
        raise typer.Exit(1)

