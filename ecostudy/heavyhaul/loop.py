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
from ecostudy.heavyhaul.plant import LOSSES
from ecostudy.heavyhaul.rhc import TERMS, input_offsets


class LoopRecord(NamedTuple):
    times: np.ndarray          # [s] at the end of each sample
    head: np.ndarray           # head position [m] at the end of each sample
    mean_speed: np.ndarray     # [m/s]
    reference: np.ndarray      # v_r at the head's position [m/s], at the end of each sample
    largest_coupler: np.ndarray  # largest |f_in| within each sample [N]
    couplers: np.ndarray       # (samples, couplers) f_in at the end of each sample [N]
    efforts: np.ndarray        # (samples, virtual cars) [N]
    solve_seconds: np.ndarray
    speed_excess: np.ndarray   # largest (fastest car - the train's limit at the head) within each sample [m/s]
    dynamic_limits: np.ndarray  # (samples, locomotive virtual cars) their dynamic brakes' limits [N, > 0]
    terms: np.ndarray          # (samples, 4) eq. 4's terms at each sample's optimum (rhc.TERMS; nan if unknown)
    traction_work: float       # [J]
    dynamic_brake_work: float
    wagon_brake_work: float
    overruns: int = 0          # solves slower than Ts: the previous input was held
    arrived: bool = True       # stopped on the reference's final approach (False: the sample cap came first)
    losses: tuple = ()         # plant.LOSSES over the run [J]
    stored_change: float = 0.0  # kinetic plus coupler elastic energy at the end minus at the start [J]


def reduced_state(plant, reduction, state):
    """The design-model state of the fence-reduced train from the plant's state."""
    c = plant.consist
    speeds = reduction.reduce(state.speeds, c.mass)
    forces = plant.coupler_forces(state.positions, state.speeds)
    boundary = [cars[-1] for cars in reduction.members[:-1]]
    return np.concatenate([speeds, forces[boundary] / reduction.model.stiffness])


def limits(plant, reduction, state):
    """(low, high) efforts of every virtual car [N]: the sum of its cars' envelopes at their speeds."""
    low, high = plant.envelopes(state.speeds)
    return reduction.reduce(low), reduction.reduce(high)


def head_position(plant, state):
    """The head's front [m] along the segment (the reference's distance)."""
    return float(state.positions[0] + 0.5 * plant.consist.length[0])


def horizon(plant, reduction, reference, state, speeds, np_):
    """(input offsets per sample [N], v_r(k) for k = 0..Np [m/s]) along the predicted positions
    (eq. 9's F1, F2): the head advances as the reference does from the reference's clock at the
    head's position; each sample's offsets are the grade and curve forces at its middle and the
    resistance at the (virtual) cars' ``speeds``."""
    ts, head = reduction.model.ts, head_position(plant, state)
    heads = reference.position_at(reference.time_at(head) + ts * np.arange(np_ + 1))
    middles = 0.5 * (heads[:-1] + heads[1:]) - head
    offsets = np.array([input_offsets(reduction.model.mass, reduction.resistance, speeds,
                                      reduction.reduce(plant.fixed_forces(state.positions + d))) for d in middles])
    return offsets, reference.speed(heads)


STOPPED = 0.3  # [m/s]: a train crawling slower on its final approach has stopped (1 km/h)


def finished(plant, reference, state):
    """Stopped (mean speed below :data:`STOPPED`) on the reference's final approach: a speed-tracking
    controller stops where its speed runs out, not at a point (the stop error is reported)."""
    mean = np.dot(plant.consist.mass, state.speeds) / plant.consist.mass.sum()
    return mean < STOPPED and head_position(plant, state) > reference.final_approach


def run(plant, reduction, controller, state, reference, samples, observer=None, applied=None):
    """At most ``samples`` steps of Ts from ``state`` (fewer when the train stops at the end of the
    ``reference``, a :class:`~ecostudy.heavyhaul.reference.Reference`); ``applied`` the efforts per
    virtual car [N] before the first sample (default: none)."""
    c, ts = plant.consist, reduction.model.ts
    nv, locos = len(reduction.members), reduction.locomotives
    u = np.zeros(nv) if applied is None else np.asarray(applied, float)
    rows, works, overruns, arrived = [], np.zeros(3), 0, False
    losses, stored = np.zeros(len(LOSSES)), plant.stored_energy(state)
    for _ in range(samples):
        measured = reduced_state(plant, reduction, state)
        x0 = measured if observer is None else observer.x.copy()  # eq. 10's x^(k|k-1)
        offsets, vr = horizon(plant, reduction, reference, state, x0[:nv], controller.np_)
        low, high = limits(plant, reduction, state)
        planned = controller.solve(x0, offsets / KN, low / KN, high / KN, vr) * KN
        if controller.last.seconds <= ts:
            u = planned
        else:
            overruns += 1
        if observer is not None:  # only the locomotives' speeds are measured (eq. 3)
            observer.update(measured[locos], u - offsets[0])
        step = plant.step(state, reduction.share(u, c.mass), ts)
        state = step.state
        works += [step.traction_work, step.dynamic_brake_work, step.wagon_brake_work]
        losses += step.losses
        head = head_position(plant, state)
        values = getattr(controller, "values", None) or {}
        rows.append((state.time, head, np.dot(c.mass, state.speeds) / c.mass.sum(), reference.speed(head),
                     step.largest_coupler_force, step.coupler_forces, u, controller.last.seconds, step.speed_excess,
                     -low[locos], [values.get(t, np.nan) for t in TERMS]))
        if finished(plant, reference, state):
            arrived = True
            break
    columns = (np.array(v) for v in zip(*rows))
    return state, LoopRecord(*columns, *map(float, works), overruns, arrived, tuple(map(float, losses)),
                             plant.stored_energy(state) - stored)
