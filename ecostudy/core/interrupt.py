"""A command stopped by a signal: SIGINT (Ctrl-C, ``kill -INT``), SIGTERM (``kill``, ``timeout``,
a batch scheduler, systemd) and SIGHUP (the terminal or SSH session closed, ``kill -HUP``) all raise
``KeyboardInterrupt`` in the main thread, so one path handles them (a study's results that reached
the command stored, its workers stopped, its store closed and unlocked, no temporary file left); the
exit status tells them apart (128 + the signal: 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP). A
SIGINT that the command inherited as ignored (a job started with ``&`` by a shell without job
control) stays ignored, as POSIX has it, and so does a SIGHUP (a command started with ``nohup``).
Only the first stop signal raises: one that follows while the command stops (a second Ctrl-C,
``timeout -s INT`` signalling the command and then its process group a few ms later) is noted and
not raised, so that it cannot cut the stop short anywhere (inside a lock of ``concurrent.futures``,
which it would leave held, hanging the pool's shutdown); the stop itself is bounded
(:func:`ecostudy.studies.workers.stop_workers`). A stop that has not ended :data:`LOST_AFTER_S`
after it began was lost (Python ignores an exception raised in a fork's callbacks or a finalizer):
the next signal raises again.
"""
import logging
import os
import signal
import sys
import threading
import time
from contextlib import contextmanager
from types import FrameType
from typing import Any, Callable, Iterator, Optional

TERMINATE = (signal.SIGTERM, signal.SIGHUP)  # the stop signals beside Ctrl-C's: they end a child at once
STOPS = (signal.SIGINT, *TERMINATE)
KEPT_IGNORED = (signal.SIGINT, signal.SIGHUP)  # inherited as ignored, they stay so (``&``, ``nohup``)
RECEIVED: list[int] = []  # the stop signals this process received while a handler of this module was set
STOPPING: list[float] = []  # when the command's stop began (a stop signal raised), empty before
LOST_AFTER_S = 5.0  # [s] a stop begun this long ago and still running was lost: the next signal raises again


class Interrupted(KeyboardInterrupt):
    """A study stopped by a signal, with what it kept: ``counts`` (``total``, ``stored_before``,
    ``computed``: stored now), the signal received (``signum``)."""

    def __init__(self, counts: dict[str, int]) -> None:
        super().__init__()
        self.counts = counts
        self.signum = RECEIVED[0] if RECEIVED else signal.SIGINT


def _under_way() -> bool:
    """Whether the command's stop began less than :data:`LOST_AFTER_S` ago."""
    return bool(STOPPING) and time.monotonic() - STOPPING[0] < LOST_AFTER_S


def _raise(signum: int, frame: Optional[FrameType]) -> None:
    RECEIVED.append(signum)
    if _under_way():  # the stop is under way: noted only
        return
    STOPPING[:] = [time.monotonic()]
    raise KeyboardInterrupt


def quiet_start() -> None:
    """The ``ecostudy`` command's first step, as ``ecostudy.cli`` begins to load, in the command's
    own process only (its console script, or ``python -m ecostudy``; a test or a notebook importing
    it is left as it is): from then on, outside :func:`stopped_by_signals`, SIGINT, SIGTERM and
    SIGHUP end the command with one line ('warning: interrupted by SIGINT') and exit status 128 +
    the signal, not a traceback of the import they cut (nothing is written yet), nor Typer's silent
    130 (``cli.app.call`` loads what it enters before the stop signals raise). With ``--debug``
    SIGINT raises KeyboardInterrupt, its traceback printed. One inherited as ignored stays so."""
    top = sys.modules.get("__main__")
    command = getattr(getattr(top, "__spec__", None), "name", None) == "ecostudy.__main__" or \
        os.path.basename(getattr(top, "__file__", None) or "") == "ecostudy"
    for s in STOPS if command else ():
        if not (s in KEPT_IGNORED and signal.getsignal(s) == signal.SIG_IGN) and not (s == signal.SIGINT and
                                                                                       "--debug" in sys.argv):
            signal.signal(s, _leave)


def _leave(signum: int, frame: Optional[FrameType]) -> None:
    RECEIVED.append(signum)
    sys.stderr.write(f"warning: interrupted by {signal.Signals(signum).name}\n")
    raise SystemExit(128 + signum)


def _ours(handler: object) -> bool:
    return handler is signal.default_int_handler or handler is _raise


@contextmanager
def stopped_by_signals() -> Iterator[None]:
    """While inside (a command's work), SIGTERM and SIGHUP raise KeyboardInterrupt as SIGINT does,
    and each is noted for :func:`exit_status`; only in the main thread (elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in STOPS}
    for s in STOPS:
        if not (s in KEPT_IGNORED and old[s] == signal.SIG_IGN):
            signal.signal(s, _raise)
    hook, threading.excepthook = threading.excepthook, _stopping_hook(threading.excepthook)
    STOPPING.clear()
    try:
        yield
    finally:
        STOPPING.clear()
        threading.excepthook = hook
        for s, handler in old.items():
            signal.signal(s, handler)


def _stopping_hook(default: Callable[[Any], object]) -> Callable[[Any], None]:
    """``threading.excepthook`` that, once a stop signal arrived, logs at debug level (``--verbose``)
    what a process pool's own thread raises: the workers are killed then, and Python's pool thread can
    fail on a pipe the pool's shutdown closed ("OSError: handle is closed", seen in 2 of 11 SIGTERMs of
    ``run --workers 2``): no result is lost by it, and it is not the command's error. Anything else,
    or before a stop, goes to ``default``."""
    def hook(args: Any) -> None:
        pool_thread = type(args.thread).__module__.startswith("concurrent.futures")
        if RECEIVED and pool_thread:
            logging.getLogger("ecostudy").debug("a process pool's thread ended with %s: %s while the command stopped",
                                                getattr(args.exc_type, "__name__", args.exc_type), args.exc_value)
            return
        default(args)
    return hook


def exit_status() -> int:
    """128 + the first stop signal received (130 when none was noted: a KeyboardInterrupt as such)."""
    return 128 + (RECEIVED[0] if RECEIVED else signal.SIGINT)


def signal_name() -> str:
    """The first stop signal received, by name (``SIGTERM``), SIGINT when none was noted."""
    return signal.Signals(RECEIVED[0] if RECEIVED else signal.SIGINT).name


@contextmanager
def held(flag: list[bool]) -> Iterator[None]:
    """A stop signal that arrives inside is noted (in ``flag``, and for :func:`exit_status`) rather
    than raised, and raised as KeyboardInterrupt when the block ends: for a C library's callbacks,
    which swallow an exception raised in them (cyipopt's: the caller's intermediate callback reads
    ``flag`` to stop at its next iteration), and for the clean-up of an interrupt, which a second
    signal must not cut short. Only in the main thread, and only for signals that raise
    KeyboardInterrupt there (one ignored stays ignored; inside another ``held``, nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in STOPS}
    ours = [s for s in STOPS if _ours(old[s])]
    managed = any(old[s] is _raise for s in ours)  # inside stopped_by_signals: its stop may be under way
    begun = managed and _under_way()

    def note(signum: int, frame: Optional[FrameType]) -> None:
        RECEIVED.append(signum)
        flag.append(True)

    for s in ours:
        signal.signal(s, note)
    try:
        yield
    finally:
        for s in ours:
            signal.signal(s, old[s])
    if flag and not begun:  # the stop begins here (one already under way is not raised again)
        if managed:
            STOPPING[:] = [time.monotonic()]
        raise KeyboardInterrupt
