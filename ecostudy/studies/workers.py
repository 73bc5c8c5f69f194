"""Worker processes that never outlive the command that started them."""
import multiprocessing
import os
import signal
import struct
import threading
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

from ecostudy.core.deadline import die_with_parent
from ecostudy.core.interrupt import STOPS, held
from ecostudy.io.store import release_inherited

STOP_WAIT_S = 10.0  # [s] the longest a stop waits for the pool to collect its killed workers (it takes ms)


def every_core(workers):
    """``workers`` as given, else every core this process may run on: the default of every study
    command (``run``, ``compare``, ``network``, ``simulate``, ``heavyhaul``); their results are the same bit for bit
    with any number of workers (tests/test_workers.py), except what is measured: wall and per-step
    solve times (slower with every core busy) and a process's peak memory."""
    return workers if workers is not None else len(os.sched_getaffinity(0))


class WorkerPool(ProcessPoolExecutor):
    """A forked process pool whose workers tell it their process IDs as they start (through a pipe,
    each ID one atomic write, no lock a killed worker could hold), so that :func:`stop_workers` can
    kill them without reading the pool's private state."""

    def __init__(self, workers):
        self.pids, write = os.pipe()  # read here; every worker writes its ID to ``write``
        os.set_blocking(self.pids, False)
        self.stopping = multiprocessing.RawValue("b", 0)  # set: a worker starting now ends at once
        super().__init__(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                         initializer=_worker_start, initargs=(write, self.stopping))
        self.write, self.seen = write, set()

    def submit(self, *args, **kwargs):
        """As the pool's, a stop signal that arrives inside raised once it returned: the first submit forks
        the workers, and Python ignores an exception raised in a fork's callbacks (logging's lock
        released in the parent), which would lose the stop."""
        with held([]):
            return super().submit(*args, **kwargs)

    def started(self):
        """The IDs of the workers started so far (read from the pipe, kept in ``seen``)."""
        while True:
            try:
                chunk = os.read(self.pids, 4096)
            except BlockingIOError:
                return self.seen
            self.seen.update(p for (p,) in struct.iter_unpack("i", chunk))

    def close_pipe(self):
        os.close(self.pids)
        os.close(self.write)


@contextmanager
def worker_pool(workers):
    """A forked process pool (workers inherit the loaded modules) whose workers die with the parent
    (SIGKILL when it dies), hold none of its store locks and leave a stop signal to it: SIGINT,
    SIGTERM and SIGHUP are ignored (Ctrl-C reaches the whole process group, as SIGTERM does from
    ``timeout``, systemd or a batch scheduler and SIGHUP from a closed terminal; the parent stores
    what reached it, then stops them). Left by an
    exception (an interrupt, or a generator closed before its end) the workers are stopped at once
    (:func:`stop_workers`), not waited for."""
    pool = WorkerPool(workers)
    try:
        yield pool
    except BaseException:
        stop_workers(pool)
        raise
    else:
        pool.shutdown()
    finally:
        pool.close_pipe()


def stop_workers(pool):
    """Stop a :class:`WorkerPool`'s worker processes now (SIGKILL: they ignore SIGTERM), whatever they
    compute: the tasks they run are lost, the others cancelled or failed. A worker forked but not yet
    registered sees ``stopping`` set after it registered and ends itself; one already gone (its pool
    broken) is not signalled (its ID may be another's now). The pool's shutdown (it sees its workers
    die and collects them) is waited for at most :data:`STOP_WAIT_S`, in a thread of its own: a stop
    never hangs on the pool's thread (which a lock left held by an exception would block forever)."""
    pool.stopping.value = 1
    for pid in pool.started():
        if _our_child(pid):
            os.kill(pid, signal.SIGKILL)
    closing = threading.Thread(target=pool.shutdown, kwargs={"wait": True, "cancel_futures": True},
                               name="ecostudy-stop-workers", daemon=True)
    closing.start()
    closing.join(STOP_WAIT_S)


def _our_child(pid):
    """Whether ``pid`` is a child of this process not yet collected (where ``os.waitid`` exists;
    elsewhere assumed)."""
    if not hasattr(os, "waitid"):
        return True
    try:
        os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
    except ChildProcessError:
        return False
    return True


@contextmanager
def arriving(futures, arrived):
    """Left by an exception (an interrupt, or its generator closed): the (case, result) of every
    future of ``futures`` ({future: case}) whose result has reached this process put in ``arrived``,
    before the workers are stopped (a task they cut short is no result)."""
    try:
        yield
    except BaseException:
        arrived.extend((case, f.result()) for f, case in futures.items()
                       if f.done() and not f.cancelled() and f.exception() is None)
        raise


def _worker_start(pids, stopping):
    die_with_parent(signal.SIGKILL)
    for stop in STOPS:
        signal.signal(stop, signal.SIG_IGN)
    os.write(pids, struct.pack("i", os.getpid()))  # atomic (a pipe, under PIPE_BUF bytes)
    if stopping.value:  # the pool was stopping when this worker registered: it may have been missed
        os._exit(1)
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
