"""Independent verification: re-simulate a driving profile over time with an adaptive integrator.

The control is the handle u(x) per grid interval (u > 0: that share of the traction envelope,
u < 0: of the braking envelope), applied to the same physics functions as the NLP but with
scipy's adaptive Runge-Kutta (DOP853) over time instead of the NLP's trapezoidal steps in
distance. Dense output is sampled to find the worst overspeed against the train-length limit.
"""
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from .physics import acceleration, running_resistance
from .units import to_kmh

TOLERANCES = {"arrival_time_error_s": 0.5, "stop_error_m": 1.0, "energy_error_pct": 1.0,
              "max_overspeed_kmh": 0.5}


@dataclass
class Trace:
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    traction_energy: float   # mechanical work of traction [J]
    braking_energy: float    # [J]
    stop_position: float     # [m]
    arrival_time: float      # [s]


def simulate(segment, train, nodes, handle, max_time=None):
    """Drive ``handle`` (one value per interval of ``nodes``) from standstill until the train stops."""
    a, b, c = train.davis
    last = len(handle) - 1
    max_time = max_time or 20 * segment.distance / 1.0 + 600

    def forces(x, v):
        k = min(max(int(np.searchsorted(nodes, x, side="right")) - 1, 0), last)
        u = handle[k]
        ft = u * train.traction.force(v) if u > 0 else 0.0
        fb = -u * train.braking.force(v) if u < 0 else 0.0
        resist = running_resistance(v, (a, b, c), train.static_mass, segment.gradient(x),
                                    train.curve_coefficient, segment.curvature(x))
        return ft, fb, resist

    def rhs(t, y):
        x, v = y[0], y[1]
        ft, fb, resist = forces(x, v)
        if v <= 0.0 and ft <= resist:  # standing: resistance cannot push the train backwards
            return [0.0, 0.0, 0.0, 0.0]
        return [v, acceleration(ft, fb, resist, train.mass), ft * v, fb * v]

    def stopped(t, y):
        return y[1] if t > 0 else 1.0
    stopped.terminal, stopped.direction = True, -1

    def runaway(t, y):
        return y[0] - (segment.distance + 100.0)
    runaway.terminal = True

    sol = solve_ivp(rhs, (0.0, max_time), [0.0, 1e-9, 0.0, 0.0], method="DOP853", rtol=1e-8,
                    atol=[1e-6, 1e-8, 1.0, 1.0], events=(stopped, runaway), dense_output=True)
    return Trace(sol.t, sol.y[0], sol.y[1], float(sol.y[2, -1]), float(sol.y[3, -1]),
                 float(sol.y[0, -1]), float(sol.t[-1])), sol


def worst_overspeed(segment, sol, samples=20000):
    """Largest speed above the train-length limit [m/s] along the simulated run (dense output)."""
    t = np.linspace(sol.t[0], sol.t[-1], samples)
    x, v = sol.sol(t)[:2]
    x = np.concatenate([x, sol.y[0]])
    v = np.concatenate([v, sol.y[1]])
    return float(np.max(v - segment.limit(np.clip(x, 0, segment.distance)), initial=0.0))


def verify(segment, train, nodes, handle, running_time, traction_energy):
    """Compare an optimised run with its re-simulation; returns the ``verification`` block."""
    trace, sol = simulate(segment, train, nodes, handle)
    overspeed = worst_overspeed(segment, sol)
    energy_err = 100.0 * (trace.traction_energy - traction_energy) / max(traction_energy, 1.0)
    out = {
        "arrival_time_error_s": trace.arrival_time - running_time,
        "stop_error_m": trace.stop_position - segment.distance,
        "energy_error_pct": energy_err,
        "max_overspeed_kmh": to_kmh(max(overspeed, 0.0)),
        "simulated_running_time_s": trace.arrival_time,
        "simulated_traction_energy_kWh": trace.traction_energy / 3.6e6,
    }
    out["passed"] = bool(all(abs(out[k]) <= tol for k, tol in TOLERANCES.items()))
    out["tolerances"] = dict(TOLERANCES)
    return out, trace
