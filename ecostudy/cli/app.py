"""The Typer application and what every command shares: one-line errors and exit codes.

Exit status: 0 verified optimal result, 1 result written but flagged (not optimal or failed
verification), 2 bad input or infeasible request, 3 solver failure or internal error, 130
interrupted. ``--debug`` shows tracebacks.
"""
import warnings
from enum import Enum

import typer

from ecostudy.core.errors import EcostudyError, InputError, problem

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Energy-efficient train control studies (Pyomo + Ipopt).")


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
                raise
            fail(exc, exc.exit_code)
        except (KeyboardInterrupt, typer.Exit):
            raise
        except Exception as exc:  # an unexpected failure still gets one line by default
            if debug:
                raise
            fail(f"internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback)", 3)
        finally:
            for w in caught:
                typer.secho(f"warning: {w.message}", fg=typer.colors.YELLOW, err=True)


def parse_pair(text, option):
    try:
        a, b = (float(x) for x in text.split(","))
        return a, b
    except ValueError:
        raise InputError(problem("command line", option, f"expected two numbers 'a,b', got '{text}'"))
