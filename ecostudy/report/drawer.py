"""Figures drawn in a second process while this one solves.

matplotlib's import with the plots module takes about 0.6 s and a run's two figures about 0.3 s
more: in one process that is a quarter of ``ecostudy solve``. A :class:`Drawer` forks a child
before the solve; the child imports matplotlib and :mod:`ecostudy.report.plots` on the other core
while the parent solves, then waits. The parent sends it the figures (their plot functions and
data, pickled: :func:`ecostudy.report.files.later`) as soon as the result is known and writes its
tables meanwhile; the child writes the figures and answers with their file names, or with the
error that stopped it, which the parent raises as its own (same type, so the same one line and
exit status as a figure drawn in this process; the child's traceback is attached as a note). The
parent waits for that answer, then for the child's exit, before it writes ``summary.json`` and
``report.html``: every file exists when the command returns, and no process is left behind. The
child draws a run's figures side by side (:func:`apart`: the second in a fork of the warm child):
the wait is the longer figure's, not their sum.

Where a child cannot be forked (no ``fork`` start method, or in a daemonic worker, which may not
start processes) or the data cannot be pickled, the figures are drawn in this process as before.
"""
import io
import multiprocessing
import os
import pickle
import signal
import sys
import traceback
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Optional

from ecostudy.core.deadline import can_fork, die_with_parent
from ecostudy.core.errors import EcostudyError
from ecostudy.core.interrupt import TERMINATE


class FigureError(EcostudyError):
    """The figure process failed in a way that has no exception of its own to raise here (it died,
    or its error could not be sent back); ``exit_code`` 3 as any internal failure."""


_serving = [False]  # True in the figure process


def _end_through_python() -> None:
    """In a figure process (after ``die_with_parent``, which ends it at once on SIGTERM or SIGHUP):
    end it through Python instead, so a figure being written leaves no temporary file beside its
    name (``io.writers.atomic_write`` removes it as the exit passes). A ``kill`` of the command's
    process group left ``.speed.png<random>.tmp`` in the output folder in 4 of 12 tries."""
    for stop in TERMINATE:
        if signal.getsignal(stop) is not signal.SIG_IGN:
            signal.signal(stop, _exit)


def _exit(signum: int, _frame: Any) -> None:
    raise SystemExit(128 + signum)


def _serve(conn, other) -> None:
    """The child: import the plotting code at once, then run each job ``(work, args)`` sent and
    answer ``("ok", value)`` or ``("error", exception or its text, traceback)``; ``None`` or a closed
    pipe (the parent gone) ends it."""
    _serving[0] = True
    other.close()  # the parent's end: when the parent goes, this side reads end-of-file
    die_with_parent()
    _end_through_python()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle; it stops this child
    failed: Optional[BaseException] = None
    try:
        import matplotlib
        matplotlib.use("Agg")
        from matplotlib.figure import Figure

        from ecostudy.report import plots  # noqa: F401  (loaded while the parent solves)
        warm = Figure()  # a first figure loads the fonts and the renderer: 0.08 s off the wait
        warm.subplots().plot([0, 1], label="m")
        warm.savefig(io.BytesIO(), format="png")
    except Exception as exc:  # noqa: BLE001 - reported with the first job
        failed = exc
    while True:
        try:
            job = conn.recv_bytes()
        except (EOFError, OSError):
            return
        if not job:
            return
        try:
            if failed is not None:
                raise failed
            work, args = pickle.loads(job)
            answer: tuple = ("ok", work(*args))
        except Exception as exc:  # noqa: BLE001 - sent to the parent, which raises it
            answer = ("error", exc, traceback.format_exc())
        try:
            conn.send_bytes(_pickled(answer))
        except OSError:  # the parent stopped waiting (its own write failed) and closed its end: nothing to tell
            return


def apart(work: Callable[..., Any], jobs: list[tuple]) -> list[Any]:
    """``[work(*args) for args in jobs]``, the first here and each other one in a process forked for
    it, so that a run's figures draw side by side on both cores (called in the figure process, where
    matplotlib is loaded and warm: the forks start ready to draw). Values in the order of ``jobs``;
    the first error raised as it was raised (same type; its traceback attached as a note), once
    every forked process has been waited for. Anywhere but in the figure process (work drawn in the
    parent: data that cannot be pickled) the jobs run here, one after the other."""
    if not _serving[0] or not jobs:
        return [work(*args) for args in jobs]
    forked = []
    for args in jobs[1:]:
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:  # the fork: draw, send the value or the error, leave without any clean-up
            try:
                os.close(read)
                die_with_parent()
                _end_through_python()
                try:
                    answer: tuple = ("ok", work(*args))
                except BaseException as exc:  # noqa: BLE001 - sent back and raised there
                    answer = ("error", exc, traceback.format_exc())
                with os.fdopen(write, "wb") as pipe:
                    pipe.write(_pickled(answer))
            finally:
                os._exit(0)  # never back into the figure process's loop
        os.close(write)
        forked.append((pid, read))
    answers: list[tuple] = []
    try:
        answers.append(("ok", work(*jobs[0])))
    finally:
        for pid, read in forked:
            with os.fdopen(read, "rb") as pipe:
                data = pipe.read()
            status = os.waitpid(pid, 0)[1]
            answers.append(pickle.loads(data) if data else
                           ("error", FigureError(f"figures: a figure's process ended (exit code "
                                                 f"{os.waitstatus_to_exitcode(status)}) before it answered"), ""))
    values = []
    for kind, value, *where in answers:
        if kind != "ok":
            error = value if isinstance(value, BaseException) else FigureError(f"figures: {value}")
            if where and where[0]:
                error.add_note("in a figure's process:\n" + where[0].rstrip())
            raise error
        values.append(value)
    return values


def _pickled(answer: tuple) -> bytes:
    """``answer`` pickled; an error that cannot travel goes as its text."""
    try:
        return pickle.dumps(answer)
    except Exception:  # noqa: BLE001
        return pickle.dumps(("error", f"{type(answer[1]).__name__}: {answer[1]}", answer[2]))


class Drawer:
    """A forked child that draws what :meth:`submit` sends it (see the module's docstring). Close it
    with :meth:`close` (:func:`drawing` does)."""

    def __init__(self) -> None:
        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe()
        sys.stdout.flush()  # nothing buffered is copied into the child
        sys.stderr.flush()
        self.process = ctx.Process(target=_serve, args=(child, self.conn), daemon=True, name="ecostudy-figures")
        self.process.start()
        child.close()

    def submit(self, work: Callable[..., Any], *args: Any) -> Callable[[], Any]:
        """Send ``work(*args)`` to the child; returns the function that waits for its value (and
        raises its error). Data that cannot be pickled is drawn here at once."""
        try:
            job = pickle.dumps((work, args), protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:  # noqa: BLE001 - e.g. a plot bound to a local function: drawn in this process
            value = work(*args)
            return lambda: value
        try:
            self.conn.send_bytes(job)
        except OSError:
            raise self._ended() from None
        return self._answer

    def _answer(self) -> Any:
        try:
            kind, value, *where = pickle.loads(self.conn.recv_bytes())
        except (EOFError, OSError):
            raise self._ended() from None
        if kind == "ok":
            return value
        error = value if isinstance(value, BaseException) else FigureError(f"figures: {value}")
        error.add_note("in the figure process:\n" + where[0].rstrip())
        raise error

    def _ended(self) -> FigureError:
        self.process.join(5.0)
        return FigureError(f"figures: the figure process ended (exit code {self.process.exitcode}) before it "
                           "answered")

    def close(self) -> None:
        """Tell the child to end and wait for it (terminated if it does not end in 10 s)."""
        try:
            self.conn.send_bytes(b"")
        except OSError:
            pass
        self.conn.close()
        self.process.join(10.0)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join()


@contextmanager
def drawing(plot: bool) -> Iterator[Optional[Drawer]]:
    """A :class:`Drawer` while the block runs, when ``plot`` and a child can be forked (else None:
    draw in this process); the child has ended when the block is left, however it is left."""
    drawer = Drawer() if plot and can_fork() else None
    try:
        yield drawer
    finally:
        if drawer is not None:
            drawer.close()
