"""Several trains on one line and one substation: the timetable on one clock (:class:`Fleet`),
and one train's legs solved against weights, credits and a train ahead (:func:`solve_train`).

Every train runs the same stops with the same running times and dwells, offset by its departure
time, on one clock of step dt (``ocp.timedomain``). The strategies are in :mod:`.strategies`.
"""
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Optional

import numpy as np

from ecostudy.analysis.single import solve_run
from ecostudy.core.defaults import FRONT_POINTS
from ecostudy.core.errors import InfeasibleError
from ecostudy.core.types import Timing
from ecostudy.core.types import Supply
from ecostudy.io.timetable import clock_steps
from ecostudy.network.legs import leg_energy_ref, solve_leg, warmth
from ecostudy.network.shared import LegRuns, task_key
from ecostudy.ocp import session
from ecostudy.ocp import timedomain
from ecostudy.ocp.problem import prepare


@dataclass
class Fleet:
    """The timetable of every train on the clock: legs[train][segment]."""

    names: list
    legs: list
    dt: float
    steps: int
    supply: Supply
    buffer: Optional[float] = None
    results: dict = field(default_factory=dict)  # space-domain net-energy runs per segment (guesses)
    dwell_steps: int = 0
    asked_times: Optional[list] = None  # running time per segment before rounding to whole steps [s]
    timetabled: bool = False  # the running times are the study's own (running_times_s), not a supplement's
    # how Ipopt ended each segment's all-out run a running time was taken from (a supplement over it)
    all_out_solver: dict = field(default_factory=dict)
    # the leg tasks solved in this process, shared by the strategies that pose the same (:mod:`.shared`)
    solved: LegRuns = field(default_factory=LegRuns, compare=False, repr=False)


def plan(track, train, stops, running_times, dwell, offsets, names, dt, supply, points=FRONT_POINTS, buffer=None,
         pool=None, supplement=0.0, check=None):
    """A :class:`Fleet`: running times rounded up to whole steps, departures offset; the dwell and
    the departures ``offsets`` [s] on the clock (else ValueError: they are not moved); each
    segment's space-domain net-energy run (the legs' first guess) solved.

    ``running_times`` [s] per segment, or None: each segment's all-out time plus ``supplement``
    (a fraction). ``pool``: a process pool (else this process); a segment's first run is submitted
    as soon as its running time is known, so all-out and first runs of different segments overlap.
    ``check(fleet)``: called with the timetable (a :class:`Fleet` without runs) as soon as its running
    times are known: before anything is solved where ``running_times`` are given."""
    _on_clock(dwell, offsets, dt)  # before anything is prepared
    cases = [prepare(track, train, a, b, points) for a, b in zip(stops[:-1], stops[1:])]
    if check is not None and running_times is not None:
        check(_timetable(track, stops, cases, running_times, dwell, offsets, names, dt, supply, buffer))
    asked, firsts, ended = _first_runs(track, train, cases, running_times, supplement, dt, points, pool)
    out = _timetable(track, stops, cases, asked, dwell, offsets, names, dt, supply, buffer)
    if check is not None and running_times is None:
        check(out)
    out.timetabled = running_times is not None
    out.results = {(c.segment.from_stop, c.segment.to_stop): r for c, r in zip(cases, firsts)}
    out.all_out_solver = {pair: status for pair, status in zip(out.results, ended) if status is not None}
    return out


def _timetable(track, stops, cases, asked, dwell, offsets, names, dt, supply, buffer):
    """The :class:`Fleet` of running times ``asked`` [s] per segment, without its first runs."""
    steps = [_steps(t, dt) for t in asked]
    pause, starts = _on_clock(dwell, offsets, dt)
    legs = []
    for start in starts:
        mine = []
        for case, n, a in zip(cases, steps, stops[:-1]):
            b = stops[stops.index(a) + 1]
            direction = 1.0 if track.stops[b] >= track.stops[a] else -1.0
            mine.append(timedomain.Leg(case, start, n, dt, track.stops[a], direction))
            start += n + pause
        legs.append(mine)
    total = max(leg.start + leg.steps for mine in legs for leg in mine)
    return Fleet(list(names), legs, dt, total, supply, buffer, {}, pause, list(asked))


def late_at_stops(fleet):
    """(stop, seconds [s] after the timetable) per stop after the first: each leg runs whole clock
    steps, its asked running time rounded up, and the dwells stay whole steps, so a train's lateness
    at a stop is the sum of its legs' roundings so far (every train runs the same segment times: the
    first train's legs stand for all)."""
    over = np.cumsum([leg.running_time - asked for leg, asked in zip(fleet.legs[0], fleet.asked_times or [])])
    return [(leg.case.segment.to_stop, float(late)) for leg, late in zip(fleet.legs[0], over)]


def _on_clock(dwell, offsets, dt):
    """(the dwell, each departure) in whole clock steps; ValueError where one falls between two
    steps: the clock cannot honour it, and it is not moved (a study file's are refused on loading,
    ``io.timetable.off_clock``)."""
    pause, starts = clock_steps(dwell, dt), [clock_steps(offset, dt) for offset in offsets]
    if pause is None or None in starts:
        raise ValueError(f"dwell {dwell:g} s or a departure of {offsets} s is not on the {dt:g} s clock")
    return pause, starts


def _steps(seconds, dt):
    """Whole clock steps covering ``seconds``."""
    return int(np.ceil(seconds / dt - 1e-9))


def _first_runs(track, train, cases, running_times, supplement, dt, points, pool):
    """(running time asked [s], net-energy run at it rounded up to whole steps, how Ipopt ended the
    all-out run the time is a supplement over (None: a time given)) per segment."""
    pairs = [(c.segment.from_stop, c.segment.to_stop) for c in cases]

    def first(k, seconds):
        return (track, train, *pairs[k], _steps(seconds, dt) * dt, points)

    def all_out(k):
        return (track, train, *pairs[k], points)

    submit = pool.submit if pool is not None else _done
    asked = list(running_times) if running_times is not None else [None] * len(pairs)
    runs, ended = [None] * len(pairs), [None] * len(pairs)
    jobs = {(submit(_all_out_time, all_out(k)) if t is None else submit(_net_energy_run, first(k, t))):
            (t is None, k) for k, t in enumerate(asked)}
    pending, infeasible = set(jobs), {}
    while pending:
        done, pending = wait(pending, return_when=FIRST_COMPLETED)
        for job in done:
            timing, k = jobs[job]
            try:
                result = job.result()
            except InfeasibleError as exc:  # every segment's, each named: not one fix and run at a time
                infeasible[k] = [f"[{k}] {pairs[k][0]} -> {pairs[k][1]}: {p}" for p in exc.problems]
                continue
            if timing:
                fastest, ended[k] = result
                asked[k] = fastest * (1 + supplement)
                follow = submit(_net_energy_run, first(k, asked[k]))
                jobs[follow] = (False, k)
                pending.add(follow)
            else:
                runs[k] = result
    if infeasible:
        raise InfeasibleError([p for k in sorted(infeasible) for p in infeasible[k]])
    return asked, runs, ended


def _done(fn, *args):
    """``fn(*args)`` run now, as a finished future (the one-process stand-in for ``pool.submit``; its
    error raised by ``result()``, as a pool's)."""
    job = Future()
    try:
        job.set_result(fn(*args))
    except Exception as exc:  # noqa: BLE001 - handed over as a pool hands it
        job.set_exception(exc)
    return job


def _net_energy_run(task):
    """(track, train, from, to, running time [s], K) -> the space-domain net-energy run (a guess)."""
    track, train, a, b, running_time, points = task
    return solve_run(track, train, a, b, Timing(running_time=running_time), objective="net_energy",
                     points=points, verify_result=False)


def all_out_times(track, train, stops, points, mapper=map):
    """Minimum running time [s] of each segment between consecutive ``stops`` (``mapper``: how
    the segments are mapped over, ``map`` or a process pool's)."""
    return [t for t, _ in mapper(_all_out_time, [(track, train, a, b, points) for a, b in zip(stops[:-1], stops[1:])])]


def _all_out_time(task):
    """(track, train, from, to, K) -> (the all-out time [s], how Ipopt ended its run)."""
    track, train, a, b, points = task
    r = solve_run(track, train, a, b, Timing(), objective="time", points=points, verify_result=False)
    return r.summary["running_time_s"], r.facts.solver.status


def _guess(fleet, leg):
    seg = leg.case.segment
    return timedomain.guess_from_space(fleet.results[(seg.from_stop, seg.to_stop)], leg)


REGULARISATION = 1e-3  # [-] weight of rheostat power and bus-voltage offset in the joint objective


def solve_model(m, what, options=None):
    out = session.solve(m, options)
    if not out.usable:
        raise out.failure(what)
    return out


def energy_ref(fleet):
    """Objective scale [kJ]: :func:`leg_energy_ref` summed over one train's legs."""
    return sum(leg_energy_ref(leg) for leg in fleet.legs[0])


def solve_train(fleet, i, weights=None, guesses=None, ahead=None, allowance=None, credit=None, mapper=map,
                memo=None, check=True):
    """Train ``i`` alone: minimise sum (w_t traction - regeneration) dt over its legs.

    ``weights``: traction weight per clock step (default 1). ``allowance``: power [kW] per clock
    step that the weight applies to; traction above it costs in full:
    w min(P, a) + max(P - a, 0) = w P + (1 - w) max(P - a, 0). ``ahead``: the line position of the
    train ahead per clock step (NaN where it is not on the line) to stay ``fleet.buffer`` behind.
    The objective is a sum over the legs and every constraint lies within one leg (the dwell fixes
    each leg's ends), so the legs are solved one by one, each at its own objective scale: the same
    problem as one NLP of all legs, 2.3x cheaper on the 19-leg regional study and no worse (the
    leg NLP is flat: one NLP of the whole train stopped up to 2.8 % above the legs' own optima;
    docs/benchmarks.md). ``mapper``: how the legs are mapped over (``map``, or a process pool's).
    ``memo``: a dict kept across calls (the supervisor rounds); a leg whose weights, allowance,
    credit and train ahead over its own steps are those of its last solve, started from that
    solve's run, is that run again and is not solved (the same problem from its own optimum).
    ``check``: whether warm legs of the sample (``legs.warmth``) are also solved cold (the
    supervisor rounds check in their first round only: ``rules.supervised``).
    Returns ([(s, v, ft, fb, fr, p) per leg], [solver outcome per leg]).
    """
    memo = {} if memo is None else memo
    known = [memo.get((i, k)) for k in range(len(fleet.legs[i]))]
    tasks = [(leg, f"train {fleet.names[i]}, leg {k + 1}", fleet.dt, fleet.buffer,
              guesses[k][:5] if guesses is not None else _guess(fleet, leg),
              (warmth(i, k) if check else True) if guesses is not None else False, weights, allowance, credit, ahead)
             for k, leg in enumerate(fleet.legs[i])]
    terms = [_own_terms(leg, weights, allowance, credit, ahead) for leg in fleet.legs[i]]
    again = [k for k, old in enumerate(known) if old is None or guesses is None or old[1] is not guesses[k]
             or not _same(old[0], terms[k])]
    solved = dict(zip(again, fleet.solved.map(mapper, solve_leg, [tasks[k] for k in again],
                                              [task_key(tasks[k], terms[k]) for k in again])))
    for k, (run, outcome) in solved.items():
        memo[(i, k)] = (terms[k], run, outcome)
    out = [solved[k] if k in solved else known[k][1:] for k in range(len(tasks))]
    return [run for run, _ in out], [outcome for _, outcome in out]


def _own_terms(leg, *arrays):
    """The parts of per-clock-step arrays (None: none) on a leg's step boundaries."""
    span = slice(leg.start, leg.start + leg.steps + 1)
    return tuple(None if a is None else np.asarray(a, float)[span] for a in arrays)


def _same(a, b):
    """Whether two tuples of :func:`_own_terms` hold the same arrays (NaN equal to NaN)."""
    return all((x is None and y is None) or (x is not None and y is not None and np.array_equal(x, y, equal_nan=True))
               for x, y in zip(a, b))


def line_positions(fleet, i, runs):
    """Line position of train ``i`` per clock step (NaN before departure and after arrival); of
    expressions where the runs' ``s`` are arrays of variables (the joint NLP's separation rows)."""
    x = np.full(fleet.steps + fleet.dwell_steps + 1, np.nan, dtype=np.asarray(runs[0].s).dtype)
    for k, (leg, run) in enumerate(zip(fleet.legs[i], runs)):
        x[leg.start:leg.start + leg.steps + 1] = leg.line_start + leg.direction * run.s
        end = leg.start + leg.steps
        nxt = fleet.legs[i][k + 1].start if k + 1 < len(fleet.legs[i]) else end + fleet.dwell_steps + 1
        x[end:nxt] = leg.line_start + leg.direction * run.s[-1]  # dwelling (at the terminus too)
    return x


def following_legs(fleet, blocks):
    """(train behind, train ahead, leg, its block, the train ahead's line position per clock step)
    for every leg of every train behind another (departure order), ``blocks[train][leg]`` leg
    blocks of one NLP: the train ahead's positions expressions of its own blocks' variables (the
    joint NLP's separation rows)."""
    order = departure_order(fleet)
    for ahead, me in zip(order[:-1], order[1:]):
        x = line_positions(fleet, ahead, [SimpleNamespace(s=np.array([b.s[j] for j in b.K], dtype=object))
                                          for b in blocks[ahead]])
        for leg, b in zip(fleet.legs[me], blocks[me]):
            yield me, ahead, leg, b, x


def step_arrays(fleet, runs_by_train):
    """(line positions [m], pantograph powers [W]) per clock step and train, shape (steps, trains):
    the middle of each step a train runs, NaN (power 0) while it waits or dwells."""
    x = np.full((fleet.steps, len(runs_by_train)), np.nan)
    p = np.zeros((fleet.steps, len(runs_by_train)))
    for i, runs in enumerate(runs_by_train):
        for leg, run in zip(fleet.legs[i], runs):
            span = slice(leg.start, leg.start + leg.steps)
            x[span, i] = leg.line_start + leg.direction * 0.5 * (run.s[:-1] + run.s[1:])
            p[span, i] = run.p
    return x, p


def departure_order(fleet):
    """Train indices in order of first departure: each one's train ahead is the one before it."""
    return [int(i) for i in np.argsort([legs[0].start for legs in fleet.legs], kind="stable")]
