"""Driver advice (Farooqi 2018 §3.1.2): a few modes instead of a continuous handle.

A driver can be told a handle level of the train's ``das_handle_levels`` (traction levels,
coast 0, braking levels: full service braking -1 by default) or "hold this speed" (cruise). The advice is the sequence of
modes with where and when each starts. Methods:

``round``   nearest level to the ATO optimum's handle in every interval (Farooqi 2018 §4.4),
            re-simulated: the baseline better DAS methods must beat.
``phases``  phase lengths of a fixed mode sequence per sector optimised over the whole journey
            (Farooqi 2018 Ch. 5; ``ocp/phases.py``).
``minlp``   the mode of every phase chosen by binaries, started from ``phases`` (``das/minlp.py``).

Every advice is re-simulated as a driver would follow it: mode by mode from the advised
positions, cruise with a speed-holding controller (``core.simulate.simulate`` with targets). The
reported energies, arrival and stop are those of that simulation.
"""
import time
from typing import NamedTuple

import numpy as np
import pandas as pd

from ecostudy.analysis.regimes import guess_from_result
from ecostudy.core.errors import SolverError
from ecostudy.core.modes import mode_name
from ecostudy.core.progress import stage
from ecostudy.core.simulate import (KINETIC_FLOOR, Driven, kinetic_floor, missed_points, simulate, window_checks,
                                     worst_overspeed)
from ecostudy.core.status import STOP_TOLERANCE_M, at_stop, driven_run, flagged, solver_part, worst
from ecostudy.core.units import KMH, to_kmh, to_kwh
from ecostudy.ocp import phases, session


class DasRun(NamedTuple):
    """A DAS method's result: its ``das`` summary block, the advice table and the advice as a driver
    follows it (re-simulated); both None for advice that failed (:func:`failed_advice`)."""

    summary: dict
    advice: pd.DataFrame | None
    driven: Driven | None


def failed_advice(method, reason):
    """The :class:`DasRun` of advice no method made (its NLP infeasible, its search stopped without a
    pattern): status ``failed`` with the reason, no energies, no advice; the ATO run it was drawn
    from stands on its own."""
    return DasRun({"method": method, "traction_energy_kWh": None, "net_energy_kWh": None, "gap_to_ato_pct": None,
                   "gap_to_ato_on_time_pct": None, "no_gap": "no advice", "note": "", "mode_changes": None,
                   "bound_kWh": None, "status": f"failed: {reason}", "solver": None, "arrival_error_s": None,
                   "stop_error_m": None, "overspeed_max_kmh": None}, None, None)


def advice_table(nodes, handle, trace, targets=None):
    """One row per mode change: start position and (simulated) time, mode, handle, target, end."""
    targets = np.full(len(handle), np.nan) if targets is None else np.asarray(targets, float)
    key = np.where(np.isfinite(targets), 10.0 + targets, handle)  # cruise rows differ from handles
    change = np.concatenate([[0], np.nonzero(np.abs(np.diff(key)) > 1e-9)[0] + 1])
    ends = np.append(change[1:], len(handle))
    x_sim, t_sim = np.maximum.accumulate(trace.x), trace.t
    rows = []
    for i0, i1 in zip(change, ends):
        cruise = np.isfinite(targets[i0])
        rows.append({"start_position_m": float(nodes[i0]),
                     "start_time_s": float(np.interp(nodes[i0], x_sim, t_sim)),
                     "mode": mode_name(handle[i0], targets[i0]),
                     "handle": np.nan if cruise else float(handle[i0]),
                     "target_speed_kmh": float(to_kmh(targets[i0])) if cruise else np.nan,
                     "end_position_m": float(nodes[i1])})
    return pd.DataFrame(rows)


def follow(segment, train, starts, levels, targets):
    """Re-simulate advice given as start positions, handle levels and cruise targets (nan: none).

    The simulation grid joins the advice positions and the track's profile changes, so every
    piece has one mode and one gradient.
    """
    starts = np.asarray(starts, float)
    nodes = np.unique(np.concatenate([[0.0, segment.distance], starts, segment.breakpoints()]))
    mid = 0.5 * (nodes[:-1] + nodes[1:])
    row = np.searchsorted(starts, mid, side="right") - 1
    handle = np.asarray(levels, float)[row]
    target = np.asarray(targets, float)[row]
    handle = np.where(np.isfinite(target), 0.0, handle)
    trace = simulate(segment, train, nodes, handle, targets=target)[0]
    return nodes, handle, target, trace


def phase_advice(layout, lengths, v):
    """(starts, levels, targets) of the phases longer than ``phases.MIN_PHASE``, merged by mode."""
    n = layout.substeps
    x = phases.node_positions(layout, lengths)
    starts, levels, targets = [], [], []
    for q, (_, mode) in enumerate(layout.phases):
        target = float(v[q * n]) if mode.kind == "cruise" else np.nan
        if lengths[q] < phases.MIN_PHASE:
            continue
        same = levels and ((mode.kind == "cruise" and abs(targets[-1] - target) < 0.05 * KMH)
                           or (mode.kind != "cruise" and np.isnan(targets[-1]) and levels[-1] == mode.level))
        if not same:
            starts.append(float(x[q * n]))
            levels.append(0.0 if mode.kind == "cruise" else mode.level)
            targets.append(target)
    return starts, levels, targets


def minimised(result):
    """(key, kWh) of the quantity the ATO run minimised: its net energy on a net-energy run, else its
    traction energy; a gap to ATO is on it."""
    key = "net_energy_kWh" if result.summary["objective"] == "net_energy" else "traction_energy_kWh"
    return key, result.summary[key]


def _gap(energies, result):
    """Gap [%] on the quantity the ATO run minimised (traction or net energy; :func:`no_gap` says
    when it is no scale for one)."""
    key, ato = minimised(result)
    return 100 * (energies[key] / ato - 1)


def _gap_on_time(energies, result, arrival):
    """Gap [%] with a late arrival charged at the ATO run's marginal energy |dE/dT| (a late train
    must make the time up elsewhere); an early arrival earns nothing (the timetable asks for the
    time, not less). This compares DAS methods that miss the timetable by different amounts."""
    key, ato = minimised(result)
    marginal = result.summary.get("marginal_energy_kWh_per_s")
    if marginal is None:
        return None
    late = max(arrival - result.summary["running_time_s"], 0.0)
    return 100 * ((energies[key] + abs(marginal) * late) / ato - 1)


def no_gap(result, arrived):
    """Why the advice has no gap to the ATO run ('' where it has one): a gap is read off an ATO run
    that is ok and minimised energy (not the all-out run's time), whose energy is a scale to take a
    share of (at least :func:`~ecostudy.core.simulate.kinetic_floor` at its top speed: a run down a
    grade that needs no traction has none), and advice that stopped at its stop."""
    if result.summary["objective"] not in ("energy", "net_energy"):
        return f"the ATO run minimised {result.summary['objective']}, not energy"
    if not result.status.ok:
        return "the ATO run is not ok"
    key, ato = minimised(result)
    small = no_scale(ato, result.train, result.summary["top_speed_kmh"] * KMH,
                     "the ATO run's " + ("net energy" if key == "net_energy_kWh" else "traction energy"))
    if small:
        return small
    return "" if arrived else f"the advice stopped more than {STOP_TOLERANCE_M:g} m off its stop"


def no_scale(kwh, train, top_speed, what):
    """Why an energy ``kwh`` [kWh] of a run of ``train`` whose top speed is ``top_speed`` [m/s] is no
    scale to take a percentage of ('' when it is one): below
    :func:`~ecostudy.core.simulate.kinetic_floor` (a run down a grade that needs no traction);
    ``what`` names the energy."""
    floor = to_kwh(kinetic_floor(train, top_speed))
    if kwh >= floor:
        return ""
    return (f"{what} ({kwh:.3g} kWh) is below {100 * KINETIC_FLOOR:g} % of the kinetic energy at its top speed "
            f"({floor:.3g} kWh): no energy to take a percentage of")


REGEN_SHORTFALL = 0.05  # the advice's electric brake taking this share less than the ATO run's: said why


def braking_note(result, outcome, gap):
    """Why advice on a net-energy run is dearer than its ATO run, where the reason is its braking
    levels ('' otherwise): the net optimum brakes where the regenerative brake takes the whole
    braking force (the RB arc of Farooqi 2018, eq. 7.4); braking at a level beyond that, the advice
    loses the difference to the friction brake."""
    if result.summary["objective"] != "net_energy" or gap is None or gap <= 1.0 or result.trace is None:
        return ""
    ato, mine = result.trace.regenerated_energy, outcome.trace.regenerated_energy
    if ato <= 0 or mine >= (1 - REGEN_SHORTFALL) * ato:
        return ""
    levels = ", ".join(f"{lv:g}" for lv in result.train.das_levels if lv < 0)
    return (f"its electric brake takes {to_kwh(mine):.3f} kWh against the ATO run's {to_kwh(ato):.3f} kWh: "
            f"braking at the train's levels ({levels}) asks more than the regenerative brake takes; a gentler "
            "braking level in the train's das_handle_levels lets advice regenerate more")


GRID_GAP_PCT = -1.0  # advice this far below its ATO optimum [%]: the optimum's grid is too coarse there, said so


def grid_note(gap, points, marginal=None, what="the advice"):
    """Why a run is cheaper than the ATO optimum ('' unless by more than :data:`GRID_GAP_PCT`
    [%]): the optimum is exact on its ``points`` intervals, the run driven by the integrator between
    them; near the all-out time, where each second costs most (``marginal`` [kWh/s]), a grid's
    hundredth of a second is worth percents."""
    if gap is None or not np.isfinite(gap) or gap >= GRID_GAP_PCT:
        return ""
    worth = "" if marginal is None else f" (here the energy changes by {abs(marginal):.3g} kWh per second of running time)"
    return (f"{what} is {abs(gap):.2f} % below the ATO optimum: the optimum's grid (K = {points}) is "
            f"too coarse to rank them{worth}; solve with more --points")


def summary_block(method, result, outcome, advice, solver, flags=(), **extra):
    """The ``das`` block of a DAS method's run: energies and gaps, and its ``status`` as a driven run
    (:func:`~ecostudy.core.status.driven_run`: stop, arrival against the ATO run's time, overspeed
    over the limits, a train with an adhesion limit its ``adhesion_use_max``; the timing points of
    the ATO run, ``result.windows``, each passed in its time and speed bounds as the ATO run's are,
    :func:`~ecostudy.core.simulate.window_checks`, kept as ``windows``), flagged too for each
    reason in ``flags``; ``solver`` says how the advice was made (e.g. ``optimal, re-simulated``)."""
    row = outcome.row(result.train, result.segment.distance)
    energies = {k: row[k] for k in ("traction_energy_kWh", "net_energy_kWh")}
    arrived = at_stop(row["stop_error_m"])  # a run short of (or past) its stop has no time or gap
    arrival_error = row["running_time_s"] - result.summary["running_time_s"] if arrived else None
    overspeed = to_kmh(worst_overspeed(result.segment, outcome.trace))
    grip = {} if "adhesion_use_max" not in row else {"adhesion_use_max": row["adhesion_use_max"]}
    points = window_checks(outcome.trace, result.windows)
    status = worst([driven_run(row["stop_error_m"], arrival_error, overspeed, row.get("adhesion_use_max"),
                               early_s=None if arrival_error is None else -arrival_error,
                               moving_kmh=to_kmh(float(outcome.trace.v[-1]))),
                    *(flagged(f) for f in (*missed_points(points), *flags))])
    why = no_gap(result, arrived)
    gap = None if why else _gap(energies, result)
    return {"method": method, **energies, "gap_to_ato_pct": gap,
            "gap_to_ato_on_time_pct": None if why else _gap_on_time(energies, result, row["running_time_s"]),
            "no_gap": why, "note": braking_note(result, outcome, gap)
            or grid_note(gap, len(result.nodes), result.summary.get("marginal_energy_kWh_per_s")),
            "mode_changes": len(advice) - 1, "bound_kWh": None, "status": str(status), "solver": solver,
            "arrival_error_s": arrival_error,
            "stop_error_m": row["stop_error_m"], "overspeed_max_kmh": overspeed,
            "top_speed_kmh": float(to_kmh(np.max(outcome.trace.v))), "windows": points, **grip, **extra}


def das_round(result):
    outcome = nearest_levels(result.segment, result.train, result.nodes, result.handle)
    advice = advice_table(result.nodes, outcome.handle, outcome.trace)
    return DasRun(summary_block("round", result, outcome, advice, "re-simulated"), advice, outcome)


def objective_of(result):
    return "net_energy" if result.summary["objective"] == "net_energy" else "energy"


def solve_layout(result, layout, guess, options=None):
    """Build and solve the fixed-mode phases NLP of ``layout`` for the ATO run's segment and time."""
    t0 = time.perf_counter()
    m = phases.build(result.segment, result.train, layout, guess,
                     running_time=result.summary["running_time_s"], objective=objective_of(result))
    build_s = time.perf_counter() - t0
    outcome = session.solve(m, options)
    outcome.build_seconds = build_s
    return m, outcome


def refine(result, m, layout, modes, points, options=None):
    """Solve again on the phases driven in ``m`` (with ``modes``), the whole sub-grid on them."""
    lengths, x, v, *_ = phases.solution(m, layout)
    fine, kept = phases.active(layout, lengths, modes, points)
    guess_v = np.interp(phases.node_positions(fine, kept), x, v)
    guess_v[0] = guess_v[-1] = 0.0
    m_fine, outcome = solve_layout(result, fine, (kept, guess_v), options)
    return m_fine, fine, outcome


def solve_phases(result, points=None, options=None, stages=2):
    """The phases NLP for the ATO ``result``: (model, layout, outcome).

    Stage 1 solves the full sequence of every sector, started from the ATO run's regimes;
    stage 2 solves again with only the phases stage 1 drives, on a sub-grid of ``points``.
    """
    seg, train = result.segment, result.train
    points = points or len(result.nodes)
    layout = phases.Layout.make(phases.sectors(seg, train), phases.sequence(train), 1, train)
    layout.substeps = phases.substeps_for(points, len(layout.phases))
    stage("DAS phases NLP (every mode)")
    m, outcome = solve_layout(result, layout, guess_from_result(result, layout), options)
    if not outcome.usable:
        raise SolverError(f"the DAS phases NLP failed ({outcome.status}, {outcome.iterations} iterations)")
    if stages == 1:
        return m, layout, outcome
    stage("DAS phases NLP (modes driven)")
    m2, layout2, again = refine(result, m, layout, [md for _, md in layout.phases], points, options)
    if again.usable:
        for k in ("seconds", "nl_seconds", "iterations", "build_seconds"):
            setattr(again, k, getattr(again, k) + getattr(outcome, k))
        return m2, layout2, again
    return m, layout, outcome


def advice_outcome(name, result, layout, m):
    """Driver advice of a solved phases (or MINLP) model, re-simulated as a driver follows it."""
    stage(f"{name} advice re-simulated")
    lengths, _, v, _, ft, _ = phases.solution(m, layout)
    starts, levels, targets = phase_advice(layout, lengths, v)
    nodes, handle, target, trace = follow(result.segment, result.train, starts, levels, targets)
    advice = advice_table(nodes, handle, trace, target)
    plan_kwh = to_kwh(float(np.sum(ft * np.diff(phases.node_positions(layout, lengths)))))
    return advice, Driven(name, handle, trace), plan_kwh


def nlp_flags(name, outcome):
    """The reasons to flag advice made on ``outcome`` of the NLP ``name``: none when Ipopt proved it
    optimal, else how Ipopt ended (:func:`~ecostudy.core.status.solver_part`)."""
    status = solver_part(name, outcome.status)
    return () if status.ok else (status.reason,)


ORDER_GAP_PCT = 5.0  # phases advice this far above its ATO run [%]: a coast it cannot write is named


def order_note(result, gap):
    """Why phases advice is far dearer than its ATO run ('' unless by more than :data:`ORDER_GAP_PCT`
    [%] and for this reason): the ATO run coasts between traction and holding a speed inside one sector
    (on a descent MA-CO-CR2: pull away, coast up to the limit, hold it), an order a sector's phases
    (coast, traction, cruise, coast, braking) cannot write; the advice holds a lower speed instead."""
    if gap is None or not np.isfinite(gap) or gap <= ORDER_GAP_PCT or 0.0 not in result.train.das_levels:
        return ""  # a train without a coast level: no coast phase at all (its gap is that)
    secs = phases.sectors(result.segment, result.train)
    runs = result.facts.regimes
    for before, coast, after in zip(runs, runs[1:], runs[2:]):
        same = phases.sector_at(secs, coast.start_m) == phases.sector_at(secs, coast.end_m)
        if before.regime in ("MA", "CR") and coast.regime == "CO" and after.regime in ("CR", "CR2") and same:
            return (f"the ATO run coasts between traction and holding a speed ({before.regime}-CO-{after.regime}, "
                    f"coasting at {coast.start_m:.0f}-{coast.end_m:.0f} m), an order the phases of a sector (coast, "
                    "traction, cruise, coast, braking) cannot write: the advice holds a speed instead")
    return ""


def das_phases(result, points=None, options=None):
    """The :class:`DasRun` of the phases NLP (Ipopt ``options``), flagged when Ipopt did not prove it optimal."""
    m, layout, outcome = solve_phases(result, points, options)
    advice, sim, plan_kwh = advice_outcome("DAS phases", result, layout, m)
    flags = nlp_flags("the DAS phases NLP", outcome)
    block = summary_block("phases", result, sim, advice, f"{outcome.status}, re-simulated", flags,
                   planned_traction_energy_kWh=plan_kwh, phases=len(layout.phases),
                   intervals=layout.intervals, solve_s=outcome.seconds + outcome.nl_seconds,
                   build_s=outcome.build_seconds)
    block["note"] = block["note"] or order_note(result, block["gap_to_ato_pct"])
    return DasRun(block, advice, sim)


def nearest_levels(segment, train, nodes, optimal_handle):
    """Nearest DAS handle level (train's ``das_handle_levels``) to the optimal handle of every
    interval (Farooqi 2018 §4.4), without a cruise mode, re-simulated; it keeps no timetable of its
    own, so its arrival and stop errors are part of a comparison."""
    levels = np.asarray(train.das_levels)
    u = levels[np.abs(optimal_handle[:, None] - levels[None, :]).argmin(axis=1)]
    trace = simulate(segment, train, nodes, u)[0]
    return Driven("DAS round (nearest level)", u, trace)
