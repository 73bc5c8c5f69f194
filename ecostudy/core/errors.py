"""Domain errors: each carries the one-line message a user sees (exit status 2 for input)."""
import math
import numbers
from os import PathLike
from typing import Iterable, TypeGuard, Union


class EcostudyError(Exception):
    """Base class; ``exit_code`` is what the CLI returns."""

    exit_code = 3


class InputError(EcostudyError):
    """Bad input: one or more problems, each naming the file, the field and what is wrong."""

    exit_code = 2

    def __init__(self, problems: Union[str, Iterable[str]]) -> None:
        if isinstance(problems, str):
            problems = [problems]
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class InfeasibleError(InputError):
    """The request cannot be met by any driving (e.g. a running time below the all-out time)."""


class TooFastError(InfeasibleError):
    """The time asked for is below the fastest possible run's (or so far above it that the train would
    crawl): the timing's fault, not the train's or the line's (those raise :class:`InfeasibleError`)."""


class WeightError(InputError):
    """Weights of the mixed objective that price energy below what the solver can tell (the run would be
    the all-out one without its regularisation); the caller that read them names where they were given."""


class LineError(InfeasibleError):
    """The line makes the run impossible at the train's envelopes: a climb (or its running
    resistance) it cannot make at full traction, a descent it cannot hold at full braking; the
    caller that read the track file names it (its ``gradients``)."""


class TractionError(LineError):
    """The train stops at full traction where the line does not pull it back (no climb, or its own
    running resistance alone above its traction): the train's fault, not the line's; the caller that
    read the train file names it (its ``traction``)."""


class FieldError(InfeasibleError):
    """An infeasible request found where its field is known but not its file (a timing window on the
    way, a timetable's times): the caller that read the file names it, with ``field`` (as the file
    writes it)."""

    def __init__(self, problems: Union[str, Iterable[str]], field: str) -> None:
        super().__init__(problems)
        self.field = field

    def in_file(self, path: object, field: str | None = None) -> InfeasibleError:
        """The same problems as ``file: field: what``, for the caller that knows the file (``field``:
        the field as that file names it, where it names it otherwise)."""
        return InfeasibleError([problem(str(path), field or self.field, p) for p in self.problems])


class SolverError(EcostudyError):
    """Ipopt did not return a usable point."""

    exit_code = 3


class EcostudyWarning(UserWarning):
    """Suspicious but usable input (e.g. Davis coefficients of an implausible size)."""


def printable(line: str) -> str:
    """``line`` with every character a terminal would not print as itself (a control character, a
    line or paragraph separator) written as its escape, so one problem stays one line."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in line)


def finite_number(value: object) -> TypeGuard[float]:
    """Whether ``value`` is a finite real number (numpy's included), not a bool: the one test every
    number a user gives passes before its range is checked. An integer too large for a float (a JSON
    literal of 400 digits) is not one."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def problem(file: Union[str, PathLike[str]], field: str, message: str) -> str:
    """Format one problem line: ``file: field: message``."""
    where = f"{file}: {field}" if field else f"{file}"
    return printable(f"{where}: {message}")  # what a user typed, escaped: one problem stays one line
