"""A study's cases run side by side in threads of the command's process, their inner work (a network
strategy's legs) spread over one pool of worker processes that every case shares.

One case per worker process (``batch._processes``) leaves a core idle as soon as fewer cases are
left than workers: on the 20-stop network study (Farooqi 2018 Sec. 8.4) the dissension rounds ran
alone on one core for most of the study. Here every case submits its legs to the same pool as it
reaches them, so the cores stay busy while any case has legs to solve; a case's own sequential
work (a supervisor round's rule terms, the circuit) runs in its thread. The results do not depend
on this: a leg's run depends only on its task, never on which process solved it.

A worker that dies (killed for memory, a crash in a library) breaks the pool, and every case with
legs left fails with it: those cases run again in a new pool, after a second break each alone, so
that only a case whose own legs kill their worker is stored failed (as ``batch._processes`` does).
"""
from concurrent.futures import ThreadPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

from ecostudy.studies.batch import died
from ecostudy.studies.workers import arriving, worker_pool


def shared_pool(todo, workers, task, arrived=None, first=None):
    """(case, result) of every case in ``todo`` as it finishes: ``task(case, pool)`` in a thread per
    case, ``pool`` a process pool of ``workers`` that every case shares. ``first(case)``: a sort key,
    the cases started in its order (the dearest first: their legs enter the pool's queue first).
    A case failed by a broken pool runs again in a new one, then alone (:func:`died` if it breaks
    that too). Interrupted: the cases finished put in ``arrived`` (a list), the workers stopped,
    nothing new started (a case's thread ends at its next leg)."""
    arrived = [] if arrived is None else arrived
    left = sorted(todo, key=first) if first is not None else list(todo)
    for _ in range(2):
        if left:
            left = yield from _one_pool(left, workers, task, arrived)
    for case in left:
        if (yield from _one_pool([case], workers, task, arrived)):
            yield case, died(case)


def broken(pool):
    """Whether a worker of ``pool`` died (the pool then refuses every task)."""
    try:
        pool.submit(int)
    except BrokenProcessPool:
        return True
    return False


def _failed(result):
    return isinstance(result, dict) and result.get("status") == "failed"


def _one_pool(cases, workers, task, arrived):
    """(case, result) of ``cases`` sharing one pool, as they finish; returns the cases that failed
    once the pool was broken (none: it never broke)."""
    again = []
    with worker_pool(workers) as pool:
        # the pool forks all its workers at its first task: here, in the thread that outlives the pool.
        # A worker dies with the thread that forked it (die_with_parent: Linux's parent-death signal
        # follows the thread), so forked from a case's thread it was killed when the case threads ended,
        # at the pool's shutdown, once holding the task queue's lock: the other worker waited on that lock
        # for ever and the shutdown with it (a test run hung so)
        pool.submit(int).result()
        threads = ThreadPoolExecutor(max_workers=max(len(cases), 1), thread_name_prefix="case")
        futures = {threads.submit(task, case, pool): case for case in cases}
        try:
            with arriving(futures, arrived):
                for future in as_completed(futures):
                    result = future.result()
                    if _failed(result) and broken(pool):  # failed with the pool, perhaps only by it
                        again.append(futures[future])
                        continue
                    yield futures[future], result
        except BaseException:
            threads.shutdown(wait=False, cancel_futures=True)
            raise
        threads.shutdown()
    return again
