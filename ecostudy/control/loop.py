"""The closed loop: a controller sampled every ``sample_time`` drives a plant stepped finely.

Each cycle the sensors read the plant's state (with measurement noise, ``core.plant.Noise``), a
mass estimator (optional) takes the accelerometer's reading of the last cycle's mean acceleration, the controller plans a
handle, and the plant runs that handle for ``sample_time`` in steps of ``plant_step`` with the
acceleration disturbance drawn per step (or held for ``noise.period``). The trip ends when the train has moved and stands.
"""
from typing import NamedTuple

import numpy as np

from ecostudy.core.physics import davis_resistance
from ecostudy.core.plant import Noise, Plant
from ecostudy.core.types import State
from ecostudy.core.units import to_kmh


class LoopResult(NamedTuple):
    """A closed-loop trip: the true states at every sample, the handles applied, the work at the
    wheel [J], the solve time of every cycle [s], and the summary numbers."""

    states: list
    handles: list
    traction_work: float
    braking_work: float
    solve_seconds: list
    stop_error_m: float
    arrival_time_s: float
    max_overspeed_kmh: float
    mass_estimates: list


def run_loop(plant, controller, sample_time, noise=Noise(), plant_step=0.01, max_time=None, estimator=None):
    """Drive ``plant`` with ``controller`` (``plan(measured state) -> handle``) to a stand."""
    segment, model = plant.segment, plant.train
    nominal = Plant(segment, model)  # the controller's model of the train, for the estimator
    rng = noise.generator()
    state, states, handles = State(), [State()], []
    work_t = work_b = 0.0
    max_time = max_time or 20 * segment.distance + 600
    moved, last, over, drawn, arrival = False, None, 0.0, (None, 0.0), None
    substeps = max(int(round(sample_time / plant_step)), 1)
    while state.time < max_time:
        measured = noise.measure(state, rng)
        if estimator is not None and last is not None and max(last[3].speed, state.speed) > 0.0:
            # what the model says the handle did (a train that stood throughout tells nothing)
            u, v0, measured0, before = last
            net = 0.0
            for v in (v0, max(measured.speed, 0.0)):  # the cycle's mean: trapezoid over its ends
                davis = davis_resistance(v, *model.davis)
                ft, fb = nominal.forces(v, u, davis)
                net += 0.5 * (ft - fb - davis) / model.mass
            grade = nominal.grade_force(measured0.position) / model.mass
            reading = noise.read_acceleration((state.speed - before.speed) / (state.time - before.time), rng)
            estimator.update(reading, grade, net, measured0.position)
        u = float(controller.plan(measured))
        handles.append(u)
        last = (u, max(measured.speed, 0.0), measured, state)
        for _ in range(substeps):
            slot = int(state.time // noise.period) if noise.period else None
            if slot is None or slot != drawn[0]:  # a new draw each step, or each noise period
                drawn = (slot, noise.disturbance(rng))
            step = plant.step(state, u, plant_step, drawn[1])
            state = step.state
            work_t += step.traction_work
            work_b += step.braking_work
            limit = float(segment.limit(np.clip(state.position, 0.0, segment.distance)))
            over = max(over, state.speed - limit)
            moved = moved or state.speed > 0.5
            if moved and state.speed <= 0.0:
                arrival = step.stood if step.stood is not None else state.time  # not the step's end
                break
        states.append(state)
        if moved and state.speed <= 0.0:
            break
    estimates = list(estimator.history) if estimator is not None else []
    return LoopResult(states, handles, work_t, work_b, list(controller.solve_seconds),
                      state.position - segment.distance,
                      arrival if arrival is not None else state.time, to_kmh(max(over, 0.0)), estimates)
