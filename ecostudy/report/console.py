"""What a long command shows while it runs, for the command line and for scripts: the ``ecostudy``
logger's handlers (stderr, a log file), a progress bar over a study's cases on stderr, and the
command line's own refusals (Typer's checks of an option's type or range) as one line.

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
from functools import partial
from pathlib import Path
from typing import Any, Callable, Iterator, Optional, Sequence

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn
from rich.text import Text
from typer.core import TyperGroup

from ecostudy.core.errors import InputError, problem
from ecostudy.core.interrupt import Interrupted, signal_name

try:  # Typer 0.26 on carries its own Click, whose exceptions derive from TyperException
    from typer import TyperException as ClickError
except ImportError:  # an older Typer: Click's
    from click import ClickException as ClickError  # type: ignore[assignment]

log = logging.getLogger("ecostudy")


class Stderr(logging.StreamHandler):
    """Messages on the current ``sys.stderr`` ('error: ...', 'warning: ...', information as is)."""

    stream = property(lambda self: sys.stderr, lambda self, value: None)

    def format(self, record: logging.LogRecord) -> str:
        return (f"{record.levelname.lower()}: " if record.levelno >= logging.WARNING else "") + record.getMessage()


def logging_to(quiet: bool = False, verbose: bool = False, log_file: Optional[Path] = None) -> Callable[[], None]:
    """Send the ``ecostudy`` logger's messages to stderr (``quiet``: errors only; ``verbose``: debug
    ones too, such as each case's progress; else information, warnings and errors) and to
    ``log_file`` (debug ones with ``verbose``). Returns the function that removes these handlers again.
    A log file that cannot be written (a folder, a missing folder, no permission) is refused
    before any handler is added: its one line on stderr, exit status 2 (no logger holds it yet)."""
    handlers: list[logging.Handler] = [Stderr()]
    handlers[0].setLevel(logging.ERROR if quiet else logging.DEBUG if verbose else logging.INFO)
    if log_file is not None:
        try:
            handlers.append(logging.FileHandler(log_file, encoding="utf-8"))
        except OSError as exc:
            sys.stderr.write("error: " + problem("command line", "--log-file", f"{log_file}: cannot write the log "
                                                 f"file ({exc.strerror})") + "\n")
            raise SystemExit(InputError.exit_code) from None
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


class Bar:
    """The progress of one command on stderr: over its cases, called as ``progress(done, failed,
    remaining, total)`` (each call also logged), or over the stages of one long piece of work and
    the steps of each (a :class:`ecostudy.core.progress.Watcher`: a stage without a count shows
    its elapsed time only; a time limit counted in seconds, how much of it is spent)."""

    def __init__(self, label: str, bar) -> None:
        self.label, self.bar, self.unit = label, bar, ""
        self.total: Optional[float] = None
        self.task = bar.add_task(label, total=None, count="", detail="", limit=False)

    def __call__(self, done: int, failed: int, remaining: int, total: int) -> None:
        log.debug("%s: %d of %d done (%d failed)", self.label, done, total, failed)
        self.bar.update(self.task, completed=done, total=total, count=f"{done}/{total}",
                        detail=f"failed {failed}, remaining {remaining}")

    def stage(self, name: str, total: Optional[float] = None, unit: str = "") -> None:
        log.debug("%s: %s", self.label, name)
        self.bar.refresh()  # the stage ending is drawn as it ended (its last count), however fast it went
        self.bar.remove_task(self.task)
        self.total, self.unit = total, unit
        self.task = self.bar.add_task(f"{self.label}: {name}", total=total, count=self._count(0), detail="",
                                      limit=unit == "s")

    def step(self, done: float, note: str = "") -> None:
        self.bar.update(self.task, completed=done, count=self._count(done), detail=note)

    def _count(self, done: float) -> str:
        return "" if self.total is None else f"{done:.0f}/{self.total:.0f}{' ' + self.unit if self.unit else ''}"


class Clock(ProgressColumn):
    """Elapsed time of the current stage and, where its total is known, the time left at the rate
    of the finished steps (nothing for a time limit: the count shows the seconds spent of it)."""

    def render(self, task) -> Text:
        if task.fields.get("limit"):  # its count is the time spent out of the limit already
            return Text("")
        text = _clock(task.elapsed)
        if task.total is not None and not task.finished and task.time_remaining is not None:
            text += f", {_clock(task.time_remaining)} left"
        return Text(text, style="progress.remaining")


def _clock(seconds: Optional[float]) -> str:
    """m:ss, or h:mm:ss from an hour on."""
    seconds = int(seconds or 0)
    hours = f"{seconds // 3600}:{seconds // 60 % 60:02d}" if seconds >= 3600 else f"{seconds // 60}"
    return f"{hours}:{seconds % 60:02d}"


@contextmanager
def progress_bar(label: str, disabled: bool = False) -> Iterator[Bar]:
    """A progress bar on stderr (off when ``disabled`` or stderr is not a terminal): yields the
    :class:`Bar`, for cases (``progress(done, failed, remaining, total)``) or stages and steps."""
    columns = [TextColumn("{task.description}"), BarColumn(bar_width=20), TextColumn("{task.fields[count]}"),
               TextColumn("{task.fields[detail]}"), Clock()]
    with Progress(*columns, console=Console(stderr=True), disable=disabled or not sys.stderr.isatty(),
                  transient=False) as bar:
        yield Bar(label, bar)


def interrupted(exc: BaseException, bar: Optional[tuple]) -> str:
    """The line of a command stopped by SIGINT, SIGTERM or SIGHUP (:mod:`ecostudy.core.interrupt`): what it
    kept and how to continue. ``bar``: the command's progress bar (label, off[, stored]); stored
    False, or no bar: a command that stores nothing before its end."""
    line = f"interrupted by {signal_name()}"
    if not bar or bar[2:] == (False,):
        return line
    if isinstance(exc, Interrupted):  # a study, with its counts
        c = exc.counts
        return (f"{line}: {c['stored_before'] + c['computed']} of {c['total']} {bar[0]} stored ({c['computed']} "
                "of them computed now); run the same command again to continue")
    return f"{line}: every finished {singular(bar[0])} is stored; run the same command again to continue"


def singular(noun: str) -> str:
    """The singular of a plural ``noun`` ending in -s or -ies: 'strategy' of 'strategies'."""
    return noun[:-3] + "y" if noun.endswith("ies") else noun[:-1]


def counted(n: int, noun: str) -> str:
    """'1 strategy', '7 strategies': ``n`` and the plural ``noun``, singular for one."""
    return f"{n} {noun if n != 1 else singular(noun)}"


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


class OneLineErrors(TyperGroup):
    """The ``ecostudy`` command group (``typer.Typer(cls=...)``): what Click checks itself (an
    option's type or range, an unknown option or command, a missing argument) is refused as ecostudy
    refuses a bad option, 'error: command line: --points: ...' on one line, exit status 2, instead of
    Click's usage box. Click's standalone mode otherwise as it is (``standalone_mode=False`` inside)."""

    def main(self, args: Optional[Sequence[str]] = None, prog_name: Optional[str] = None,
             complete_var: Optional[str] = None, standalone_mode: bool = True, windows_expand_args: bool = True,
             **extra: Any) -> Any:
        run = partial(super().main, args, prog_name, complete_var, False, windows_expand_args, **extra)
        if not standalone_mode:
            return run()
        try:
            code = run()
        except ClickError as exc:
            ctx = getattr(exc, "ctx", None)
            if ctx is not None and exc.format_message() == ctx.get_help():  # no arguments at all: the help
                sys.stderr.write(exc.format_message() + "\n")
            else:
                sys.stderr.write("error: " + usage_line(exc) + "\n")
            sys.exit(exc.exit_code)
        except typer.Abort:
            sys.stderr.write("Aborted!\n")
            sys.exit(1)
        sys.exit(code if isinstance(code, int) else 0)


def usage_line(exc: Exception) -> str:
    """One line for Click's refusal ``exc``: 'command line: OPTION: what is wrong' (an argument by its
    name in capitals), or 'command line: what is wrong' where Click names neither."""
    param, option = getattr(exc, "param", None), getattr(exc, "option_name", None)
    if param is None:
        text = exc.format_message()  # type: ignore[attr-defined]
        if option:  # an unknown option, or one without its value: named first, as a parameter is
            text = text.replace(f"Option {option!r} ", "").replace(f"No such option: {option}", "no such option")
        return problem("command line", option or "", _sentence(text))
    if param.param_type_name == "option":
        name = next((o for o in param.opts if o.startswith("--")), param.opts[0])
    else:
        name = param.name.upper()
    return problem("command line", name, _sentence(getattr(exc, "message", "") or "missing"))


def _sentence(text: str) -> str:
    """Click's message as ecostudy words its own: lower case first, no full stop."""
    text = text.strip().removeprefix("Value error, ").removesuffix(".")  # pydantic's prefix of a ValueError
    return text[:1].lower() + text[1:] if text[1:2].islower() or text[1:2] == " " else text
