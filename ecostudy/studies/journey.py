"""Multi-stop journeys: how to spread a total running-time supplement over the segments.

Each segment's energy-optimal front E_i(T_i) is convex and decreasing (ecostudy.pareto). For a
total running time the least total energy has equal marginal saving -dE_i/dT_i on every segment
that gets a supplement (Lagrange; Farooqi 2018 §7.1.1 fronts). The allocation is made on the
fronts, linearly interpolated, by handing out small time steps to the segment whose next step
saves most; every segment is then solved exactly at its allocated time and verified.
Two baselines: every segment the same percentage over its all-out time, and a MARECO-style
split (the time each segment takes under one common MARECO speed cap v1, ecostudy/heuristics/mareco.py: the
way OSRD's MARECO allowance spreads a margin over a whole path). Every distribution is then
driven energy-optimally, so the comparison is about the split alone. The whole-journey NLP
(:func:`whole_journey`) solves all segments at once with free running times summing to the total:
the exact split the fronts approximate.
"""
import heapq
import math

import numpy as np
import pandas as pd
import pyomo.environ as pyo
from scipy.interpolate import PchipInterpolator

from ecostudy.analysis.single import solve_run
from ecostudy.core.defaults import FRONT_POINTS, SLOWEST
from ecostudy.core.errors import FieldError, InfeasibleError, SolverError
from ecostudy.core.kinematics import running_time
from ecostudy.core.simulate import window_checks
from ecostudy.core.status import OK, Status, failed, flagged, solver_part, worst
from ecostudy.core.types import Timing, Window
from ecostudy.core.units import apart, to_kmh
from ecostudy.heuristics import mareco
from ecostudy.io.timetable import schedule
from ecostudy.ocp import session
from ecostudy.ocp.problem import (ALL_OUT_MARGIN, Written, build, capped_guess, check_windows, crawling, prepare,
                                  under_envelope)
from ecostudy.ocp.space import passing_time
from ecostudy.studies.pareto import sweep
from ecostudy.studies.reachable import check_reachable
from ecostudy.studies.workers import ticker

FRONT_COUNT = 15  # points of each segment's front
NEAR_BELOW, NEAR_SPLIT = 0.10, (0.5, 1.0, 1.5, 2.0)  # a mean supplement below NEAR_BELOW: front points at these multiples


def too_short(total_time, fastest, basis=""):
    """Refuse a journey whose total time is below the sum of the segments' all-out times."""
    total, least = apart(total_time, fastest)
    raise InfeasibleError(f"infeasible: the total time {total} s is below the sum of the all-out times "
                          f"{least} s{basis}")


def segment_time(t, all_out, envelope):
    """The running time [s] a segment is solved at for a split's ``t``: ``t``, or the all-out NLP's
    time ``all_out`` where ``t`` lies between that and the kinematic envelope's time ``envelope``
    on the same grid (``prepare(...).estimate``), less ``check_feasible``'s own margin.
    Both are the segment's fastest run, discretised two ways; they differ by the grid's accuracy
    (metro line, K = 100: 0.14-0.32 %; K = 1000: 0.014-0.032 %), and a split computed on the envelope
    (MARECO-style at supplement 0) can fall between them. Below both: no run, refused by the solve."""
    return all_out if min(all_out, envelope) * (1 - ALL_OUT_MARGIN) <= t < all_out else t


def equal_marginal(fronts, total_time, step=0.05):
    """Running time per segment [s] minimising total energy on the interpolated fronts."""
    times = [float(f["running_time_s"].iloc[0]) for f in fronts]
    spare = total_time - sum(times)
    if spare < -1e-9:
        too_short(total_time, sum(times))

    # monotone cubic (PCHIP) through each front: the fronts are convex, and straight chords
    # between 15 points put the split 0.6 % above the whole-journey NLP where PCHIP is within 0.1 %
    curves = []
    for f in fronts:
        t, keep = np.unique(f["running_time_s"].to_numpy(), return_index=True)
        curves.append(PchipInterpolator(t, f["traction_energy_kWh"].to_numpy()[keep]))
    ends = [float(f["running_time_s"].iloc[-1]) for f in fronts]

    def energy(i, t):  # flat beyond the front's last point
        return float(curves[i](min(t, ends[i])))

    def saving(i):  # energy saved by the next step on segment i (fronts end flat)
        return energy(i, times[i]) - energy(i, times[i] + step)

    heap = [(-saving(i), i) for i in range(len(fronts))]
    heapq.heapify(heap)
    while spare > 1e-9:
        _, i = heapq.heappop(heap)
        dt = min(step, spare)
        times[i] += dt
        spare -= dt
        heapq.heappush(heap, (-saving(i), i))
    return times


def uniform(fronts, total_time):
    """Running time per segment [s] with the same supplement over every all-out time."""
    base = np.array([float(f["running_time_s"].iloc[0]) for f in fronts])
    return list(base * total_time / base.sum())


def mareco_split(track, train, pairs, total_time, points, floors=None):
    """Running time per segment [s]: each segment's MARECO-style time for the one cap v1 that
    makes the total ``total_time`` (bisection; the total falls as v1 rises). ``floors``: the
    segments' fastest runs on the grid [s] (the all-out NLP's): a MARECO time below its floor (the
    envelope integrated exactly runs faster than the grid allows) counts as the floor, so the
    times the segments are solved at still sum to ``total_time``."""
    cases = [prepare(track, train, a, b, points) for a, b in pairs]
    floors = [0.0] * len(cases) if floors is None else floors

    def times(v1):
        return [max(running_time(mareco.profile(c, v1), c.nodes), low) for c, low in zip(cases, floors)]

    lo, hi = 0.5, max(mareco.cap_ceiling(c) for c in cases)
    if sum(times(hi)) > total_time:
        raise InfeasibleError(f"the total time {total_time:.1f} s is below the MARECO-style runs' fastest "
                              f"{sum(times(hi)):.1f} s")
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if sum(times(mid)) > total_time else (lo, mid)
    split = times(hi)
    scale = total_time / sum(split)  # the bisection's last 1e-12 relative
    return [t * scale for t in split]


def _segments_model(cases, start_times):
    """One Pyomo model with every segment's NLP as a block (``run.build``), each running time T_n
    free, total traction work minimised; the caller ties the T_n together. Returns (model, blocks)."""

    m = pyo.ConcreteModel()
    parts = []
    for n, (case, t) in enumerate(zip(cases, start_times)):
        part = build(case, capped_guess(case, t), "energy", {}, running_time=t)
        part.objective.deactivate()
        part.T.setlb(0.0)
        part.T.setub(None)
        m.add_component(f"segment{n}", part)
        parts.append(part)
    m.objective = pyo.Objective(expr=sum(p.traction_work for p in parts) / max(p.energy_ref for p in parts))
    return m, parts


def _solve_times(m, parts, what, options=None):
    """Solve the journey model (Ipopt ``options``): its running times [s] and their status, ``ok``
    when Ipopt proved them optimal, else ``flagged`` naming ``what`` and how Ipopt ended."""

    outcome = session.solve(m, options)
    if outcome.status in ("infeasible", "restoration_failed"):
        raise InfeasibleError(f"infeasible: no run of {what} ({outcome.status})")
    if not outcome.usable:
        raise outcome.failure(what)
    return [float(pyo.value(p.T)) for p in parts], solver_part(what, outcome.status)


def whole_journey(track, train, pairs, total_time, start_times, points, options=None):
    """(running times [s], their status) from one NLP over all segments (:func:`_segments_model`),
    the running times summing to ``total_time``. The exact optimum the equal-marginal split
    approximates on interpolated fronts. Started from ``start_times`` (e.g. that split)."""

    m, parts = _segments_model([prepare(track, train, a, b, points) for a, b in pairs], start_times)
    m.total = pyo.Constraint(expr=sum(p.T for p in parts) / total_time == 1.0)
    return _solve_times(m, parts, "the whole-journey NLP", options)


def windowed_journey(track, train, plan, points, start_times=None, options=None):
    """Running times [s] from one NLP over all segments that keeps a timetable's windows.

    The segments' blocks as in :func:`whole_journey`; the journey clock ties them: segment n
    departs within its departure window (a fixed time: equal bounds) or at the previous arrival
    plus the dwell, never before that arrival plus the (least) dwell; its arrival keeps the stop's
    (earliest, latest) window and every passing point's node time keeps its window (speed bounds
    sit on the node, ``model.define_windows``; Yazhemsky 2017 eq. 4.1g on a whole journey, the
    TTOBench journey format). Returns the running times and the departures [s], and their status
    (:func:`_solve_times`).
    """

    pairs = list(zip(plan.stops, plan.stops[1:]))
    cases = [prepare(track, train, a, b, points, windows=[Window(w.distance, None, None, w.min_speed, w.max_speed)
                                                          for w in ws]) for (a, b), ws in zip(pairs, plan.windows)]
    for case in cases:  # a speed window above what the train reaches there (the times: check_reachable)
        try:
            check_windows(case)
        except FieldError as exc:  # its index is the segment's: the timetable's list is named whole
            raise FieldError(exc.problems, "windows") from None
    check_reachable(plan, cases)
    if start_times is None:
        start_times = [1.1 * c.estimate for c in cases]
    m, parts = _segments_model(cases, start_times)
    m.clock = pyo.ConstraintList()
    ref = sum(start_times)
    departures, guess = [], 0.0
    for n, (case, part) in enumerate(zip(cases, parts)):
        ready = departures[-1] + parts[n - 1].T + plan.dwell[n] if n else None
        guess += start_times[n - 1] + plan.dwell[n] if n else 0.0
        if plan.departure[n] is None:
            departures.append(ready)
        else:  # a departure window (equal bounds: a fixed time), never before the train is ready
            lo, hi = plan.departure[n]
            guess = min(max(guess, lo if lo is not None else guess), hi if hi is not None else guess)
            m.add_component(f"departure{n}", pyo.Var(bounds=(lo, hi), initialize=guess))
            departures.append(m.component(f"departure{n}"))
            if ready is not None:
                m.clock.add(ready / ref <= departures[-1] / ref)
        bounds = [(departures[n] + part.T, *plan.arrival[n])]
        bounds += [(departures[n] + passing_time(part, case.nodes, w.distance), w.earliest, w.latest)
                   for w in plan.windows[n]]
        for when, lo, hi in bounds:
            if lo is not None:
                m.clock.add(when / ref >= lo / ref)
            if hi is not None:
                m.clock.add(when / ref <= hi / ref)
    try:
        times, status = _solve_times(m, parts, "the journey that keeps its timing windows", options)
    except InfeasibleError as exc:  # each pair of times passed check_reachable: together they do not
        raise FieldError(f"{exc}: the stop times, dwells and passing windows together leave none", "stops, windows") from None
    return times, [float(pyo.value(d)) for d in departures], status


def _relative(t, departure):
    return None if t is None or t - departure <= 0 else t - departure


def _segment_windows(plan, n, departure):
    """Segment n's passing points with times since its own departure (the segment solve's clock)."""
    return tuple(Window(w.distance, _relative(w.earliest, departure), _relative(w.latest, departure),
                        w.min_speed, w.max_speed) for w in plan.windows[n])


def _span(lo, hi, unit):
    return f"[{'' if lo is None else f'{lo:g}'}, {'' if hi is None else f'{hi:g}'}] {unit}"


def timing_columns(plan, n, departure, arrival, run):
    """(journey-clock columns of segment n with whether the run keeps its windows, the first window
    it breaks in words or ""): the departure, the passing points and the arrival (a window at the
    stop) on the simulated trace (``simulate.window_checks``), times on the journey clock."""
    lo, hi = plan.arrival[n]
    stop = Window(run.facts.distance_m, _relative(lo, departure), _relative(hi, departure))
    checks = window_checks(run.trace, _segment_windows(plan, n, departure) + (stop,))
    d_lo, d_hi = plan.departure[n] or (None, None)
    broken = []
    if not ((d_lo is None or departure >= d_lo - 1e-3) and (d_hi is None or departure <= d_hi + 1e-3)):
        broken.append(f"departs {plan.stops[n]} at {departure:.1f} s, window {_span(d_lo, d_hi, 's')}")
    for w, check in zip(plan.windows[n], checks):  # on the journey clock, as the plan gives them
        if not check["kept"]:
            speeds = tuple(None if v is None else to_kmh(v) for v in (w.min_speed, w.max_speed))
            bounds = " and ".join(_span(a, b, unit) for a, b, unit in ((w.earliest, w.latest, "s"), (*speeds, "km/h"))
                                  if (a, b) != (None, None))  # only the bounds the point has
            broken.append(f"passes {w.distance:g} m after {plan.stops[n]} at {departure + check['simulated_time_s']:.1f} s "
                          f"and {check['simulated_speed_kmh']:.1f} km/h, window {bounds}")
    if not checks[-1]["kept"]:
        broken.append(f"arrives at {plan.stops[n + 1]} at {departure + checks[-1]['simulated_time_s']:.1f} s, "
                      f"window {_span(lo, hi, 's')}")
    columns = {"departure_s": departure, "arrival_s": arrival,
               "arrival_earliest_s": math.nan if lo is None else lo, "arrival_latest_s": math.nan if hi is None else hi,
               "windows_kept": not broken}
    return columns, "; ".join(broken)


def journey(track, train, stops, total_time=None, supplement=None, points=FRONT_POINTS, front_count=FRONT_COUNT, workers=1,
            scheduled=None, plan=None, progress=None, nlp_options=None):
    """Per-segment table for each distribution of one total running time, and the totals.

    Give ``total_time`` [s], ``supplement`` [-] over the sum of the segments' all-out times,
    ``scheduled`` running times per segment [s] (a timetable), which are then a distribution of
    their own, compared with the same total spread the other ways, or a ``plan``
    (timetable.JourneyPlan) with windows: the windowed journey NLP decides the running times and
    the other distributions spread its total; every row says whether it keeps the windows.
    ``progress(done, failed, remaining, total)``: each segment's front, then each run solved.
    ``nlp_options``: Ipopt options of the journey NLPs (whole-journey, timing windows); a
    distribution they did not prove optimal has every row flagged saying how Ipopt ended.
    """
    windowed, proven = None, {}
    if plan is not None:
        windowed, windowed_departures, proven["timing windows NLP"] = windowed_journey(track, train, plan, points,
                                                                                       options=nlp_options)
        total_time = float(sum(windowed))
        proven["all"] = proven["timing windows NLP"]  # every distribution spreads its total: not proven, every row flagged
    if scheduled is not None:
        total_time = float(sum(scheduled))
    pairs = list(zip(stops[:-1], stops[1:]))
    # the fronts reach 2.5 times the mean supplement (at least 60 %): a segment can take more than
    # the mean, and 15 points over a longer reach interpolate too coarsely (measured: a fixed
    # 150 % reach put the equal-marginal split 4.6 % above the whole-journey NLP at +15 %); each
    # front ends at its segment's longest running time solved (SLOWEST): no run of it can take longer
    mean = supplement or 0.0
    estimates = [prepare(track, train, a, b, points).estimate for a, b in pairs]
    if total_time is not None:
        for n, ((a, b), t, fast) in enumerate(zip(pairs, scheduled or (), estimates)):
            if t < 0.99 * fast:  # a timetabled segment no run can keep: refused before any front is solved
                raise FieldError(f"infeasible: {t:.1f} s from {a} to {b}, below the fastest possible run's "
                                 f"{fast:.1f} s (kinematic envelope)", f"stops[{n + 1}].arrival_s")
            if t > SLOWEST * fast:  # as solve refuses it
                raise FieldError(crawling(f"{t:.1f} s from {a} to {b}", fast), f"stops[{n + 1}].arrival_s")
        fastest = sum(estimates)
        if under_envelope(total_time, fastest):  # the kinematic all-out times: refused before any front is solved
            too_short(total_time, fastest, " (kinematic envelope)")
        if total_time > SLOWEST * fastest:
            raise InfeasibleError(f"the total time {total_time:.6g} s is over {SLOWEST:g} times the sum of the fastest "
                                  f"runs' {fastest:.1f} s (kinematic envelope): the train would crawl")
        mean = max(total_time / fastest - 1.0, 0.0)
    reach = max(0.6, 2.5 * mean)
    # a small supplement falls where the front bends most, below its evenly spaced points: points
    # around it (measured on the metro line at +1 %: without them the equal-marginal split was 3.0 %
    # above the whole-journey NLP and above the same percentage's 0.8 %)
    near = tuple(f * mean for f in NEAR_SPLIT) if 0 < mean < NEAR_BELOW else ()
    tick = ticker(progress, len(pairs) * (5 + (scheduled is not None) + (plan is not None)))  # fronts, 4+ splits
    fronts = []
    for a, b in pairs:
        fronts.append(sweep(track, train, a, b, count=front_count, supplement_max=reach, points=points,
                            workers=workers, verify_result=False, within_slowest=True, near=near)[0])
        tick()
    all_out = sum(float(f["running_time_s"].iloc[0]) for f in fronts)
    # each front's all-out run (its first row): the segment's all_out_time_s and supplement_pct
    fastest_proven = [solver_part(f"the all-out run from {a} to {b}", str(f["solver_status"].iloc[0]))
                      for (a, b), f in zip(pairs, fronts)]
    if total_time is None:  # a supplement over the segments' all-out runs: each one not proven optimal flags every row
        total_time = all_out * (1 + supplement)
        proven["all"] = worst(fastest_proven)
    marginal = equal_marginal(fronts, total_time)
    unsolved = {}  # a distribution with no running times: every row failed, the others still driven
    try:
        whole, proven["whole-journey NLP"] = whole_journey(track, train, pairs, total_time, marginal, points, nlp_options)
    except (InfeasibleError, SolverError) as exc:
        whole, unsolved["whole-journey NLP"] = [math.nan] * len(pairs), exc
    try:  # the envelope's fastest runs, integrated exactly, may be slower than the NLP's all-out runs
        mareco_times = mareco_split(track, train, pairs, total_time, points,
                                    [float(f["running_time_s"].iloc[0]) for f in fronts])
    except InfeasibleError as exc:
        mareco_times, unsolved["MARECO-style"] = [math.nan] * len(pairs), exc
    plans = {"whole-journey NLP": whole, "equal marginal saving": marginal, "same percentage": uniform(fronts, total_time),
             "MARECO-style": mareco_times}
    if scheduled is not None:
        plans["as timetabled"] = list(scheduled)
    if windowed is not None:
        plans = {"timing windows NLP": windowed, **plans}
    rows, results = [], {}
    written = Written(size=len(pairs))  # each segment's NLP written once for every distribution's time
    for name, times in plans.items():
        results[name] = []
        departures, arrivals = schedule(plan, times) if plan is not None else (None, None)
        if name == "timing windows NLP":  # the NLP's own departures (a later one may serve a window)
            departures = windowed_departures
            arrivals = [d + t for d, t in zip(departures, times)]
        for n, ((a, b), t, f) in enumerate(zip(pairs, times, fronts)):
            keep = _segment_windows(plan, n, departures[n]) if name == "timing windows NLP" else ()
            t0 = float(f["running_time_s"].iloc[0])
            solved_at = segment_time(t, t0, estimates[n])
            row = {"distribution": name, "from": a, "to": b, "distance_m": abs(track.stops[b] - track.stops[a]),
                   "all_out_time_s": t0,
                   "running_time_s": math.nan, "supplement_pct": 100 * (solved_at / t0 - 1),
                   "traction_energy_kWh": math.nan, "net_energy_kWh": math.nan}
            try:  # a segment no run can drive at its time is a failed row; the others are still solved
                if name in unsolved:
                    raise unsolved[name]
                r = solve_run(track, train, a, b, Timing(running_time=solved_at), points=points, windows=keep,
                              written=written, structure=None if keep else (n, a, b))
            except (InfeasibleError, SolverError) as exc:
                clock = {"departure_s": departures[n], "arrival_s": arrivals[n], "windows_kept": False} if plan else {}
                rows.append({**row, **clock, "verified": False, "status": str(failed(str(exc)))})
                tick()
                continue
            results[name].append(r)
            tick()
            facts = r.facts
            clock, broken = timing_columns(plan, n, departures[n], arrivals[n], r) if plan is not None else ({}, "")
            status = worst([r.status, proven.get(name, OK), proven.get("all", OK), fastest_proven[n],
                            flagged(f"breaks the timetable: {broken}") if broken else OK])
            rows.append({**row, "distance_m": facts.distance_m, "running_time_s": facts.running_time_s,
                         "traction_energy_kWh": facts.traction_energy_kWh, "net_energy_kWh": facts.net_energy_kWh,
                         **clock, "verified": bool(facts.verification and facts.verification.passed),
                         "status": str(status)})
        if len(results[name]) < len(pairs):  # drawn only when every segment ran
            del results[name]
    table = off_total(pd.DataFrame(rows), total_time, len(pairs))
    totals = table.groupby("distribution", sort=False)[["running_time_s", "traction_energy_kWh", "net_energy_kWh"]].sum(
        min_count=len(pairs))  # a distribution with a failed segment has no total (NaN, not a partial sum)
    if plan is not None:
        totals["windows_kept"] = table.groupby("distribution", sort=False)["windows_kept"].all().to_numpy()
    totals["status"] = table.groupby("distribution", sort=False)["status"].agg(
        lambda column: str(worst([Status.parse(s) for s in column]))).to_numpy()
    return table, totals.reset_index(), results, fronts


TOTAL_TOLERANCE = 1e-3  # [s], besides 1e-6 of the total: a distribution's runs that take longer together are flagged


def off_total(table, total_time, segments):
    """``table`` with every row of a distribution whose solved runs do not sum to ``total_time``
    flagged, the difference said (a segment solved at its fastest run where its share was faster
    still: :func:`segment_time`); a distribution with a failed segment is failed already."""
    sums = table.groupby("distribution", sort=False)["running_time_s"].sum(min_count=segments)
    for name, took in sums.items():
        if np.isfinite(took) and abs(took - total_time) > TOTAL_TOLERANCE + 1e-6 * total_time:
            off = flagged(f"the distribution's runs take {took:.3f} s together, not the journey's {total_time:.3f} s")
            rows = table["distribution"] == name
            table.loc[rows, "status"] = [str(worst([Status.parse(s), off])) for s in table.loc[rows, "status"]]
    return table
