"""Independent verification: re-simulate a driving profile over time with an adaptive integrator.

The control is the handle u(x) per grid interval (u > 0: that share of the traction envelope,
u < 0: of the braking envelope), applied to the same physics functions as the NLP but with
scipy's adaptive Runge-Kutta (DOP853) over time instead of the NLP's trapezoidal steps in
distance, restarted wherever the control or the track jumps (an adaptive stepper can otherwise
step clean over a short interval of different control). Dense output is sampled to find
the worst overspeed against the train-length limit.
"""
from bisect import bisect_right
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ecostudy.core.kinematics import point_resistance
from ecostudy.core.physics import acceleration, davis_resistance
from ecostudy.core.units import to_kmh, to_kwh

TOLERANCES = {"arrival_time_error_s": 0.5, "stop_error_m": 1.0, "energy_error_pct": 1.0,
              "max_overspeed_kmh": 0.5}


@dataclass
class Trace:
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    traction_energy: float   # mechanical work of traction [J]
    braking_energy: float    # [J]
    regenerated_energy: float  # mechanical work taken by the electric brake [J] (before efficiency)
    stop_position: float     # [m]
    arrival_time: float      # [s]


def pieces(nodes, handle, segment, jump=1e-3, targets=None):
    """Start indices of runs of intervals with (nearly) the same handle, gradient and curvature.

    An adaptive stepper can step straight over a short interval of different control without
    sampling it, so the integration restarts at every such discontinuity (and wherever a cruise
    target speed starts, ends or changes).
    """
    mid = 0.5 * (nodes[:-1] + nodes[1:])
    grade, curve = segment.gradient(mid), segment.curvature(mid)
    change = ((np.abs(np.diff(handle)) > jump) | (np.diff(grade) != 0) | (np.diff(curve) != 0)
              | (np.sign(handle[1:]) != np.sign(handle[:-1])))
    if targets is not None:
        tgt = np.nan_to_num(np.asarray(targets, float), nan=-1.0)
        change |= np.diff(tgt) != 0
    return np.concatenate([[0], np.nonzero(change)[0] + 1])


def simulate(segment, train, nodes, handle, max_time=None, targets=None, gain=1.0):
    """Drive ``handle`` (one value per interval of ``nodes``) from standstill until the train stops.

    ``targets`` (optional, one per interval, nan elsewhere) asks for cruise control there: a
    speed-holding controller F = F_R(x, v) + M * gain * (v_target - v), the resistance fed
    forward, clipped to the traction and braking envelopes (a driver or DAS holding a speed).
    """
    a, b, c = (float(x) for x in train.davis)
    handle = [float(u) for u in handle]
    target = [float(x) for x in targets] if targets is not None else [float("nan")] * len(handle)
    last = len(handle) - 1
    max_time = max_time or 20 * segment.distance + 600

    node_list = nodes.tolist()
    fixed = [0.0]  # gradient + curve force of the current piece [N]: constant within a piece
    span = [0, last]  # intervals of the current piece: a step that overshoots the piece's end must
    # not sample the next piece's control, or the end event is located on a polluted dense output

    def forces(x, v):
        k = min(max(bisect_right(node_list, x) - 1, span[0]), span[1])
        resist = davis_resistance(v, a, b, c) + fixed[0]
        if target[k] == target[k]:  # cruise control (not nan)
            net = resist + train.mass * gain * (target[k] - v)
            return ((min(net, train.traction.force(v)), 0.0, resist) if net >= 0
                    else (0.0, min(-net, train.braking.force(v)), resist))
        u = handle[k]
        ft = u * train.traction.force(v) if u > 0 else 0.0
        fb = -u * train.braking.force(v) if u < 0 else 0.0
        return ft, fb, resist

    def rhs(t, y):
        x, v = y[0], y[1]
        ft, fb, resist = forces(x, v)
        if v <= 0.0 and ft <= resist:  # standing: resistance cannot push the train backwards
            return [0.0, 0.0, 0.0, 0.0, 0.0]
        fr = min(fb, train.regeneration.force(v)) if train.regeneration is not None and fb > 0 else 0.0
        return [v, acceleration(ft, fb, resist, train.mass), ft * v, fb * v, fr * v]

    def stopped(t, y):
        return y[1] if t > t_start else 1.0
    stopped.terminal, stopped.direction = True, -1

    starts = pieces(nodes, handle, segment, targets=targets)
    bounds = list(nodes[starts[1:]]) + [segment.distance + 100.0]  # past the stop: runaway guard
    y, t_start, solutions = [0.0, 1e-9, 0.0, 0.0, 0.0], 0.0, []
    for first, following, x_end in zip(starts, list(starts[1:]) + [last + 1], bounds):
        span[0], span[1] = first, following - 1
        x_mid = 0.5 * (nodes[first] + nodes[first + 1])
        fixed[0] = float(point_resistance(segment, train, x_mid))

        def reached(t, y, x_end=x_end):
            return y[0] - x_end
        reached.terminal, reached.direction = True, 1
        sol = solve_ivp(rhs, (t_start, max_time), y, method="DOP853", rtol=1e-8,
                        atol=[1e-6, 1e-8, 1.0, 1.0, 1.0], events=(stopped, reached), dense_output=True)
        solutions.append(sol)
        y, t_start = sol.y[:, -1].copy(), sol.t[-1]
        if sol.status != 1 or sol.t_events[0].size:  # stopped, or ran out of time
            break
        y[0] = x_end  # land exactly on the boundary (event location is accurate to rounding)
    t, x, v = dense_samples(solutions)
    return Trace(t, x, v, float(y[2]), float(y[3]), float(y[4]), float(y[0]), float(t_start)), solutions


def dense_samples(solutions, samples=4000):
    """Time, position and speed from the pieces' dense output, about ``samples`` points in all."""
    total = sum(s.t[-1] - s.t[0] for s in solutions) or 1.0
    t, x, v = [], [], []
    for sol in solutions:
        n = max(int(samples * (sol.t[-1] - sol.t[0]) / total), 2)
        tt = np.union1d(np.linspace(sol.t[0], sol.t[-1], n), sol.t)
        xx, vv = sol.sol(tt)[:2]
        t.append(tt)
        x.append(xx)
        v.append(vv)
    return np.concatenate(t), np.concatenate(x), np.concatenate(v)


def worst_overspeed(segment, trace):
    """Largest speed above the train-length limit [m/s] along the simulated run (dense samples)."""
    over = trace.v - segment.limit(np.clip(trace.x, 0, segment.distance))
    return float(np.max(over, initial=0.0))


def window_checks(trace, windows, time_tolerance=0.5, speed_tolerance=0.5 / 3.6):
    """Simulated passing time and speed at each timing point, and whether they keep its bounds."""
    x = np.maximum.accumulate(trace.x)
    out = []
    for w in windows:
        t = float(np.interp(w.distance, x, trace.t))
        v = float(np.interp(w.distance, x, trace.v))
        ok = ((w.earliest is None or t >= w.earliest - time_tolerance)
              and (w.latest is None or t <= w.latest + time_tolerance)
              and (w.min_speed is None or v >= w.min_speed - speed_tolerance)
              and (w.max_speed is None or v <= w.max_speed + speed_tolerance))
        out.append({"distance_m": w.distance, "simulated_time_s": t, "simulated_speed_kmh": to_kmh(v), "kept": ok})
    return out


def verify(segment, train, nodes, handle, running_time, traction_energy, windows=()):
    """Compare an optimised run with its re-simulation; returns the ``verification`` block."""
    trace, _ = simulate(segment, train, nodes, handle)
    overspeed = worst_overspeed(segment, trace)
    energy_err = 100.0 * (trace.traction_energy - traction_energy) / max(traction_energy, 1.0)
    out = {
        "arrival_time_error_s": trace.arrival_time - running_time,
        "stop_error_m": trace.stop_position - segment.distance,
        "energy_error_pct": energy_err,
        "max_overspeed_kmh": to_kmh(max(overspeed, 0.0)),
        "simulated_running_time_s": trace.arrival_time,
        "simulated_traction_energy_kWh": to_kwh(trace.traction_energy),
    }
    out["windows"] = window_checks(trace, windows)
    out["passed"] = bool(all(abs(out[k]) <= tol for k, tol in TOLERANCES.items())
                         and all(w["kept"] for w in out["windows"]))
    out["tolerances"] = dict(TOLERANCES)
    return out, trace


@dataclass
class Driven:
    """A handle sequence driven by the simulator: a strategy's or an advice's named result."""

    name: str
    handle: np.ndarray
    trace: object

    def row(self, train, distance):
        t = self.trace
        regen = train.regeneration_efficiency * t.regenerated_energy
        changes = int(np.count_nonzero(np.abs(np.diff(self.handle)) > 1e-3))
        return {"strategy": self.name, "running_time_s": t.arrival_time,
                "traction_energy_kWh": to_kwh(t.traction_energy),
                "net_energy_kWh": to_kwh(t.traction_energy / train.traction_efficiency - regen),
                "stop_error_m": t.stop_position - distance, "handle_changes": changes}
