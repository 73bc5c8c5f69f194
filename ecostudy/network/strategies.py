"""Several trains on one line and one substation: timetables, strategies, the joint optimum.

Every train runs the same stops with the same running times and dwells, offset by its departure
time, on one clock of step dt (``timedomain``). Strategies (Farooqi 2018 Ch. 7-8, Yazhemsky 2017 §6.2.3):

independent  each train minimises its own pantograph net energy, regeneration credited as if
             the line always took it (a): no collaboration; it ignores ``buffer`` (flagged
             where its trains come nearer)
receptivity  the supervisor rounds below with no rule: each train's regeneration credited only
             up to what the line could take from it, given the others' runs (a baseline that
             shows what the rules add)
triggering   supervisor rule 7.7: while another train brakes, a train's traction is weighted
             (1 - gamma2) / (1 - gamma1) with the thesis' gamma1 = 0.71, gamma2 = 0.9 (b)
voltage      rule 7.11 as the thesis' text applies it, between consecutive trains: while the
             pantograph voltage of the train ahead is above a train's own (it regenerates),
             that train's traction weighs 0 (c); the voltages are those of eq. 7.8 as written
             (a receptive source, :func:`sensed`): on the line with the diode a surplus nobody
             draws carries no current and the comparison would see nothing
dissension   Farooqi 2018 eqs. 8.14-8.17: each train's weight gamma_i follows a two-state Markov
             law whose rate away from "braking" grows with the number of braking neighbours;
             traction weighs gamma_i / gamma0 (d)
joint        one NLP over all trains and the network of eq. 7.8 minimising substation energy,
             each train ``buffer`` behind the one ahead: the bound no rule can beat (e)
following    the independent runs, each train's head kept ``buffer`` metres behind the tail of
             the one ahead on the common clock (Yazhemsky 2017 eq. 6.9), the leader's time-position
             profile fixed (f)

The rules (b), (c), (d) re-optimise one train at a time against the others' latest runs, for a
few supervisor rounds, keeping the timetable; their regeneration is credited only up to what the
line could take then (:func:`supervised`). Every strategy is scored by the same network solve
(``circuit.solve_steps``).
"""
import math
import time
from concurrent.futures import as_completed

import numpy as np

from ecostudy.core.errors import SolverError
from ecostudy.core.simulate import outside
from ecostudy.core.status import TOLERANCES, calibrated, solver_part
from ecostudy.core.registry import Registry
from ecostudy.network.fleet import late_at_stops
from ecostudy.network.joint import joint
from ecostudy.network.rules import RULES, following, independent, supervised
from ecostudy.network.scoring import buffer_missed, closest_approach, evaluate, separations, verify_leg


# the strategies after independent driving, dearest first, so that a pool's workers end together
# (`ecostudy network <study> --no-plot --workers 2`, each in its worker: 3-train study
# 45.2, 38.3, 32.1, 24.6, 19.1, 5.1 s; 2-train study 9.8, 10.4, 10.8, 9.0, 5.6, 2.0 s); also the
# order in which a network study starts its strategies on a shared pool (``studies.network``)
DEAREST_FIRST = ("triggering", "dissension", "voltage", "receptivity", "joint", "following")


def run_strategies(fleet, strategies, progress=print, pool=None, workers=1, tick=None):
    """Every strategy on ``fleet``: {name: {"runs", "steps", "trains", "totals", "info"}}, in the
    order asked; one that fails is {"failed": why, "wall_s"} and the others go on. ``progress``
    receives a line per strategy, ``tick(done, failed, remaining, total)`` the counts (a bar).

    The independent runs are solved first: they are strategy (a) and the start of the others.
    ``pool``: a process pool of ``workers`` processes (``--workers``) or None. With one, the
    strategies after the independent runs are solved and scored in parallel, one per worker,
    dearest first (``DEAREST_FIRST``), when there are at least twice as many as workers (they are
    unequal: two per worker balance them); else each train's legs are (a strategy's rounds are
    sequential: train after train).
    """
    rest = [name for name in strategies if name != "independent"]
    pooled = pool.map if pool is not None else map
    by_strategy = pool is not None and len(rest) >= 2 * workers
    mapper = map if by_strategy else pooled  # the legs and re-simulations of the strategies after independent
    t0 = time.perf_counter()
    ind = independent(fleet, pooled)
    out = {}

    def report(name, result):
        out[name] = result
        if tick:
            failed = sum("failed" in r for r in out.values())
            tick(len(out), failed, len(strategies) - len(out), len(strategies))
        if progress and "failed" in result:
            progress(f"{name:12s} FAILED: {result['failed']}")
        elif progress:
            info = result["info"]
            progress(f"{name:12s} substation {result['totals']['substation_kWh']:.3f} kWh, {result['totals']['wall_s']:.1f} s"
                     + (f" ({info['rounds_stopped']})" if info.get("rounds_stopped") else "")
                     + "".join(f"; {train} kept its earlier run {why}" for train, why in info.get("rounds_held", {}).items()))

    if "independent" in strategies:
        report("independent", _scored(fleet, ind, {}, time.perf_counter() - t0, pooled))
    if by_strategy:
        futures = {pool.submit(_strategy, fleet, name, ind): name for name in
                   sorted(rest, key=lambda name: DEAREST_FIRST.index(name) if name in DEAREST_FIRST else -1)}
        for future in as_completed(futures):
            report(futures[future], future.result())
    for name in rest:
        if name not in out:
            report(name, _strategy(fleet, name, ind, mapper))
    return {name: out[name] for name in strategies}


def solve_independent(fleet, mapper=map):
    """The independent runs of ``fleet`` (strategy (a), the start of every other; each train's legs
    over ``mapper``) and their wall time [s]."""
    t0 = time.perf_counter()
    ind = independent(fleet, mapper)
    return ind, time.perf_counter() - t0


# strategies that solve no legs one by one (one NLP of everything): given a pool, :func:`one_strategy`
# runs them whole in one of its workers, not in the calling process
WHOLE = ("joint",)
BALANCE_PCT = 0.1  # [%] the circuit's energy balance a strategy may miss by (its bisection is exact to far less)


def one_strategy(fleet, name, ind, wall=0.0, pool=None):
    """One strategy of ``fleet`` from the independent runs ``ind`` (``wall``: their solve time [s]),
    solved and scored as :func:`run_strategies` does; a failed solve is {"failed": why, "wall_s"}.
    ``pool``: a process pool shared with other strategies (``studies.legpool``): the legs and
    re-simulations go to its workers, a :data:`WHOLE` strategy goes there in one piece; this
    process keeps the rounds' own work (rule terms, the circuit). A leg's run depends only on its
    task, never on the process that solved it, so the results are those of ``pool=None``."""
    mapper = pool.map if pool is not None else map
    if name == "independent":
        return _scored(fleet, ind, {}, wall, mapper)
    if pool is not None and name in WHOLE:
        return pool.submit(_strategy, fleet, name, ind).result()
    return _strategy(fleet, name, ind, mapper)


def _supervised(rule):
    def run(fleet, ind, mapper):
        runs, history, stopped, held = supervised(fleet, rule, ind, mapper=mapper)
        return runs, {"rounds_substation_kWh": history, **({"rounds_stopped": stopped} if stopped else {}),
                      **({"rounds_held": held} if held else {})}
    return run


# the strategies after independent driving (which every study solves first), by name: each entry
# takes (fleet, independent runs, mapper) and returns (runs, info)
STRATEGIES: Registry = Registry("network strategy")
for _rule in RULES:  # a supervisor rule is a strategy of supervisor rounds
    STRATEGIES.register(_rule.name, _supervised(_rule.name), doc=_rule.doc)
STRATEGIES.register("joint", lambda fleet, ind, mapper: joint(fleet, ind),
                    doc="one NLP over all trains and the circuit: the bound no rule beats")
STRATEGIES.register("following", lambda fleet, ind, mapper: (following(fleet, ind, mapper), {}),
                    doc="each train buffer_m behind the tail of the one ahead (Yazhemsky 2017, eq. 6.9)")


def _strategy(fleet, name, ind, mapper=map):
    """One strategy after independent driving, from its runs ``ind``, solved and scored (the
    re-simulations over ``mapper``); when a solve fails {"failed": why, "wall_s"}. A top-level
    function so a process pool can run it."""
    t0 = time.perf_counter()
    run = STRATEGIES.get(name)
    try:
        runs, info = run(fleet, ind, mapper)
    except SolverError as exc:  # one strategy failing does not stop the study
        return {"failed": str(exc), "wall_s": time.perf_counter() - t0}
    return _scored(fleet, runs, info, time.perf_counter() - t0, mapper)


def _scored(fleet, runs, info, wall, mapper=map):
    """A strategy's runs scored by the circuit, re-simulated (over ``mapper``) and flagged."""
    steps, trains, totals = evaluate(fleet, runs)
    flat = iter(mapper(_verified, [(leg, run) for i in range(len(runs)) for leg, run in zip(fleet.legs[i], runs[i])]))
    checks = [[next(flat) for _ in runs[i]] for i in range(len(runs))]
    gaps = separations(fleet, runs)
    for i, n in enumerate(fleet.names):
        ver = checks[i]
        last = fleet.legs[i][-1]
        trains[n].update(arrival_s=(last.start + last.steps) * fleet.dt,
                         arrival_error_worst_s=max(abs(v["arrival_time_error_s"]) for v in ver),
                         stop_error_worst_m=max(abs(v["stop_error_m"]) for v in ver),
                         energy_error_worst_pct=max(abs(v["energy_error_pct"]) for v in ver),
                         overspeed_max_kmh=max(v["overspeed_max_kmh"] for v in ver),
                         verified=all(v["passed"] for v in ver), separation_min_m=gaps[n],
                         **({"adhesion_use_max": max(v["adhesion_use_max"] for v in ver)}  # a train with the limit
                            if "adhesion_use_max" in ver[0] else {}))
    totals.update(wall_s=wall, all_verified=all(t["verified"] for t in trains.values()),
                  separation_min_m=min([g for g in gaps.values() if g is not None], default=None),
                  **guard_counts(runs))
    # only the joint optimum sees the circuit: another strategy's runs may ask for traction the
    # line cannot carry or a current limit forbids; it is not served and the result is flagged
    limit = (f"max_train_current_A {fleet.supply.max_current:g} A or the line" if math.isfinite(fleet.supply.max_current)
             else "the line: no pantograph voltage serves it")
    flags = [f"{totals['unserved_kWh']:.3f} kWh of traction not served ({limit})"] \
        if totals["unserved_kWh"] > 1e-3 else []
    if not totals["all_verified"]:
        flags.append(resimulation_missed(fleet, checks))
    floor = fleet.supply.min_voltage  # the lowest pantograph voltage of the line (V_min)
    if totals["voltage_min_V"] < floor - 0.5:  # 0.5 V: the circuit's bisection is exact to far less
        flags.append(f"a pantograph voltage fell to {totals['voltage_min_V']:.1f} V, below min_voltage_V "
                     f"{floor:.0f} V (network_steps_*.csv)")
    flags += timetable_rounding(fleet)
    closest = closest_approach(fleet, runs)
    if closest is not None and closest["gap_m"] < 0.0:  # head past the tail ahead
        flags.append(f"trains overlap on the line: train {closest['train']}'s head came {-closest['gap_m']:.1f} m past "
                     f"the tail of train {closest['ahead']} at {closest['time_s']:g} s, {closest['position_m']:.0f} m "
                     "along the line (offset_s)")
    missed = buffer_missed(fleet, runs, closest)
    if missed is not None and missed["gap_m"] >= 0.0:  # nearer than buffer_m, no overlap (flagged above)
        flags.append(f"train {missed['train']}'s head came within {missed['gap_m']:.1f} m of the tail of train "
                     f"{missed['ahead']} at {missed['time_s']:g} s, {missed['position_m']:.0f} m along the line: "
                     f"closer than buffer_m {fleet.buffer:g} m (network_trains.csv separation_min_m)")
    if abs(totals["balance_error_pct"]) > BALANCE_PCT:  # the circuit's solution did not balance its powers
        flags.append(f"the line's energy balance misses by {totals['balance_error_pct']:+.3f} % (substation plus "
                     "regeneration used against traction input plus line losses): the circuit did not balance")
    flags += not_optimal(fleet, runs, info)
    flags += [calibrated(reason).reason for reason in  # a train of a flagged calibration: every run of it
              dict.fromkeys(leg.case.train.calibration_reason for legs in fleet.legs for leg in legs) if reason]
    totals["status"] = "ok" if not flags else "flagged: " + "; ".join(flags)
    return {"runs": runs, "steps": steps, "trains": trains, "totals": totals, "info": info}


def timetable_rounding(fleet):
    """The flag (a list of at most one reason) of a timetable the clock does not keep: with
    ``running_times_s`` a train that reaches a stop more than the arrival tolerance after its
    timetable, its legs' running times rounded up to whole steps added up (``fleet.late_at_stops``);
    with a supplement, where the timetable is each segment's time rounded up, a segment whose
    rounding alone exceeds the tolerance."""
    tolerance = TOLERANCES["arrival_time_error_s"]
    late = late_at_stops(fleet)
    if fleet.timetabled:
        stop, worst = max(late, key=lambda pair: pair[1], default=(None, 0.0))
        if worst > tolerance:
            return [f"every train reaches {stop} {worst:.1f} s after its timetable: the running times, each rounded "
                    f"up to whole {fleet.dt:g} s steps (time_step_s), add up over the segments (running_times_s)"]
        return []
    rounding = np.diff([0.0] + [over for _, over in late])
    if rounding.size and rounding.max() > tolerance:
        return [f"a segment runs {rounding.max():.1f} s over its running time, rounded up to whole "
                f"{fleet.dt:g} s steps (time_step_s)"]
    return []


SHOWN_PARTS = 3  # a strategy's reason names at most this many legs or NLPs Ipopt did not prove optimal


def not_optimal(fleet, runs, info):
    """The flags of a strategy whose runs rest on a point Ipopt did not prove optimal (a usable
    point kept: ``legs.solve_leg``'s ``solver_status`` note, the joint NLP's ``solver_status``) or
    whose running times are a supplement over an all-out run Ipopt did not prove optimal,
    each naming the leg or NLP and how Ipopt ended (:func:`~ecostudy.core.status.solver_part`:
    'T1 leg 2: Ipopt ended max_iterations, not optimal')."""
    parts = [solver_part(f"{fleet.names[i]} leg {k + 1}", run.notes["solver_status"]) for i, train in enumerate(runs)
             for k, run in enumerate(train) if run.notes and "solver_status" in run.notes]
    if info.get("solver_status") is not None:
        parts.append(solver_part("the joint NLP", info["solver_status"]))
    parts += [solver_part(f"the all-out run from {a} to {b}", ended) for (a, b), ended in fleet.all_out_solver.items()]
    reasons = [s.reason for s in parts if not s.ok]
    if len(reasons) > SHOWN_PARTS:  # a long line of legs: the first ones and how many more
        reasons = reasons[:SHOWN_PARTS] + [f"and {len(reasons) - SHOWN_PARTS} more legs or NLPs not proven optimal "
                                           "(legs_not_optimal_count)"]
    return reasons


def guard_counts(runs):
    """What the local-optimum guards of ``legs.solve_leg`` did on a strategy's final runs: warm legs
    also solved cold, the largest warm-over-cold cost difference among them [%] (of the warm solves
    that ended before ``legs.WARM_MAX_ITER``), warm legs stopped there, warm legs replaced by
    their cold solve, cold legs replaced by their solve from the trapezoidal start,
    runs that stood before their stop and were solved again, and runs Ipopt did not prove optimal."""
    notes = [run.notes for train in runs for run in train if run.notes]
    checked = [n for n in notes if "warm_vs_cold_pct" in n]
    finished = [n["warm_vs_cold_pct"] for n in checked if "warm_capped_at" not in n]
    return {"legs_checked_cold_count": len(checked), "warm_vs_cold_worst_pct": max(finished, default=None),
            "legs_warm_capped_count": sum("warm_capped_at" in n for n in notes),
            "legs_replaced_by_cold_count": sum(bool(n.get("replaced_by_cold")) for n in notes),
            "legs_replaced_by_trapezoid_count": sum(bool(n.get("replaced_by_trapezoid")) for n in notes),
            "legs_restarted_standing_count": sum(bool(n.get("restarted")) for n in notes),
            "legs_not_optimal_count": sum("solver_status" in n for n in notes)}


def resimulation_missed(fleet, checks):
    """What the legs that failed their re-simulation missed (``checks``: per train, per leg, the
    :func:`~ecostudy.network.scoring.verify_leg` blocks; a leg within every tolerance failed by
    standing before its stop), on the study's clock: the legs' error grows with ``time_step_s``."""
    missed = [f"{fleet.names[i]} leg {k + 1}: " + (", ".join(outside(v)) or f"stood {v['stood_before_stop_s']:.1f} s before its stop")
              for i, legs in enumerate(checks) for k, v in enumerate(legs) if not v["passed"]]
    shown = "; ".join(missed[:3]) + (f"; and {len(missed) - 3} more legs" if len(missed) > 3 else "")
    return f"re-simulation outside tolerance ({shown}) on the {fleet.dt:g} s clock (time_step_s; network_trains.csv)"


def _verified(pair):
    """``verify_leg`` of one (leg, run): a top-level function so a process pool can run it."""
    return verify_leg(*pair)
