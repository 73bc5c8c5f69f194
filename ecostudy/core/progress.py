"""Progress of one long piece of work, told from deep inside it to whoever watches (the command
line's bar on stderr), without a callback passed through every layer: the work names its
**stages** (the ATO solve, the MINLP search, a bootstrap over logs, ...) and, where it can count
them, the **steps** of a stage done out of its total (draws refitted, runs replayed, seconds of a
search's time limit spent). Nothing is told when nobody watches (a script, a worker process).

A watcher is any object with the two methods of :class:`Watcher`; :func:`watched` sets it for a
block, as :func:`ecostudy.core.budget.forced` sets the size guards. Stages without a count (one
solver call) are named only: no percentage is made up for them.
"""
import contextvars
from contextlib import contextmanager
from typing import Iterator, Optional, Protocol


class Watcher(Protocol):
    """What watches the work (``ecostudy.report.console.progress_bar`` yields one)."""

    def stage(self, name: str, total: Optional[float] = None, unit: str = "") -> None:
        """A stage named ``name`` begins: ``total`` steps of ``unit`` (None: not counted)."""

    def step(self, done: float, note: str = "") -> None:
        """``done`` steps of the current stage are finished; ``note``: the current case, or what
        the work has found so far."""


WATCHER: contextvars.ContextVar[Optional[Watcher]] = contextvars.ContextVar("ecostudy_progress", default=None)


@contextmanager
def watched(watcher: Optional[Watcher]) -> Iterator[None]:
    """Within this block, :func:`stage` and :func:`step` tell ``watcher`` (None: nobody)."""
    token = WATCHER.set(watcher)
    try:
        yield
    finally:
        WATCHER.reset(token)


def stage(name: str, total: Optional[float] = None, unit: str = "") -> None:
    """Tell the watcher, if any, that the stage ``name`` of ``total`` steps (None: uncounted) begins."""
    watcher = WATCHER.get()
    if watcher is not None:
        watcher.stage(name, total, unit)


def step(done: float, note: str = "") -> None:
    """Tell the watcher, if any, that ``done`` steps of the current stage are finished."""
    watcher = WATCHER.get()
    if watcher is not None:
        watcher.step(done, note)
