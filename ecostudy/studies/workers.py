"""Worker processes that never outlive the command that started them."""
import ctypes
import multiprocessing
import signal
from concurrent.futures import ProcessPoolExecutor

PR_SET_PDEATHSIG = 1  # linux/prctl.h


def die_with_parent():
    """Ask Linux to send SIGTERM to this process when its parent dies (a killed ``ecostudy run``
    must not leave workers computing); elsewhere nothing happens."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        pass


def worker_pool(workers):
    """A forked process pool (workers inherit the loaded modules) whose workers die with the parent."""
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=die_with_parent)


def ticker(progress, total):
    """``tick(n)``: ``n`` more of ``total`` units of work done, reported as ``progress(done, 0,
    remaining, total)`` (the form :func:`ecostudy.studies.batch.execute` reports in; None: silent)."""
    done = [0]

    def tick(n=1):
        done[0] += n
        if progress:
            progress(done[0], 0, total - done[0], total)
    return tick
