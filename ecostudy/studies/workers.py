"""Worker processes that never outlive the command that started them."""
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor

from ecostudy.core.deadline import die_with_parent
from ecostudy.io.store import release_inherited


def every_core(workers):
    """``workers`` as given, else every core this process may run on: the default of every study
    command (``run``, ``compare``, ``network``, ``simulate``, ``heavyhaul``); their results are the same bit for bit
    with any number of workers (tests/test_workers.py), except what is measured: wall and per-step
    solve times (slower with every core busy) and a process's peak memory."""
    return workers if workers is not None else len(os.sched_getaffinity(0))


def worker_pool(workers):
    """A forked process pool (workers inherit the loaded modules) whose workers die with the parent
    and hold none of its store locks."""
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=_worker_start)


def _worker_start():
    die_with_parent()
    release_inherited()


def ticker(progress, total):
    """``tick(n)``: ``n`` more of ``total`` units of work done, reported as ``progress(done, 0,
    remaining, total)`` (the form :func:`ecostudy.studies.batch.execute` reports in; None: silent)."""
    done = [0]

    def tick(n=1):
        done[0] += n
        if progress:
            progress(done[0], 0, total - done[0], total)
    return tick


def kept(memo, key, compute):
    """``compute()`` kept in this process's ``memo`` under ``key``, one key at a time: the shared
    start of a study's cases (the ATO optimum of a comparison, the independent runs of a network
    study) solved once per worker process, while a worker never holds every study's."""
    if key not in memo:
        memo.clear()
        memo[key] = compute()
    return memo[key]
