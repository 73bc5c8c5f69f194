"""The heavy-haul closed loop: the receding-horizon controller (heavyhaul.rhc) on the fence-reduced
design model driving the full cascade plant (heavyhaul.plant), one sample Ts at a time.

The controller reads either the plant's state reduced to virtual cars (mass-weighted speeds; a
virtual coupler's extension from the force of the real coupler at the boundary over the virtual
stiffness) or, given an ``observer`` (heavyhaul.observer, eq. 10), its estimate from the
locomotives' measured speeds. Efforts are per virtual car, shared back to its cars in proportion
to mass, clipped by the plant to every car's envelope. A solve that takes longer than Ts is not
applied: the previous input is held, as the paper does (counted in ``overruns``).
A standing train on a climb is held on its brakes while the traction asked of its locomotives is below the grade
and resistance it feels (:func:`held`: a driver's hill start; the held time counts in the run). A train held
twice running with the same plan stands held for good (:func:`repeats`): the run ends there.

The terminal approach: past the reference's stop v_r continues its final deceleration below zero
(a held last move then brakes into the stop at the reference's rate instead of stopping within a
sample to stand for the rest of the horizon), and the sample in which the controller's plan stops
the train brakes it onto the stop (or pulls it there, where coasting would stand it short on a
climb) and ends when it stands (:func:`stopping`).
"""
from typing import NamedTuple

import numpy as np

from ecostudy.core.errors import SolverError
from ecostudy.core.status import PROVEN
from ecostudy.core.units import KMH, KN
from ecostudy.heavyhaul.approach import braking_point, stopping_share
from ecostudy.heavyhaul.plant import LOSSES, CascadeStep
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
    adhesion: np.ndarray       # (samples, 5) the largest adhesion use within each sample (CascadePlant.adhesion_use)
    held: np.ndarray           # True for a sample the train stood held on its brakes (:func:`held`)
    traction_work: float       # [J]
    dynamic_brake_work: float
    wagon_brake_work: float
    overruns: int = 0          # solves slower than Ts: the previous input was held
    stood: bool = True         # stood on the reference's final approach, anywhere on it (False: the sample cap came first, or rolling_back)
    losses: tuple = ()         # plant.LOSSES over the run [J]
    stored_change: float = 0.0  # kinetic plus coupler elastic energy at the end minus at the start [J]
    rolling_back: bool = False  # the run ended on the final approach with the train rolling back (not stood)
    end_forces: tuple = (0.0, 0.0)  # where the run ended: (grade and resistance the train feels, its locomotives' utmost traction) [N]
    held_for_good: bool = False  # the run ended held on its brakes with the plan of the sample before (:func:`repeats`)
    unproven: tuple = ()  # how the solver ended each driven solve it did not prove optimal (e.g. AlmostSolved)


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
    head's position, and past the stop v_r continues the final deceleration below zero
    (:meth:`~ecostudy.heavyhaul.reference.Reference.speed_in`); each sample's offsets are the grade
    and curve forces at its middle and the resistance at the (virtual) cars' ``speeds``."""
    ts, head = reduction.model.ts, head_position(plant, state)
    heads = reference.position_at(reference.time_at(head) + ts * np.arange(np_ + 1))
    middles = 0.5 * (heads[:-1] + heads[1:]) - head
    offsets = np.array([input_offsets(reduction.model.mass, reduction.resistance, speeds,
                                      reduction.reduce(plant.fixed_forces(state.positions + d))) for d in middles])
    return offsets, reference.speed_in(ts * np.arange(np_ + 1), head)


def target_words(vr_end):
    """The horizon's target at the sample's end [m/s] as a failed solve's reason states it: past the
    reference's stop the target continues below zero (:func:`horizon`), the reference itself is 0."""
    if vr_end > 0:
        return f"v_r {vr_end / KMH:.1f} km/h at the sample's end"
    return "v_r 0 km/h at the sample's end (past the reference's stop)"


STOPPED = 0.3  # [m/s]: a plan that slows the train below this on its final approach stops it (1 km/h)


def finished(plant, reference, state):
    """Standing (mean speed below :data:`STANDING`) or rolling back on the reference's final approach
    (where it stood: the stop error, reported and checked). A train still crawling forward there runs
    on: the next sample's plan stops it (:func:`stopping`), short of the stop or beyond it."""
    return mean_speed(plant, state) < STANDING and head_position(plant, state) > reference.final_approach


PIECE = 1.0  # [s]: the stopping sample is stepped in pieces this long (at most)
STANDING = 0.02  # [m/s]: a train slower stands (the stopping sample ends, a run ends, a held train creeps no faster)


def mean_speed(plant, state):
    """The train's mass-weighted mean speed [m/s]."""
    return float(np.dot(plant.consist.mass, state.speeds) / plant.consist.mass.sum())


def stopping(plant, reduction, reference, state, planned, ts):
    """The sample in which the controller's plan stops the train (its predicted mean speed v(1) below
    :data:`STOPPED`, on the final approach), stepped in pieces of :data:`PIECE`: in each the train
    runs at the constant deceleration v^2 / 2d that stops its head at the stop (d the distance to
    go; the whole brake beyond it): where the resistance and grades the train feels decelerate it
    more (coasting would stand it short, on a climb) the locomotives pull the difference, each its
    share of its traction envelope (adhesion included when on; all of it when that is not enough);
    else the planned move's braking is scaled to the brake needed. With air brakes the pipe's delays,
    build-up and release are anticipated instead (:func:`~ecostudy.heavyhaul.approach.stopping_share`:
    the share of every brake, or where even coasting stands the train short, of the traction, that
    stands the head at the stop in the one-mass prediction); and the sample ends when the
    train stands (mean speed under :data:`STANDING`; its brakes hold it, as friction; a piece lasts
    at most the time the train needs to stop). One :class:`~ecostudy.heavyhaul.plant.CascadeStep` for the sample."""
    c, steps, u, now = plant.consist, [], planned, state
    end = state.time + ts
    while end - now.time > 1e-6 and mean_speed(plant, now) >= STANDING and len(steps) < 10 * ts / PIECE:
        v, d = mean_speed(plant, now), reference.distance[-1] - head_position(plant, now)
        held = float(plant.resistance(now.positions, now.speeds).sum())  # running, grade, curve [N]
        low, high = limits(plant, reduction, now)
        wanted = held - c.mass.sum() * v * v / (2 * d) if d > 0 else 0.0  # [N]: the constant deceleration v^2 / 2d
        if plant.air_brake is not None and d > 0:  # the pipe's delays, build-up and release anticipated (heavyhaul.approach)
            share, stop_in, pulling = stopping_share(plant, now, reduction.share(low, c.mass),
                                                     reduction.share(high, c.mass), d)
            u = share * (high if pulling else low)
        elif wanted > 0:  # coasting stands it short (a climb): the locomotives pull that force, within their envelopes
            u, stop_in = np.clip(high * (wanted / max(high.sum(), 1.0)), 0.0, high), 2 * d / v
        elif d > 0:  # the constant deceleration that stops the head at the stop, for at most its 2d/v
            stop_in = 2 * d / v
            shape = planned if planned.sum() < 0 else low  # else every car the same share of its brakes
            u = np.clip(shape * (wanted / shape.sum()), low, 0.0)
        else:  # beyond: the whole brake until the train stands
            u, stop_in = low, v * c.mass.sum() / max(held - low.sum(), 1.0)
        dt = min(PIECE, max(stop_in, 0.01), end - now.time)
        steps.append(plant.step(now, reduction.share(u, c.mass), dt))
        now = steps[-1].state
    return combined(steps), u


def held(plant, reduction, state, planned):
    """A standing train (mean speed under :data:`STANDING`) on a climb is held on its brakes for the
    sample (a hill start: :meth:`~ecostudy.heavyhaul.plant.CascadePlant.hold`) while the traction its
    locomotives would apply (``planned`` per virtual car, within their envelopes) is below the grade,
    curve and running resistance it feels; the controller's plan is kept. Where the grade does not
    pull it back (level or falling on the whole) a standing train stays standing without the hold."""
    if abs(mean_speed(plant, state)) >= STANDING or float(plant.grade_curve(state.positions)[0].sum()) <= 0.0:
        return False
    efforts = plant.efforts(reduction.share(planned, plant.consist.mass), state.speeds)
    return float(np.maximum(efforts[plant.loco], 0.0).sum()) < float(plant.resistance(state.positions, state.speeds).sum())


REPEATED = 1e-3  # [N]: a plan within this of the one before, every virtual car, is the same plan


def repeats(held_now, held_before, plan, before, estimate=None, estimated=None):
    """True when a sample held the train (``held_now``) as the one before did (``held_before``) with
    the same ``plan`` as that one's (``before``, N per virtual car, within :data:`REPEATED`) and the same
    observer ``estimate`` (None: no observer): the train stands where it stood, with the same brakes, so
    the controller is asked the same again and the train stays held to the sample cap."""
    same = before is not None and np.allclose(plan, before, rtol=0.0, atol=REPEATED)
    if estimate is not None:
        same = same and np.allclose(estimate, estimated, rtol=0.0, atol=1e-12)
    return bool(held_now and held_before and same)


def anticipated(plant, reduction, reference, state, ts):
    """With air brakes: the final application is due now (:func:`~ecostudy.heavyhaul.approach.braking_point`
    at the reference's final deceleration); from then on every sample is a stopping sample."""
    low, _ = limits(plant, reduction, state)
    return braking_point(plant, state, reduction.share(low, plant.consist.mass),
                         reference.distance[-1] - head_position(plant, state), reference.final_deceleration, ts)


def combined(steps):
    """Consecutive steps as one :class:`~ecostudy.heavyhaul.plant.CascadeStep`."""
    if not steps:
        return None
    last = steps[-1]
    return CascadeStep(last.state, last.coupler_forces, max(s.largest_coupler_force for s in steps),
                       *(sum(getattr(s, k) for s in steps) for k in ("traction_work", "dynamic_brake_work",
                                                                      "wagon_brake_work")),
                       max(s.speed_excess for s in steps), tuple(np.sum([s.losses for s in steps], axis=0)),
                       max((s.adhesion for s in steps), key=lambda a: a[0]), last.levels)


def run(plant, reduction, controller, state, reference, samples, observer=None, applied=None):
    """At most ``samples`` steps of Ts from ``state`` (fewer when the train stops at the end of the
    ``reference``, a :class:`~ecostudy.heavyhaul.reference.Reference`); ``applied`` the efforts per
    virtual car [N] before the first sample (default: none)."""
    c, ts = plant.consist, reduction.model.ts
    nv, locos = len(reduction.members), reduction.locomotives
    u = np.zeros(nv) if applied is None else np.asarray(applied, float)
    rows, works, overruns, stood, braking, rolling_back = [], np.zeros(3), 0, False, False, False
    held_before, before, estimated, for_good, unproven = False, None, None, False, []
    losses, stored = np.zeros(len(LOSSES)), plant.stored_energy(state)
    for _ in range(samples):
        measured = reduced_state(plant, reduction, state)
        x0 = measured if observer is None else observer.x.copy()  # eq. 10's x^(k|k-1)
        low, high = limits(plant, reduction, state)
        offsets, vr = horizon(plant, reduction, reference, state, x0[:nv], controller.np_)
        try:
            planned = controller.solve(x0, offsets / KN, low / KN, high / KN, vr) * KN
        except SolverError as exc:  # where the train was, in the reason
            raise SolverError(f"{exc} at {state.time:.0f} s, head at {head_position(plant, state):.0f} m, "
                              f"mean speed {mean_speed(plant, state) / KMH:.1f} km/h against "
                              f"{target_words(vr[1])}") from exc
        seconds = controller.last.seconds
        if seconds <= ts:
            u = planned
            if controller.last.status not in PROVEN:  # usable, not proven optimal: driven, and counted
                unproven.append(controller.last.status)
        else:
            overruns += 1
        if observer is not None:  # only the locomotives' speeds are measured (eq. 3)
            observer.update(measured[locos], u - offsets[0])
        step = None
        braking = braking or (plant.air_brake is not None and anticipated(plant, reduction, reference, state, ts))
        if braking or (head_position(plant, state) > reference.final_approach
                       and (getattr(controller, "values", None) or {}).get("planned", [np.inf])[0] < STOPPED):
            step, u = stopping(plant, reduction, reference, state, u, ts)  # the plan stops within this sample
        holding = step is None and held(plant, reduction, state, u)
        if holding:
            step = plant.hold(state, ts, STANDING)
        step = step or plant.step(state, reduction.share(u, c.mass), ts)
        state = step.state
        works += [step.traction_work, step.dynamic_brake_work, step.wagon_brake_work]
        losses += step.losses
        head = head_position(plant, state)
        values = getattr(controller, "values", None) or {}
        rows.append((state.time, head, np.dot(c.mass, state.speeds) / c.mass.sum(), reference.speed(head),
                     step.largest_coupler_force, step.coupler_forces, u, seconds, step.speed_excess,
                     -low[locos], [values.get(t, np.nan) for t in TERMS], step.adhesion, holding))
        estimate = None if observer is None else observer.x.copy()
        if repeats(holding, held_before, u, before, estimate, estimated):
            for_good = True
            break
        held_before, before, estimated = holding, u.copy(), estimate
        if finished(plant, reference, state):
            rolling_back = mean_speed(plant, state) <= -STANDING  # it does not stand
            stood = not rolling_back
            break
    columns = (np.array(v) for v in zip(*rows))
    return state, LoopRecord(*columns, *map(float, works), overruns, stood, tuple(map(float, losses)),
                             plant.stored_energy(state) - stored, rolling_back, end_forces(plant, reduction, state),
                             for_good, tuple(unproven))


def end_forces(plant, reduction, state):
    """(grade, curve and running resistance the train feels [N], its locomotives' utmost traction at
    their speeds [N], adhesion included when on): a train short of the stop whose utmost is the
    smaller cannot go on (a stall)."""
    return float(plant.resistance(state.positions, state.speeds).sum()), float(limits(plant, reduction, state)[1].sum())
