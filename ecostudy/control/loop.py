"""The closed loop: a controller sampled every ``sample_time`` drives a plant stepped finely.

Each cycle the sensors read the plant's state (with measurement noise, ``core.plant.Noise``), a
mass estimator (optional) takes the accelerometer's reading of the last cycle's mean acceleration,
the controller plans a handle, and the plant runs for ``sample_time`` in steps of ``plant_step``
with the acceleration disturbance drawn per step (or held for ``noise.period``). The trip ends
when the train has moved and stands. A controller with an ``observe(pieces, before, after)``
method is told each sample what ran: the pieces [(duration [s], handle)] applied and the measured
states at the sample's start and end (the terminal approach's braking fit, ``control.brakefit``).

The computation delay (``delay``): solving takes time, so the control planned from the state
measured at sample k cannot act at k.

- ``0``: it acts at k, as if solving took no time;
- ``d`` samples (1: the default of a study): it acts from k + d, and the controller plans from
  the state predicted for k + d (the controller's own model of the train, with the estimated mass
  when it has an estimator, run from the measured state under the controls already planned,
  which hold meanwhile). Deterministic and repeatable;
- ``"measured"``: it acts when its solve time has elapsed (the held control until then; a solve
  longer than a sample holds it over the next samples, which then plan nothing), planned from the
  state predicted that far ahead by the previous solve's time. Not repeatable: for studies of the
  real-time budget.
"""
from typing import NamedTuple

import numpy as np

from ecostudy.core.errors import EcostudyError
from ecostudy.core.plant import Noise, Plant, Truth
from ecostudy.core.types import State
from ecostudy.core.units import to_kmh

MEASURED = "measured"
HANDLE_TOLERANCE = 1e-6  # a handle this far outside [-1, 1] is a solver's rounding, not a controller's error


def planned_handle(controller, state):
    """``controller.plan(state)`` as a number in [-1, 1]; anything else (2: twice the traction
    envelope, a percentage, None, NaN) is refused naming the controller and where it was planned,
    so that the plant never drives a force its envelopes do not give."""
    u = controller.plan(state)
    try:
        handle = float(u)
    except (TypeError, ValueError):
        handle = float("nan")
    if not abs(handle) <= 1.0 + HANDLE_TOLERANCE:  # NaN too
        at = round(state.position, 1) + 0.0  # never "-0.0 m" for a measured stand
        shown = f"{handle:g}" if handle == handle else repr(u)  # 2, not np.float64(2.0)
        raise EcostudyError(f"{type(controller).__name__}.plan gave the handle {shown} at {at:.1f} m, "
                            f"{state.speed:.2f} m/s, clock {state.time:.1f} s: a handle is a number in [-1, 1]")
    return min(max(handle, -1.0), 1.0)  # a solver's rounding past the bound, within the tolerance


class LoopResult(NamedTuple):
    """A closed-loop trip: the true states at every sample, the handles applied, the work at the
    wheel [J], the solve time of every cycle [s], the summary numbers, per sample the measured
    state (``readings``), and for a train with an adhesion limit the largest share of the true
    train's limit asked (``core.plant.adhesion_use`` at every plant step's start and at every piece end
    within it, ``core.plant.Step.adhesion``: the force jumps at a gradient edge the step crosses)."""

    states: list
    handles: list
    traction_work: float
    braking_work: float
    solve_seconds: list
    stop_error_m: float
    arrival_time_s: float
    overspeed_max_kmh: float
    mass_estimates: list
    readings: list = []
    adhesion_use_max: float | None = None


def check_delay(delay):
    """``delay`` if it is a number of samples >= 0 or ``"measured"``; ValueError otherwise."""
    if delay == MEASURED or (isinstance(delay, (int, np.integer)) and not isinstance(delay, bool) and delay >= 0):
        return delay
    raise ValueError(f"the computation delay is a number of samples >= 0 or 'measured', not {delay!r}")


def check_times(sample_time, plant_step):
    """ValueError unless ``sample_time`` and ``plant_step`` [s] are finite and positive: a sample of
    0 s never advances the clock (the loop would not end), a plant step of 0 s divides by zero. A sample
    shorter than the plant step is one step of the sample."""
    for name, value in (("sample time", sample_time), ("plant step", plant_step)):
        if not (isinstance(value, (int, float, np.integer, np.floating)) and np.isfinite(value) and value > 0):
            raise ValueError(f"the {name} is a number of seconds > 0, not {value!r}")


def predict(model, state, pieces):
    """The state ``model`` (a Plant: the controller's train) reaches from ``state`` under ``pieces``
    [(duration [s], handle)], without disturbance."""
    for duration, handle in pieces:
        if duration > 0.0:
            state = model.step(state, handle, duration).state
    return state


class _Trip:
    """The plant side of the loop: the true state, the work and the overspeed, the noise draws."""

    def __init__(self, plant, noise, plant_step):
        self.plant, self.noise, self.plant_step, self.rng = plant, noise, plant_step, noise.generator()
        self.state, self.work_t, self.work_b, self.over = State(), 0.0, 0.0, 0.0
        self.moved, self.arrival, self.drawn = False, None, (None, 0.0)
        self.grip = None if plant.truth.adhesion(plant.train) is None else 0.0  # the largest adhesion use

    @property
    def stood(self):
        return self.moved and self.state.speed <= 0.0

    def run(self, pieces):
        """Run the plant under ``pieces`` [(duration [s], handle)], in steps of at most plant_step."""
        for duration, u in pieces:
            steps = max(int(round(duration / self.plant_step)), 1) if duration > 0.0 else 0
            for _ in range(steps):
                slot = int(self.state.time // self.noise.period) if self.noise.period else None
                if slot is None or slot != self.drawn[0]:  # a new draw each step, or each noise period
                    self.drawn = (slot, self.noise.disturbance(self.rng))
                step = self.plant.step(self.state, u, duration / steps, self.drawn[1])
                self.state = step.state
                if self.grip is not None:  # at the step's start and every piece end: each edge it crossed
                    self.grip = max(self.grip, step.adhesion or 0.0)
                self.work_t += step.traction_work
                self.work_b += step.braking_work
                self.over = max(self.over, step.overspeed)  # at every limit edge the step crossed, and its end
                self.moved = self.moved or self.state.speed > 0.5
                if self.stood:
                    self.arrival = step.stood if step.stood is not None else self.state.time  # not the step's end
                    return


def run_loop(plant, controller, sample_time, noise=Noise(), plant_step=0.01, max_time=None, estimator=None, delay=0,
             until=None):
    """Drive ``plant`` with ``controller`` (``plan(measured state) -> handle``) to a stand, the
    control acting ``delay`` after its measurement (the module docstring); ``until`` [m]: stop the
    trip at the first sample at or past this position instead (a partial trip: for studies of the
    estimator's convergence)."""
    delay = check_delay(delay)
    check_times(sample_time, plant_step)
    segment, model = plant.segment, plant.train
    nominal = Plant(segment, model)  # the controller's model of the train: estimator and prediction
    trip = _Trip(plant, noise, plant_step)
    states, handles, readings = [State()], [], []
    max_time = max_time or 20 * segment.distance + 600
    last, held, acted = None, 0.0, None
    observe = getattr(controller, "observe", None)
    planned = [0.0] * (delay if delay != MEASURED else 0)  # controls planned, not acting yet
    busy_until, pending, lag = -np.inf, None, 0.0  # "measured": the solve under way and its result
    while trip.state.time < max_time:
        state = trip.state
        measured = noise.measure(state, trip.rng)
        readings.append(measured)
        if estimator is not None and last is not None and max(last[3].speed, state.speed) > 0.0:
            # what the model says the handle did (a train that stood throughout tells nothing)
            u, _, measured0, before = last
            reading = noise.read_acceleration((state.speed - before.speed) / (state.time - before.time), trip.rng)
            estimator.observe(nominal, u, measured0, measured, reading)
        if observe is not None and acted is not None:
            observe(acted, last[2], measured)
        # the controller's model for the prediction: with the mass it estimates, if it does
        ahead_model = nominal if estimator is None else Plant(segment, model, Truth(mass=estimator.estimate))
        if delay == MEASURED:
            pieces = _measured_cycle(controller, ahead_model, measured, sample_time, held, lag, busy_until, pending)
            pieces, held, lag, busy_until, pending = pieces
        elif delay:
            ahead = predict(ahead_model, measured, [(sample_time, u) for u in planned])
            planned.append(planned_handle(controller, ahead))
            held = planned.pop(0)
            pieces = [(sample_time, held)]
        else:
            held = planned_handle(controller, measured)
            pieces = [(sample_time, held)]
        handles.append(pieces[0][1])
        last, acted = (pieces[0][1], max(measured.speed, 0.0), measured, state), list(pieces)
        trip.run(pieces)
        states.append(trip.state)
        if trip.stood or (until is not None and trip.state.position >= until):
            break
    estimates = list(estimator.history) if estimator is not None else []
    state = trip.state
    return LoopResult(states, handles, trip.work_t, trip.work_b, list(controller.solve_seconds),
                      state.position - segment.distance, trip.arrival if trip.arrival is not None else state.time,
                      to_kmh(max(trip.over, 0.0)), estimates, readings, trip.grip)


def _measured_cycle(controller, nominal, measured, sample_time, held, lag, busy_until, pending):
    """One sample of the measured computation delay: (the pieces the plant runs, the control held
    at the sample's end, the last solve time, when the solve under way ends, its control)."""
    t = measured.time
    if pending is None and busy_until <= t + 1e-9:  # free: start a solve from the state predicted by the last lag
        ahead = predict(nominal, measured, [(lag, held)])
        u = planned_handle(controller, ahead)
        lag = float(controller.solve_seconds[-1]) if controller.solve_seconds else 0.0
        busy_until, pending = t + lag, u
    if pending is not None and busy_until < t + sample_time:  # it acts within this sample
        switch = max(busy_until - t, 0.0)
        pieces = [(switch, held), (sample_time - switch, pending)] if switch > 0.0 else [(sample_time, pending)]
        return pieces, pending, lag, busy_until, None
    return [(sample_time, held)], held, lag, busy_until, pending
