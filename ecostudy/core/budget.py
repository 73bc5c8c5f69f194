"""Work too big to be meant: refused before computing, with its size and an estimate, unless the
user says ``--force``. The commands set :data:`FORCE` around their work (:func:`forced`); checks
anywhere below read it, so a loader refuses a 10^6-point curve as a study refuses a run that
would be simulated to its time cap."""
import contextvars
import math
import os
from contextlib import contextmanager
from os import PathLike
from typing import Iterator, Sequence

from ecostudy.core.errors import InputError, problem

FORCE: contextvars.ContextVar[bool] = contextvars.ContextVar("ecostudy_force", default=False)
MAX_RUN_SECONDS = 2 * 3600.0     # the longest one run (a case) may be estimated to compute
MAX_STUDY_SECONDS = 2 * 3600.0   # the longest one command may be estimated to run (its workers together)
WORKER_BYTES = 0.4e9             # a worker with the solver stack loaded (170 MB measured) and its model


ENVIRONMENT = "ECOSTUDY_FORCE"   # the same, for worker processes started inside the block


@contextmanager
def forced(force: bool = True) -> Iterator[None]:
    """Within this block (and in worker processes it starts), :func:`refuse_unless_forced` lets the
    work run."""
    token, before = FORCE.set(bool(force)), os.environ.get(ENVIRONMENT)
    if force:
        os.environ[ENVIRONMENT] = "1"
    try:
        yield
    finally:
        FORCE.reset(token)
        if before is None:
            os.environ.pop(ENVIRONMENT, None)
        else:
            os.environ[ENVIRONMENT] = before


def is_forced() -> bool:
    """Whether the size guards are lifted here (:func:`forced`)."""
    return FORCE.get() or os.environ.get(ENVIRONMENT) == "1"


def refuse_unless_forced(where: str | PathLike[str], field: str, message: str) -> None:
    """Raise the one-line refusal ``where: field: message; ...--force`` unless forced."""
    if not is_forced():
        raise InputError(problem(where, field, f"{message}; give --force to run it anyway"))


def duration(seconds: float) -> str:
    """A duration as people say it: 40 s, 12 min, 3.5 h, 9 days, 2.3e+301 days (past a million days:
    three digits and the power of ten, never a number of 300 digits)."""
    if not math.isfinite(seconds):  # past the largest float (1.8e308 s)
        return "more than 1e+303 days"
    if seconds >= 1e6 * 86400:
        return f"{seconds / 86400:.2g} days"
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 3 * 86400:
        return f"{seconds / 3600:.1f}".removesuffix(".0") + " h"
    return f"{seconds / 86400:.0f} days"


def how_many(n: float) -> str:
    """A count as people read it: 864,000 (in full up to a billion), 2e+303 (three digits and the
    power of ten beyond), and one past the largest float (a step of 1e-320 s) as more than 1e+308."""
    if not math.isfinite(n):
        return "more than 1e+308"
    return f"{n:,.0f}" if n < 1e9 else f"{n:.3g}"


def size(nbytes: float) -> str:
    """Bytes as people say them: 300 MB, 2.5 GB."""
    return f"{nbytes / 1e9:.1f} GB" if nbytes >= 1e9 else f"{nbytes / 1e6:.0f} MB"


def machine_memory() -> int | None:
    """Physical memory of this machine [bytes] (None where the system does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def check_run(where: str | PathLike[str], field: str, what: str, seconds: float | None = None,
              nbytes: float | None = None) -> None:
    """Refuse (unless forced) one run estimated above :data:`MAX_RUN_SECONDS` or half the memory."""
    memory = machine_memory()
    if seconds is not None and seconds > MAX_RUN_SECONDS:
        refuse_unless_forced(where, field, f"{what}: an estimated {duration(seconds)} of computing, above the "
                             f"{duration(MAX_RUN_SECONDS)} one run may take")
    if nbytes is not None and memory and nbytes > memory / 2:
        refuse_unless_forced(where, field, f"{what}: an estimated {size(nbytes)} of memory, above half of this "
                             f"machine's {size(memory)}")


def study_estimate(runs: Sequence[float], workers: int = 1, run_bytes: float = 0.0,
                   serial: Sequence[float] = ()) -> tuple[float, float, float]:
    """(seconds of computing, wall seconds with ``workers``, peak bytes) of a study whose runs are
    estimated at ``runs`` seconds each: the work shared among the workers (never below its longest
    run), then the ``serial`` runs one after the other in the command's own process; every worker
    holds the solver stack and one run's model."""
    total = float(sum(runs))
    workers = max(1, min(int(workers), len(runs) or 1))
    wall = max(total / workers, max(runs, default=0.0)) + float(sum(serial))
    return total + float(sum(serial)), wall, workers * (WORKER_BYTES + run_bytes)


def check_study(where: str | PathLike[str], what: str, runs: Sequence[float], workers: int = 1, run_bytes: float = 0.0,
                part_hint: str = "", serial: Sequence[float] = ()) -> None:
    """Refuse (unless forced) a study whose runs (estimated seconds each), shared among ``workers``,
    then its ``serial`` runs, are estimated above :data:`MAX_STUDY_SECONDS` of wall time or half the
    memory. ``part_hint``: how to run a part of it (``--only NAME``), added to the refusal."""
    total, wall, nbytes = study_estimate(runs, workers, run_bytes, serial)
    memory = machine_memory()
    count = len(runs) + len(serial)
    how = f"{count} run{'s' * (count != 1)}, an estimated {duration(total)} of computing"
    if wall > MAX_STUDY_SECONDS:
        hint = f"; run a part of it ({part_hint}) and the rest later" if part_hint else ""
        refuse_unless_forced(where, "study", f"{what}: {how} ({duration(wall)} with {workers} worker"
                             f"{'s' if workers > 1 else ''}), above the {duration(MAX_STUDY_SECONDS)} one command "
                             f"may take{hint}")
    if memory and nbytes > memory / 2:
        fewer = "; use fewer --workers" if workers > 1 else ""  # one worker: nothing fewer to use
        refuse_unless_forced(where, "study", f"{what}: {how}, with {workers} worker{'s' * (workers > 1)} an estimated "
                             f"{size(nbytes)} of memory, above half of this machine's {size(memory)}{fewer}")
