"""What a long command shows while it runs, for the command line and for scripts: the ``ecostudy``
logger's handlers (stderr, a log file) and a progress bar over a study's cases on stderr.

Progress and messages never go to stdout, where the results are printed (``ecostudy ... | cat``
stays clean); the bar is drawn only when stderr is a terminal.
"""
import atexit
import logging
import multiprocessing
import os
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator, Optional

log = logging.getLogger("ecostudy")


class Stderr(logging.StreamHandler):
    """Messages on the current ``sys.stderr`` ('error: ...', 'warning: ...', information as is)."""

    stream = property(lambda self: sys.stderr, lambda self, value: None)

    def format(self, record: logging.LogRecord) -> str:
        return (f"{record.levelname.lower()}: " if record.levelno >= logging.WARNING else "") + record.getMessage()


def logging_to(quiet: bool = False, verbose: bool = False, log_file: Optional[Path] = None) -> Callable[[], None]:
    """Send the ``ecostudy`` logger's messages to stderr (``quiet``: errors only; ``verbose``: debug
    ones too, such as each case's progress; else information, warnings and errors) and to
    ``log_file`` (debug ones with ``verbose``). Returns the function that removes these handlers again."""
    handlers: list[logging.Handler] = [Stderr()]
    handlers[0].setLevel(logging.ERROR if quiet else logging.DEBUG if verbose else logging.INFO)
    if log_file is not None:
        handlers.append(logging.FileHandler(log_file, encoding="utf-8"))
        handlers[1].setLevel(logging.DEBUG if verbose else logging.INFO)
        handlers[1].setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    log.setLevel(logging.DEBUG)
    for handler in handlers:
        log.addHandler(handler)

    def close() -> None:
        for handler in handlers:
            log.removeHandler(handler)
            handler.close()
    return close


@contextmanager
def progress_bar(label: str, disabled: bool = False) -> Iterator[Callable[[int, int, int, int], None]]:
    """A progress bar over a study's cases on stderr (off when ``disabled`` or stderr is not a
    terminal): yields ``progress(done, failed, remaining, total)``, which also logs each step."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    columns = [TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("failed {task.fields[failed]}, remaining {task.fields[remaining]}"), TimeRemainingColumn()]
    with Progress(*columns, console=Console(stderr=True), disable=disabled or not sys.stderr.isatty(),
                  transient=False) as bar:
        task = bar.add_task(label, total=None, failed=0, remaining="?")

        def progress(done: int, failed: int, remaining: int, total: int) -> None:
            log.debug("%s: %d of %d done (%d failed)", label, done, total, failed)
            bar.update(task, completed=done, total=total, failed=failed, remaining=remaining)

        yield progress


def leave(code: object) -> None:
    """Exit with ``code`` once everything is finished, without the interpreter's teardown: freeing
    Pyomo's, pandas' and matplotlib's objects one by one took 0.4-0.5 s after every file was written
    (``docs/speed.md``). First the exit handlers run as at a normal exit (log files flushed and
    closed, temporary files removed, worker pools joined); then, when no worker process and no
    thread other than daemons is left, ``os._exit``. Otherwise, or for an exit code that is not a
    number, the normal exit."""
    sys.stdout.flush()
    sys.stderr.flush()
    atexit._run_exitfuncs()  # what a normal exit runs first: logging.shutdown, tempfile and pool clean-up
    children = multiprocessing.active_children()
    threads = [t for t in threading.enumerate() if t is not threading.main_thread() and t.is_alive() and not t.daemon]
    if children or threads or not (code is None or isinstance(code, int)):
        sys.exit(code if code is None or isinstance(code, (int, str)) else str(code))
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code or 0)
