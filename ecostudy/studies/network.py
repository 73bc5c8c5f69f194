"""A network study: the fleet planned (all-out times, every segment's first run), then every
strategy run and scored by the same circuit (``network.fleet``, ``network.strategies``), over a
pool of worker processes when ``workers`` > 1. The tables and files: ``report.files.write_network``.
"""
from contextlib import nullcontext
from typing import Any, Callable, NamedTuple, Optional

from ecostudy.network import fleet, strategies
from ecostudy.studies.workers import worker_pool


class NetworkRun(NamedTuple):
    """A network study's results: the planned fleet, every strategy's outcome (``totals``,
    ``trains``, ``steps``, ``info``; a failed strategy has ``failed`` and ``wall_s`` only)."""

    fleet: Any
    outcome: dict


def run_network(st, workers: int = 1, progress: Callable[[str], None] = print,
                tick: Optional[Callable[[int, int, int, int], None]] = None) -> NetworkRun:
    """Plan the fleet of a loaded network study ``st`` and run its strategies (``progress``: a line
    each, ``tick(done, failed, remaining, total)``: the strategies' counts)."""
    with worker_pool(workers) if workers > 1 else nullcontext() as pool:
        fl = fleet.plan(st.track, st.train, st.stops, st.running_times, st.dwell, st.offsets, st.names, st.dt,
                        st.supply, st.points, st.buffer, pool, st.supplement)
        progress(f"{len(st.names)} trains, {len(st.stops) - 1} segments ({', '.join(f'{t:.1f}' for t in fl.asked_times)} s "
                 f"before rounding to {st.dt} s steps), {fl.steps} steps")
        outcome = strategies.run_strategies(fl, st.strategies, progress=progress, pool=pool, workers=workers,
                                               tick=tick)
    return NetworkRun(fl, outcome)
