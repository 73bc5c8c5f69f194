"""One run between two stops: build, solve, verify, tabulate. Stage times are recorded.

``solve_run`` is the library entry point behind ``ecostudy solve``.
"""
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from pyomo.common.gc_manager import PauseGC

from . import initial, model as formulation, pontryagin, regimes, solver
from .errors import InfeasibleError, SolverError
from .grid import make_grid, make_segment, node_limits
from .inputs import Timing
from .simulate import verify
from .units import KMH, KN, KW, KWH, to_kmh


@dataclass
class RunResult:
    profile: pd.DataFrame
    summary: dict
    segment: object
    train: object
    nodes: np.ndarray
    handle: np.ndarray
    trace: object = None
    stages: dict = field(default_factory=dict)
    das: tuple = None  # (advice table, simulated outcome) when a DAS method was asked for

    @property
    def ok(self):
        return self.summary["solver"]["status"] == "optimal" and self.summary["verification"]["passed"]


@contextmanager
def _stage(stages, name):
    t0 = time.perf_counter()
    yield
    stages[name] = stages.get(name, 0.0) + time.perf_counter() - t0


def handles(train, v, ft, fb):
    """Handle u in [-1, 1] per interval: net force over the envelope at the interval's mean speed."""
    vm = 0.5 * (v[:-1] + v[1:])
    net = ft - fb
    u = np.where(net >= 0, net / np.maximum(train.traction.force(vm), 1e-9),
                 net / np.maximum(train.braking.force(vm), 1e-9))
    return np.clip(u, -1.0, 1.0)


def regenerated_force(train, v, fb):
    """Part of the braking force the electric brake can take at the interval's mean speed [N]."""
    if train.regeneration is None:
        return np.zeros_like(fb)
    vm = 0.5 * (v[:-1] + v[1:])
    return np.minimum(fb, train.regeneration.force(vm))


@dataclass
class Case:
    """One segment prepared for solving: profiles, grid, node limits and the fastest envelope."""

    track: object
    train: object
    segment: object
    nodes: np.ndarray
    limits: np.ndarray
    envelope: np.ndarray   # fastest speeds on the grid [m/s] (initial.envelope_speeds)
    estimate: float        # running time of that envelope [s], close to the all-out time
    windows: tuple = ()    # inputs.Window timing points, each on a node


def prepare(track, train, from_stop, to_stop, points, stages=None, windows=()):
    """Segment between two stops, grid of ``points`` nodes, limits and the fastest envelope."""
    with _stage(stages if stages is not None else {}, "grid"):
        segment = make_segment(track, train, from_stop, to_stop)
        nodes = make_grid(segment, points, extra=[w.distance for w in windows])
        limits = node_limits(segment, nodes)
        envelope = initial.envelope_speeds(segment, train, nodes, limits)
    return Case(track, train, segment, nodes, limits, envelope, initial.running_time(envelope, nodes),
                tuple(windows))


def build(case, guess, objective, stages, weights=(1.0, 1.0), **timing):
    """The Pyomo model of ``case``; the cyclic GC is paused (it cost 70 % of the build)."""
    with _stage(stages, "build"), PauseGC():
        time_ref = max(initial.running_time(guess[0], case.nodes), 1.0)
        return formulation.build_model(case.segment, case.train, case.nodes, case.limits, guess,
                                       objective=objective, time_ref=time_ref, weights=weights,
                                       windows=case.windows, **timing)


def record(stages, outcome, nl_seconds=0.0):
    """Add one solve's NL-write and Ipopt times and iterations to ``stages``."""
    stages["nl_write"] = stages.get("nl_write", 0.0) + nl_seconds
    stages["solve"] = stages.get("solve", 0.0) + outcome.seconds
    stages["iterations"] = stages.get("iterations", 0) + outcome.iterations


def _solve_once(case, guess, objective, stages, options, **timing):
    m = build(case, guess, objective, stages, **timing)
    outcome = solver.solve(m, options)
    record(stages, outcome, outcome.nl_seconds)
    return m, outcome


def guess_from_speeds(case, speeds):
    """(v, dt, F_T, F_B) on the grid realising ``speeds``: Ipopt's starting point."""
    dt = initial.interval_times(np.maximum(speeds, 5e-4), case.nodes)  # no infinite first/last step
    ft, fb = initial.forces_for(speeds, case.segment, case.train, case.nodes)
    return speeds, dt, ft, fb


def capped_guess(case, running_time):
    """Fastest envelope capped at one cruise speed so that it takes ``running_time``."""
    return guess_from_speeds(case, initial.capped_speeds(case.envelope, case.nodes, running_time))


def warm_guess(previous, case):
    """Starting point interpolated from a previous result's profile (speed vs position)."""
    prof = previous.profile
    speeds = np.minimum(np.interp(case.nodes, prof["position_m"], prof["speed_kmh"] * KMH), case.limits)
    speeds[0] = speeds[-1] = 0.0
    return guess_from_speeds(case, speeds)


def all_out(case, stages, options=None):
    """Minimum running time on this grid [s], the solved model and Ipopt's outcome."""
    m, outcome = _solve_once(case, guess_from_speeds(case, case.envelope), "time", stages, options)
    if not outcome.usable and case.windows and outcome.status in ("infeasible", "restoration_failed"):
        points = ", ".join(f"{w.distance:.0f} m" for w in case.windows)
        raise InfeasibleError(f"infeasible: no run keeps the timing windows at {points} from "
                              f"{case.segment.from_stop} ({outcome.status})")
    if not outcome.usable:
        raise SolverError(f"Ipopt could not find the all-out run ({outcome.status})")
    return float(np.sum(formulation.solution_arrays(m)[1])), m, outcome


def solve_run(track, train, from_stop, to_stop, timing=Timing(), objective="energy", points=1000,
              weights=(1.0, 1.0), warm_start=None, options=None, verify_result=True, windows=()):
    """Energy-optimal (or all-out, or mixed) run between two stops, verified by simulation.

    Parameters
    ----------
    timing : Timing  running time [s], supplement over the all-out time [-], or window [s].
    objective : str  ``energy``, ``net_energy``, ``time`` (all-out) or ``mixed``.
    points : int  Grid nodes K.
    warm_start : RunResult, optional  Start Ipopt from this earlier result.
    windows : sequence of inputs.Window  Timing points on the way (earliest/latest, speed bounds).
    """
    stages = {}
    case = prepare(track, train, from_stop, to_stop, points, stages, windows)
    check_windows(case)
    target, window, t_allout = timing.running_time, timing.window, None
    latest = target if target is not None else (window[1] if window else None)
    if objective == "time" or timing.supplement is not None or (latest is not None and latest < 0.97 * case.estimate):
        t_allout, m, outcome = all_out(case, stages, options)
        if timing.supplement is not None:
            target = t_allout * (1 + timing.supplement)
        _check_feasible(latest, t_allout)

    if objective != "time":
        if warm_start is not None:
            guess = warm_guess(warm_start, case)
        else:
            guess = capped_guess(case, target or (window[1] if window else case.estimate * 1.1))
        kw = {"running_time": target} if target is not None else {"window": window} if window else {}
        m, outcome = _solve_once(case, guess, objective, stages, options, weights=weights, **kw)
        if not outcome.usable:
            if latest is not None and t_allout is None:
                t_allout, _, _ = all_out(case, stages, options)
                _check_feasible(latest, t_allout)
            raise SolverError(f"Ipopt failed ({outcome.status}) after {outcome.iterations} iterations; "
                              "try more --points or a longer running time")
    return finish(case, m, outcome, stages, objective, t_allout, verify_result)


def finish(case, m, outcome, stages, objective, t_allout=None, verify_result=True):
    """Tables, regimes and verification of a solved model: the :class:`RunResult`."""
    train, segment, nodes = case.train, case.segment, case.nodes
    with _stage(stages, "tables"):
        v, dt, ft, fb, _ = formulation.solution_arrays(m)
        u = handles(train, v, ft, fb)
        profile, totals = tabulate(train, nodes, v, dt, ft, fb)
        net = objective == "net_energy"
        labels = regimes.classify(train, v, ft, fb, regeneration=net and train.regeneration is not None)
        regime_runs = regimes.runs(labels, nodes)
        costate = None
        if objective in ("energy", "net_energy"):  # psi = lambda / v of eq. 2.17 (7.4) from Ipopt's multipliers
            psi = pontryagin.ipopt_psi(m, nodes, train, objective)
            bounds = pontryagin.regime_bounds(train, v, ft, fb, labels, objective)
            costate = {"method": "Ipopt multipliers of the speed recursion",
                       "conditions": "eq. 7.4 (regeneration credited)" if net else "eq. 2.17",
                       **pontryagin.check(nodes, labels, psi, bounds=bounds)}
            profile["costate_ratio"] = np.append(psi, np.nan)
        marginal = formulation.marginal_energy(m) if objective in ("energy", "net_energy") else None
    verification, trace = None, None
    if verify_result:
        with _stage(stages, "verify"):
            verification, trace = verify(segment, train, nodes, u, totals["running_time_s"],
                                         totals["traction_energy_kWh"] * KWH, case.windows)
    summary = {
        "track": case.track.name, "train": train.name, "from": segment.from_stop, "to": segment.to_stop,
        "distance_m": segment.distance, **totals, "points": len(nodes), "objective": objective,
        "all_out_time_s": t_allout,
        "marginal_energy_kWh_per_s": None if marginal is None else marginal / KWH,
        "regimes": {"sequence": regimes.sequence_text(regime_runs),
                    "distance_shares": regimes.distance_shares(labels, nodes),
                    "runs": [{"regime": r, "start_m": a, "end_m": b} for r, a, b in regime_runs]},
        "pontryagin": costate,
        "solver": {"status": outcome.status, "iterations": outcome.iterations,
                   "seconds": stages.get("solve", 0.0), "max_constraint_violation": outcome.max_violation},
        "verification": verification,
        "stages_s": {k: round(v_, 4) for k, v_ in stages.items() if k != "iterations"},
    }
    return RunResult(profile, summary, segment, train, nodes, u, trace, stages)


def check_windows(case, margin=0.02):
    """Refuse at once a timing window no run can keep: passing later than ``latest`` even on the
    fastest envelope (with every window's speed cap), or a minimum speed above that envelope.
    Within ``margin`` of these bounds the NLP decides (the envelope is an explicit estimate)."""
    if not case.windows:
        return
    limits = case.limits.copy()
    index = [formulation.window_node(case.nodes, w.distance) for w in case.windows]
    for k, w in zip(index, case.windows):
        if w.max_speed is not None:
            limits[k] = min(limits[k], w.max_speed)
    fastest = initial.envelope_speeds(case.segment, case.train, case.nodes, limits)
    passing = np.concatenate([[0.0], np.cumsum(initial.interval_times(fastest, case.nodes))])
    for k, w in zip(index, case.windows):
        if w.latest is not None and w.latest < (1 - margin) * passing[k]:
            raise InfeasibleError(f"infeasible: the fastest run passes {w.distance:.0f} m from "
                                  f"{case.segment.from_stop} at {passing[k]:.1f} s (window: by {w.latest:.1f} s)")
        if w.min_speed is not None and w.min_speed > (1 + margin) * fastest[k]:
            raise InfeasibleError(f"infeasible: at {w.distance:.0f} m from {case.segment.from_stop} the train "
                                  f"reaches at most {to_kmh(fastest[k]):.1f} km/h (window: at least "
                                  f"{to_kmh(w.min_speed):.1f} km/h)")


def _check_feasible(latest, t_allout):
    if latest is not None and latest < t_allout - 1e-6 * t_allout:
        raise InfeasibleError(f"infeasible: the fastest possible run takes {t_allout:.1f} s "
                              f"(asked for {latest:.1f} s)")


def tabulate(train, nodes, v, dt, ft, fb):
    """Profile table (one row per node; interval quantities on the row of the interval start) and totals."""
    ds = np.diff(nodes)
    fr = regenerated_force(train, v, fb)
    work_t, work_b, work_r = ft * ds, fb * ds, fr * ds
    u = handles(train, v, ft, fb)
    pad = lambda a: np.append(a, np.nan)  # noqa: E731  the last node starts no interval
    profile = pd.DataFrame({
        "position_m": nodes,
        "time_s": np.concatenate([[0.0], np.cumsum(dt)]),
        "speed_kmh": to_kmh(v),
        "handle": pad(u),
        "traction_force_kN": pad(ft / KN),
        "braking_force_kN": pad(fb / KN),
        "power_kW": pad(ft * 0.5 * (v[:-1] + v[1:]) / KW),
        "cumulative_energy_kWh": np.concatenate([[0.0], np.cumsum(work_t)]) / KWH,
    })
    regen = train.regeneration_efficiency * work_r.sum()
    totals = {
        "running_time_s": float(dt.sum()),
        "traction_energy_kWh": float(work_t.sum() / KWH),
        "braking_energy_kWh": float(work_b.sum() / KWH),
        "regenerated_energy_kWh": float(regen / KWH),
        "net_energy_kWh": float((work_t.sum() / train.traction_efficiency - regen) / KWH),
        "traction_energy_J_per_kg": float(work_t.sum() / train.static_mass),
        "top_speed_kmh": float(to_kmh(v.max())),
    }
    return profile, totals
