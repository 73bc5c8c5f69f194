"""Work that must stop at a deadline, whatever it is doing: run in a forked child process that
reports its progress through a pipe and is killed when the time is up.

A solver that checks its time limit only between its iterations (MindtPy does, and its set-up and
each NLP or MILP it starts run to their end) can overrun the limit by minutes. In a child process
the deadline holds: the parent keeps every message the child posted before it was stopped (the
best solution found so far, say) and knows whether the work finished, failed or was stopped.
"""
import ctypes
import multiprocessing
import os
import signal
import time
import traceback
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any, Callable

from ecostudy.core.interrupt import TERMINATE

Work = Callable[..., Any]  # work(post, *args): post(message) sends a message to the parent

PR_SET_PDEATHSIG = 1  # linux/prctl.h


def die_with_parent(sig: int = signal.SIGTERM) -> None:
    """Ask Linux to send ``sig`` to this process when its parent dies (a killed command must not
    leave children computing; elsewhere nothing is sent), and let SIGTERM and SIGHUP end it at once:
    a forked child inherits the command's own handler, which turns them into KeyboardInterrupt
    (:mod:`ecostudy.core.interrupt`) for the command to handle, not its children. One the command
    ignores (SIGHUP under ``nohup``) stays ignored."""
    for stop in TERMINATE:
        if signal.getsignal(stop) is not signal.SIG_IGN:
            signal.signal(stop, signal.SIG_DFL)
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, sig)
    except (OSError, AttributeError):
        pass


def can_fork() -> bool:
    """Whether this process may start a forked child: a ``fork`` platform, and not a daemonic worker
    (Dask's, a pool's), which may not start processes."""
    return "fork" in multiprocessing.get_all_start_methods() and not multiprocessing.current_process().daemon


@dataclass
class Ended:
    """How a :func:`run_until` ended: ``finished`` with ``value``; ``stopped`` at the deadline;
    or ``error`` (the child's exception, or how it died). ``posts``: what the child sent before."""

    seconds: float
    finished: bool = False
    stopped: bool = False
    value: Any = None
    error: str | None = None
    posts: list[Any] = field(default_factory=list)


def _child(conn: Connection, work: Work, args: tuple[Any, ...]) -> None:
    die_with_parent()
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # solver lines (C-level prints too) are not the command's output
    os.dup2(devnull, 2)
    try:
        conn.send(("done", work(lambda message: conn.send(("post", message)), *args)))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which decides
        conn.send(("error", f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=3)}"))
    finally:
        conn.close()


def run_until(seconds: float, work: Work, *args: Any,
              tick: Callable[[float, list[Any]], None] | None = None) -> Ended:
    """``work(post, *args)`` in a forked child, stopped (SIGTERM, then SIGKILL) ``seconds`` after
    the start. ``post(message)`` sends a picklable message to the parent at once. ``tick(elapsed,
    posts)``, if given, is called in the parent about twice a second while it waits (progress)."""
    t0 = time.perf_counter()
    if not can_fork():                 # a daemonic worker (Dask's) may not start children:
        return _inline(t0, work, args)  # the work runs here, held only by its own limit
    receive, send = multiprocessing.Pipe(duplex=False)
    child = multiprocessing.get_context("fork").Process(target=_child, args=(send, work, args), daemon=True)
    child.start()
    send.close()
    ended = Ended(seconds=0.0)
    while True:
        left = seconds - (time.perf_counter() - t0)
        if tick is not None:
            tick(min(seconds - left, seconds), ended.posts)
        if left <= 0:
            ended.stopped = True
            break
        try:
            if not receive.poll(min(left, 0.5)):
                if not child.is_alive() and not receive.poll(0):
                    ended.error = f"the process stopped with exit code {child.exitcode}"
                    break
                continue
            kind, payload = receive.recv()
        except (EOFError, OSError):
            ended.error = f"the process stopped with exit code {child.exitcode}"
            break
        if kind == "post":
            ended.posts.append(payload)
        elif kind == "done":
            ended.finished, ended.value = True, payload
            break
        else:
            ended.error = payload
            break
    _stop(child)
    if ended.stopped:  # what the child posted just before it was stopped
        _drain(receive, ended)
    receive.close()
    ended.seconds = time.perf_counter() - t0
    return ended


def _inline(t0: float, work: Work, args: tuple[Any, ...]) -> Ended:
    ended = Ended(seconds=0.0)
    try:
        ended.value, ended.finished = work(ended.posts.append, *args), True
    except Exception as exc:  # noqa: BLE001 - reported as the child's would be
        ended.error = f"{type(exc).__name__}: {exc}"
    ended.seconds = time.perf_counter() - t0
    return ended


def _drain(receive: Connection, ended: Ended) -> None:
    try:
        while receive.poll(0):
            kind, payload = receive.recv()
            if kind == "post":
                ended.posts.append(payload)
    except Exception:  # noqa: BLE001 - a message cut off by the kill is not a message
        pass


def _stop(child: BaseProcess) -> None:
    child.join(0.5 if child.is_alive() else None)
    if child.is_alive():
        child.terminate()
        child.join(2.0)
    if child.is_alive():
        child.kill()
        child.join()
