"""Independent verification: re-simulate a driving profile over time with an adaptive integrator.

The control is the handle u(x) per grid interval (u > 0: that share of the traction envelope,
u < 0: of the braking envelope), applied by the plant (:mod:`ecostudy.core.plant`: the same
physics functions as the NLP, scipy's adaptive Runge-Kutta DOP853 over time instead of the NLP's
trapezoidal steps in distance, restarted wherever the control or the track jumps: an adaptive
stepper can otherwise step clean over a short interval of different control). Dense output is
sampled to find the worst overspeed against the train-length limit.
"""
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ecostudy.core.grid import Segment, intervals_of
from ecostudy.core.plant import Plant, Truth, adhesion_use, controls_of  # adhesion_use: the check of every run, here too
from ecostudy.core.status import ADHESION_USE, TOLERANCES, past
from ecostudy.core.types import Train, Window
from ecostudy.core.units import FloatArray, to_kmh, to_kwh



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
    net_energy: float = 0.0  # drawn from the line minus fed back [J] (physics.line_energy)
    adhesion_use: float | None = None  # the largest share of the adhesion limit asked (adhesion_use); None: no limit


def simulate(segment: Segment, train: Train, nodes: FloatArray, handle: Sequence[float] | FloatArray,
             max_time: float | None = None, targets: Sequence[float] | FloatArray | None = None, gain: float = 1.0,
             truth: Truth = Truth()) -> tuple["Trace", list[Any]]:
    """Drive ``handle`` (one value per interval of ``nodes``) from standstill until the train stops:
    :meth:`Plant.drive` of the nominal train (or of ``truth``). ``targets`` (optional, one per
    interval, nan elsewhere) asks for cruise control there: a speed-holding controller
    F = F_R(x, v) + M * gain * (v_target - v), the resistance fed forward, clipped to the traction
    and braking envelopes (a driver or DAS holding a speed). A train with an adhesion limit has the
    trace's :func:`adhesion_use` too. Returns (:class:`Trace`, pieces)."""
    plant = Plant(segment, train, truth)
    y, t_stop, solutions = plant.drive(nodes, handle, targets, gain, max_time)
    t, x, v = dense_samples(solutions)
    grip = None
    if train.adhesion is not None:
        controls = controls_of(handle, targets, gain)
        grip = adhesion_use(plant, x, v, [controls[k] for k in intervals_of(nodes, x)])
    return Trace(t, x, v, float(y[2]), float(y[3]), float(y[4]), float(y[0]), t_stop, float(y[5]), grip), solutions


def dense_samples(solutions: Sequence[Any], samples: int = 4000) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Time, position and speed from the pieces' dense output, about ``samples`` points in all."""
    total = sum(s.t[-1] - s.t[0] for s in solutions) or 1.0
    t: list[FloatArray] = []
    x: list[FloatArray] = []
    v: list[FloatArray] = []
    for sol in solutions:
        n = max(int(samples * (sol.t[-1] - sol.t[0]) / total), 2)
        tt = np.union1d(np.linspace(sol.t[0], sol.t[-1], n), sol.t)
        xx, vv = sol.sol(tt)[:2]
        t.append(tt)
        x.append(xx)
        v.append(vv)
    return np.concatenate(t), np.concatenate(x), np.concatenate(v)


def worst_overspeed(segment: Segment, trace: Trace) -> float:
    """Largest speed above the train-length limit [m/s] along the simulated run (dense samples)."""
    over = trace.v - segment.limit(np.clip(trace.x, 0, segment.distance))
    return float(np.max(over, initial=0.0))


def window_checks(trace: Trace, windows: Sequence[Window], time_tolerance: float = 0.5,
                  speed_tolerance: float = 0.5 / 3.6) -> list[dict[str, Any]]:
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


def missed_points(checks: Sequence[dict[str, Any]]) -> list[str]:
    """The reason of each timing point a run missed (its :func:`window_checks`), naming the point by
    its distance from the departure stop with the simulated passing time and speed."""
    return [f"the timing point at {w['distance_m']:g} m is missed ({w['simulated_time_s']:.1f} s, "
            f"{w['simulated_speed_kmh']:.1f} km/h)" for w in checks if not w["kept"]]


KINETIC_FLOOR = 0.1  # share of the top speed's kinetic energy below which a run's traction is no energy scale


def energy_scale(train: Train, trace: Trace, traction_energy: float) -> float:
    """The energy [J] the re-simulation's energy errors are a share of: the run's traction work, but
    not less than :data:`KINETIC_FLOOR` of the kinetic energy at its top speed (a run down a grade
    that needs little or no traction: a share of its near-zero traction read 100 % and 5517 % off
    for 1.5e-5 kWh). A run that pulls itself to its top speed has at least that kinetic energy in
    traction, so the floor moves no run that needs traction to speak of."""
    return max(traction_energy, kinetic_floor(train, float(np.max(trace.v, initial=0.0))), 1.0)


def kinetic_floor(train: Train, top_speed: float) -> float:
    """:data:`KINETIC_FLOOR` of the kinetic energy [J] at ``top_speed`` [m/s]: an energy below it is
    no scale to take a share of (:func:`energy_scale`; a driver advice's gap to its ATO run)."""
    return KINETIC_FLOOR * 0.5 * train.mass * top_speed ** 2


def verify(segment: Segment, train: Train, nodes: FloatArray, handle: Sequence[float] | FloatArray, running_time: float,
           traction_energy: float, windows: Sequence[Window] = (),
           net_energy: float | None = None) -> tuple[dict[str, Any], Trace]:
    """Compare an optimised run with its re-simulation; returns the ``verification`` block. With
    ``net_energy`` [J] (drawn from the line minus fed back) its error too; each energy's error in %
    of :func:`energy_scale` (the traction work, or the top speed's kinetic energy where larger: a net
    energy, or the traction of a run down a grade, can be near zero). A train with an adhesion limit
    also has ``adhesion_use_max`` (the trace's :func:`adhesion_use`), at most :data:`ADHESION_USE` to pass."""
    trace, _ = simulate(segment, train, nodes, handle)
    overspeed = worst_overspeed(segment, trace)
    percent = 100.0 / energy_scale(train, trace, traction_energy)  # an energy's error in % of the run's energy
    out: dict[str, Any] = {
        "arrival_time_error_s": trace.arrival_time - running_time,
        "stop_error_m": trace.stop_position - segment.distance,
        "energy_error_pct": percent * (trace.traction_energy - traction_energy),
        **({} if net_energy is None else {"net_energy_error_pct": percent * (trace.net_energy - net_energy)}),
        "overspeed_max_kmh": to_kmh(max(overspeed, 0.0)),
        "simulated_running_time_s": trace.arrival_time,
        "simulated_traction_energy_kWh": to_kwh(trace.traction_energy),
        "simulated_net_energy_kWh": to_kwh(trace.net_energy),
    }
    tolerances = dict(TOLERANCES)
    if train.adhesion is not None:  # only then: a run of a train without the limit is written as before
        out["adhesion_use_max"] = trace.adhesion_use
        tolerances["adhesion_use_max"] = ADHESION_USE
    out["windows"] = window_checks(trace, windows)
    out["passed"] = within_tolerances(out, tolerances) and all(w["kept"] for w in out["windows"])
    out["tolerances"] = tolerances
    return out, trace


def within_tolerances(block: dict[str, Any], tolerances: dict[str, float] | None = None) -> bool:
    """Whether a ``verification`` block's errors are each within ``tolerances`` (default: the
    block's own; its timing windows apart: ``passed`` needs those kept too)."""
    return not outside(block, tolerances)


def outside(block: dict[str, Any], tolerances: dict[str, float] | None = None) -> list[str]:
    """A ``verification`` block's errors beyond ``tolerances`` (default: the block's own), each as
    ``energy_error_pct 1.32 (tolerance 1)``; a NaN error is beyond any tolerance."""
    tolerances = block["tolerances"] if tolerances is None else tolerances
    return [f"{k} {past(block[k], tol)} (tolerance {tol:g})" for k, tol in tolerances.items()
            if k in block and not abs(block[k]) <= tol]



@dataclass
class Driven:
    """A handle sequence driven by the simulator: a strategy's or an advice's named result."""

    name: str
    handle: np.ndarray
    trace: Trace

    def row(self, train: Train, distance: float) -> dict[str, Any]:
        t = self.trace
        changes = int(np.count_nonzero(np.abs(np.diff(self.handle)) > 1e-3))
        return {"strategy": self.name, "running_time_s": t.arrival_time,
                "traction_energy_kWh": to_kwh(t.traction_energy),
                "net_energy_kWh": to_kwh(t.net_energy),
                "stop_error_m": t.stop_position - distance, "handle_changes": changes,
                **({} if t.adhesion_use is None else {"adhesion_use_max": t.adhesion_use})}
