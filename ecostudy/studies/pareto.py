"""Energy against running time: the epsilon-constraint Pareto front (Farooqi 2018 §7.1.1, Table 7.1).

The running time is swept from the all-out time T0 to T0 (1 + supplement_max). Every point is
energy-optimal for its running time. A chain of points shares one Pyomo model and one NL file
(:class:`ecostudy.ocp.session.Session`): only the bounds of the running-time variable change, and
after the chain's first point Ipopt starts from the previous point's primal and dual solution
(:data:`WARM_START`); a point whose warm start fails is retried as the cold start of a new
chain. ``workers`` > 1 splits the sweep into contiguous chains solved in forked processes.
"""
import time
from concurrent.futures import as_completed

import numpy as np
import pandas as pd

from ecostudy.analysis.single import finish, solve_run
from ecostudy.core.defaults import FRONT_POINTS
from ecostudy.core.errors import SolverError
from ecostudy.core.status import Status
from ecostudy.core.types import Timing
from ecostudy.das.methods import das_columns
from ecostudy.io.runsummary import RunSummary
from ecostudy.ocp import session
from ecostudy.ocp.problem import all_out, build, capped_guess, prepare, record, slowest_time
from ecostudy.ocp.solver import IPOPT
from ecostudy.studies.workers import ticker, worker_pool

# After the first point of a chain, Ipopt starts from the previous point's primal AND dual
# solution with a small barrier parameter (measured where it is set: ``ocp.solver.IPOPT``).
WARM_START = IPOPT["pareto_warm"]


def _chain(case, times, objective, options, verify_result, warm, tick=None, t_allout=None):
    """Energy-optimal results at ``times`` [s], one model and NL file for the whole chain
    (``tick(n)``: n more points solved, in this process; ``t_allout``: the all-out time [s], which a
    point at it is, with no marginal energy: ``analysis.single.AT_ALL_OUT``)."""
    tick = tick or (lambda n: None)
    if not warm:  # every point on its own, exactly as `ecostudy solve --time T` would
        results = []
        for t in times:
            results.append(solve_run(case.track, case.train, case.segment.from_stop, case.segment.to_stop,
                                     Timing(running_time=t), objective=objective, points=len(case.nodes),
                                     options=options, verify_result=verify_result))
            tick(1)
        return results
    stages = {}
    m = build(case, capped_guess(case, times[0]), objective, stages, running_time=times[0])
    nlp = session.Session(m)
    results = []
    for i, t in enumerate(times):
        point_stages = {"build": stages["build"] if i == 0 else 0.0}
        nlp.set_bounds(m.T, t, t)
        outcome = nlp.solve({**WARM_START, **(options or {})} if i else options)
        record(point_stages, outcome, nlp.nl_seconds if i == 0 else 0.0)
        if not outcome.usable:
            if i == 0:  # a cold start failed: nothing better to try
                raise SolverError(f"Ipopt failed at running time {t:.2f} s ({outcome.status})")
            # a warm start that fails is retried cold: a fresh chain from this point on
            return results + _chain(case, times[i:], objective, options, verify_result, warm, tick, t_allout)
        results.append(finish(case, m, outcome, point_stages, objective, t_allout, verify_result))
        tick(1)
    return results


def weighted_points(track, train, from_stop, to_stop, count=8, points=FRONT_POINTS, energy_weights=None):
    """Weighted-sum points: minima of w_t T + w_e E / Ms (Yazhemsky 2017 eq. 4.1a) for w_t = 1 and
    ``count`` energy weights w_e [s kg/J] from 0.03 to 30. On a convex front each lies on the
    epsilon-constraint front; the weighted sum cannot reach points where the front is not convex.
    Each row has its run's status (solver and re-simulation)."""
    weights = energy_weights if energy_weights is not None else np.geomspace(0.03, 30.0, count)
    rows = []
    for we in weights:
        r = solve_run(track, train, from_stop, to_stop, Timing(), objective="mixed", weights=(1.0, float(we)),
                      points=points)
        f = r.facts
        rows.append({"energy_weight_s_kg_per_J": float(we), "running_time_s": f.running_time_s,
                     "traction_energy_kWh": f.traction_energy_kWh, "net_energy_kWh": f.net_energy_kWh,
                     "solver_status": f.solver.status,
                     "verified": None if f.verification is None else f.verification.passed, "status": str(r.status)})
    return pd.DataFrame(rows)


def weighted_statuses(table):
    """Every weighted-sum point's status (a table of :func:`weighted_points`), named by its weight."""
    return {f"weighted w_e = {r.energy_weight_s_kg_per_J:.3g}": Status.parse(r.status) for r in table.itertuples()}


def _split(items, parts):
    """Contiguous chunks of ``items`` (warm-start chains need neighbours together)."""
    return [list(chunk) for chunk in np.array_split(np.asarray(items, dtype=float), parts) if len(chunk)]


def sweep(track, train, from_stop, to_stop, count=20, supplement_max=0.40, points=FRONT_POINTS,
          objective="energy", workers=1, warm=True, options=None, verify_result=True, progress=None,
          within_slowest=False, near=()):
    """The front as (table, results); results[0] is the all-out run itself.

    Parameters
    ----------
    count : int  Points of the front, the all-out run, +5 % and +10 % among them (:func:`front_supplements`).
    supplement_max : float  Largest supplement over the all-out time [-], e.g. 0.40.
    workers : int  Processes (contiguous warm-start chains); 1 solves in this process.
    warm : bool  Reuse one model per chain and start from the neighbour (False: cold, independent).
    progress : callable  ``progress(done, failed, remaining, total)`` as points are solved (a whole
        chain at a time with ``workers`` > 1), as :func:`ecostudy.studies.batch.execute` calls it.
    within_slowest : bool  End the front at the longest running time solved
        (:func:`~ecostudy.ocp.problem.slowest_time`) where ``supplement_max`` would pass it.
    near : sequence of float  Supplements [-] to solve besides (a journey's: where its split will fall).
    """
    stages = {}
    t0 = time.perf_counter()
    case = prepare(track, train, from_stop, to_stop, points, stages)
    t_allout, m, outcome = all_out(case, stages, options)
    allout = finish(case, m, outcome, stages, "time", t_allout, verify_result)
    if within_slowest:  # a hair inside (1 ppm): the solved times differ from the asked ones by about 1e-9
        supplement_max = min(supplement_max, slowest_time(case) * (1 - 1e-6) / t_allout - 1.0)
    supplements = front_supplements(count, supplement_max, near)[1:]
    times = t_allout * (1 + supplements)
    tick = ticker(progress, len(times) + 1)
    tick(1)  # the all-out run
    chunks = _split(times, max(1, min(workers, len(times))))
    if len(chunks) > 1:
        with worker_pool(len(chunks)) as pool:
            futures = {pool.submit(_chain, case, c, objective, options, verify_result, warm, None, t_allout): len(c)
                       for c in chunks}
            for future in as_completed(futures):
                tick(futures[future])
            parts = [future.result() for future in futures]
    else:
        parts = [_chain(case, chunks[0], objective, options, verify_result, warm, tick, t_allout)] if chunks else []
    results = [allout] + [r for part in parts for r in part]
    table = front_table([(r.summary, r.status) for r in results], t_allout)
    table.attrs["wall_s"] = time.perf_counter() - t0
    return table, results


REPORTED_SUPPLEMENTS = (0.05, 0.10)  # operators ask what +5 % and +10 % buy: always solved


def front_supplements(count, supplement_max, near=()):
    """Exactly ``count`` supplements from 0 to ``supplement_max``, +5 % and +10 % among them, and
    the supplements ``near`` (within the reach) before the evenly spaced ones.

    The front is strongly convex near the all-out time, so the reported savings are solved
    points, never interpolated between distant ones: the evenly spaced points are thinned until
    +5 % and +10 % fit in ``count`` (the largest gaps split if a point is still missing). With
    fewer than four points only the reported supplements that fit are kept.
    """
    wanted = [x for x in near if 0 < x <= supplement_max + 1e-12] + list(REPORTED_SUPPLEMENTS)
    extra = [x for x in wanted if x <= supplement_max + 1e-12][:max(0, count - 2)]
    for n in range(count, 1, -1):
        points = np.unique(np.round(np.concatenate([np.linspace(0.0, supplement_max, n), extra]), 12))
        if len(points) <= count:
            break
    while len(points) < count:
        gap = int(np.argmax(np.diff(points)))
        points = np.insert(points, gap + 1, round((points[gap] + points[gap + 1]) / 2, 12))
    return points


def facts_of(summary):
    """A point's summary typed (a study's ``das`` is a table row, not a run's advice block: left out)."""
    return RunSummary.from_dict({**summary, "das": None})


def front_table(points, t_allout):
    """One row per point, columns named with their units; ``points``: (summary, status) of each
    point, the all-out run first (a point not solved: summary None, its row empty but its status)."""
    rows = []
    for summary, status in points:
        if summary is None:
            rows.append({"status": str(status)})
            continue
        s = facts_of(summary)
        rows.append({
            "running_time_s": s.running_time_s,
            "supplement_pct": 100 * (s.running_time_s / t_allout - 1),
            "traction_energy_kWh": s.traction_energy_kWh,
            "net_energy_kWh": s.net_energy_kWh,
            "top_speed_kmh": s.top_speed_kmh,
            "coasting_share_pct": 100 * s.distance_shares["CO"],
            "regime_sequence": s.regime_sequence,
            "solver_status": s.solver.status,
            "iterations": s.solver.iterations,
            "verified": None if s.verification is None else s.verification.passed,
            "status": str(status),
        })
    table = pd.DataFrame(rows, columns=list(FRONT_ROW))
    e0 = table["traction_energy_kWh"].iloc[0]
    table.insert(4, "saving_vs_all_out_pct", 100 * (1 - table["traction_energy_kWh"] / e0))
    # what one more second buys: -dE/dT at each point, its own NLP's arrival multiplier (as solve reports
    # it); a slope between neighbours depends on which points the front holds (0.16-0.18 kWh/s against
    # 0.063 on a sparse metro front); the all-out run has none
    marginal = [np.nan if summary is None or summary.get("marginal_energy_kWh_per_s") is None
                else -float(summary["marginal_energy_kWh_per_s"]) for summary, _ in points]
    table.insert(5, "marginal_saving_kWh_per_s", marginal)
    return table


FRONT_ROW = ("running_time_s", "supplement_pct", "traction_energy_kWh", "net_energy_kWh", "top_speed_kmh",
             "coasting_share_pct", "regime_sequence", "solver_status", "iterations", "verified", "status")


def saving_at(table, supplement_pct):
    """Traction-energy saving against all-out at a supplement [%]: that of the point solved there,
    None when the front has none (too few points, a smaller ``supplement_max``, the point failed):
    the front is strongly convex near the all-out time, so a value interpolated between distant
    points, or held beyond the front's end, is no measurement (+5 % between 0 and +40 % read 10 %
    where the point solved saves 39 %)."""
    at = table.loc[np.isclose(table["supplement_pct"], supplement_pct, rtol=0.0, atol=1e-4), "saving_vs_all_out_pct"]
    return float(at.iloc[0]) if len(at) else None


def rises(table, tolerance=1e-6):
    """The running times [s] (before, after) between which the front's traction energy rises by more
    than ``tolerance`` of its largest energy (the all-out run's): a front that reaches zero energy (a
    descent) has solver noise of 1e-8 kWh there, which is no rise."""
    e, t = table["traction_energy_kWh"].to_numpy(), table["running_time_s"].to_numpy()
    if not len(e):
        return []
    up = np.nonzero(np.diff(e) > tolerance * float(np.nanmax(np.abs(e))))[0]
    return [(float(t[i]), float(t[i + 1])) for i in up]


def is_monotone(table, tolerance=1e-6):
    """Energy non-increasing as running time grows (:func:`rises`: to ``tolerance`` of the largest)."""
    return not rises(table, tolerance)


def _das_point(result, method, points, time_limit):
    return das_columns(result, method, points, time_limit)


def das_front(table, results, method="phases", points=None, workers=1, time_limit=60.0):
    """The front's table with the DAS run of every point beside the ATO optimum (``das_`` columns).

    Each point's advice is computed for the ATO run's running time (:func:`ecostudy.das.das_run`)
    and re-simulated as a driver follows it; the all-out point has no slack for a DAS plan and is
    tried like the others (a failure is recorded in ``das_status``).
    """
    args = [(r, method, points, time_limit) for r in results]
    if workers > 1 and len(results) > 1:
        with worker_pool(min(workers, len(results))) as pool:
            rows = list(pool.map(_das_point, *zip(*args)))
    else:
        rows = [_das_point(*a) for a in args]
    das = pd.DataFrame(rows, index=table.index)
    out = pd.concat([table, das], axis=1)
    out.attrs.update(table.attrs, das_method=method)
    return out


def das_meta(table):
    """What a reader asks of a DAS front: how many points solved, the gap range, monotonicity."""
    ok = table["das_traction_energy_kWh"].notna() if "das_traction_energy_kWh" in table else table.index < 0
    # the gap range over the advice runs that are ok only: a run short of its stop saves what it did not drive
    trusted = ok & table["das_status"].astype(str).eq("ok") if "das_status" in table else ok
    gaps = table.loc[trusted, "das_gap_to_ato_on_time_pct"] if trusted.any() else pd.Series(dtype=float)
    energy = table.loc[ok, "das_traction_energy_kWh"].to_numpy() if ok.any() else np.zeros(0)
    return {"method": table.attrs.get("das_method"), "points": int(len(table)), "solved": int(ok.sum()),
            "ok": int(trusted.sum()),
            "min_gap_on_time_pct": float(gaps.min()) if len(gaps) else None,
            "max_gap_on_time_pct": float(gaps.max()) if len(gaps) else None,
            "monotone": bool(np.all(np.diff(energy) <= 1e-6 * energy[:-1])) if len(energy) > 1 else None}


__all__ = ["sweep", "das_front", "das_meta", "weighted_points", "weighted_statuses", "front_table", "saving_at",
           "is_monotone", "rises"]
