"""Leg runs shared by the strategies of one study in one process (:class:`LegRuns`).

Several strategies pose some of the same leg tasks: on the 3-train metro study the first train's
first leg runs alone before the second train departs, so every supervisor rule's first round gives
it the same weights, allowance and credit, and rule 7.11 weighs the first train as the receptivity
credit alone does (``rules.rule_terms``), so its first round poses all of that train's legs as the
receptivity rounds do. A leg's run depends only on its task (``legs.solve_leg``), so such a task is
solved once and its run handed to every strategy that poses it.
"""
import copy
import hashlib
import threading
from concurrent.futures import Future

import numpy as np


def task_key(task, terms):
    """A digest of what a leg task's run depends on: the leg (its label names train and leg), the
    clock step, the buffer, the start, whether warm, and ``terms``: the weights, allowance, credit
    and train ahead on the leg's own steps (``fleet._own_terms``: ``solve_leg`` reads no other step)."""
    _, label, dt, buffer, guess, warm, *_ = task
    digest = hashlib.sha1(repr((label, dt, buffer, warm)).encode())
    for a in (*guess, *terms):
        if a is None:
            digest.update(b"none")
            continue
        a = np.ascontiguousarray(a, dtype=float)
        digest.update(repr(a.shape).encode())
        digest.update(a.tobytes())
    return digest.hexdigest()


class LegRuns:
    """(run, outcome) of each leg task solved in this process, by :func:`task_key`: a task posed
    again (by another strategy, or by two at once from their threads) is not solved again, and the
    results are those of solving it every time. Pickled empty (a process keeps its own)."""

    def __init__(self):
        self._lock = threading.Lock()
        self._runs = {}  # key -> Future of (run, outcome); None where its solve failed
        self.hits = 0  # tasks handed a run solved for another

    def __getstate__(self):
        return {}

    def __setstate__(self, state):
        self.__init__()

    def map(self, mapper, solve, tasks, keys):
        """[(run, outcome)] of ``solve`` (``legs.solve_leg``) over ``tasks`` (``mapper``: ``map`` or a
        pool's), each task not known yet solved here, the others taken (a copy) from the strategy that
        solved them."""
        with self._lock:
            mine = [n for n, key in enumerate(keys) if key not in self._runs]
            for n in mine:
                self._runs[keys[n]] = Future()
            futures = [self._runs[key] for key in keys]
        try:
            for n, out in zip(mine, mapper(solve, [tasks[n] for n in mine])):
                futures[n].set_result(out)
        except BaseException:
            self._forget([(keys[n], futures[n]) for n in mine])
            raise
        outs = [future.result() for future in futures]
        failed = [n for n, out in enumerate(outs) if out is None]  # another's solve raised: solved here
        if failed:
            for n, out in zip(failed, self.map(mapper, solve, [tasks[n] for n in failed], [keys[n] for n in failed])):
                outs[n] = out
        mine_set = set(mine) | set(failed)
        with self._lock:
            self.hits += len(outs) - len(mine_set)
        return [out if n in mine_set else copy.deepcopy(out) for n, out in enumerate(outs)]

    def _forget(self, pending):
        """The unfinished of ``pending`` (key, future) dropped, their waiters told to solve them."""
        with self._lock:
            for key, future in pending:
                if not future.done():
                    del self._runs[key]
                    future.set_result(None)
