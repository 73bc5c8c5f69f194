"""The heavy-haul closed loop: the receding-horizon controller (heavyhaul.rhc) on the fence-reduced
design model driving the full cascade plant (heavyhaul.plant), one sample Ts at a time.

The controller reads either the plant's state reduced to virtual cars (mass-weighted speeds; a
virtual coupler's extension from the force of the real coupler at the boundary over the virtual
stiffness) or, given an ``observer`` (heavyhaul.observer, eq. 10), its estimate from the
locomotives' measured speeds. Efforts are per virtual car, shared back to its cars in proportion
to mass, clipped by the plant to every car's envelope. A solve that takes longer than Ts is not
applied: the previous input is held, as the paper does (counted in ``overruns``).
"""
from typing import NamedTuple

import numpy as np

from ecostudy.core.units import KN
from ecostudy.heavyhaul.rhc import input_offsets


class LoopRecord(NamedTuple):
    times: np.ndarray          # [s] at the end of each sample
    mean_speed: np.ndarray     # [m/s]
    largest_coupler: np.ndarray  # largest |f_in| within each sample [N]
    efforts: np.ndarray        # (samples, virtual cars) [N]
    solve_seconds: np.ndarray
    traction_work: float       # [J]
    dynamic_brake_work: float
    wagon_brake_work: float
    overruns: int = 0          # solves slower than Ts: the previous input was held


def reduced_state(plant, reduction, state):
    """The design-model state of the fence-reduced train from the plant's state."""
    c = plant.consist
    speeds = reduction.reduce(state.speeds, c.mass)
    forces = plant.coupler_forces(state.positions, state.speeds)
    boundary = [cars[-1] for cars in reduction.members[:-1]]
    return np.concatenate([speeds, forces[boundary] / reduction.model.stiffness])


def limits(plant, reduction, state):
    """(low, high) efforts of every virtual car [N]: the sum of its cars' envelopes at their speeds."""
    c, low, high = plant.consist, [], []
    for cars in reduction.members:
        up = sum(c.traction[i].force(max(float(state.speeds[i]), 0.1)) if c.traction[i] else 0.0 for i in cars)
        dyn = sum(c.dynamic_brake[i].force(max(float(state.speeds[i]), 0.1)) if c.dynamic_brake[i] else 0.0
                  for i in cars)
        low.append(-(dyn + c.pneumatic_brake[cars].sum()))
        high.append(up)
    return np.array(low), np.array(high)


def run(plant, reduction, controller, state, reference, samples, observer=None, applied=None):
    """``samples`` steps of Ts from ``state``; ``reference(t)`` the reference speed [m/s] at time t;
    ``applied`` the efforts per virtual car [N] before the first sample (default: none)."""
    c, ts = plant.consist, reduction.model.ts
    nv, locos = len(reduction.members), reduction.locomotives
    u = np.zeros(nv) if applied is None else np.asarray(applied, float)
    rows, works, overruns = [], np.zeros(3), 0
    for _ in range(samples):
        measured = reduced_state(plant, reduction, state)
        x0 = measured if observer is None else observer.x.copy()  # eq. 10's x^(k|k-1)
        grades = reduction.reduce(plant.segment.gradient(state.positions), c.mass)
        offsets = input_offsets(reduction.model.mass, reduction.resistance, x0[:nv], grades)
        low, high = limits(plant, reduction, state)
        horizon = [reference(state.time + k * ts) for k in range(controller.np_ + 1)]
        planned = controller.solve(x0, offsets / KN, low / KN, high / KN, horizon) * KN
        if controller.last.seconds <= ts:
            u = planned
        else:
            overruns += 1
        if observer is not None:  # only the locomotives' speeds are measured (eq. 3)
            observer.update(measured[locos], u - offsets)
        step = plant.step(state, reduction.share(u, c.mass), ts)
        state = step.state
        works += [step.traction_work, step.dynamic_brake_work, step.wagon_brake_work]
        rows.append((state.time, np.dot(c.mass, state.speeds) / c.mass.sum(), step.largest_coupler_force, u,
                     controller.last.seconds))
    times, mean, largest, efforts, seconds = (np.array(v) for v in zip(*rows))
    return state, LoopRecord(times, mean, largest, efforts, seconds, *map(float, works), overruns)
