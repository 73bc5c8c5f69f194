"""The mass estimators on Yazhemsky 2017's Ch. 10 trip ("A real-time capable adaptive optimal
controller for a commuter train", §10.3, Figs. 10.8-10.9): a train 20 % heavier than the model,
the §10.1 noise (sigma_a = 0.05 m/s^2 held 1 s, sigma_V = 0.01 m/s, sigma_X = 0.01 m, sigma_A =
0.01 m/s^2, read as standard deviations), the convex controller (SOCP 6.10, weights 1 / 0.1) at
10 Hz on the representative 5 km track, the control acting one sample after its measurement.
One trip per noise seed; the estimate's error where the train passes given positions
(``bench/bench_estimator.py``, ``tests/test_estimator.py``)."""
from typing import NamedTuple

from ecostudy.control.controllers import Convex
from ecostudy.control.estimators import make_estimator
from ecostudy.control.loop import run_loop
from ecostudy.core.grid import make_segment
from ecostudy.core.plant import Noise, Plant, Truth
from ecostudy.io.loaders import load_track, load_train
from ecostudy.ocp.convex import ConvexProgram, ConvexWeights, trapezoid_grid

SAMPLE_TIME = 0.1
LATEST = 360.0  # T_max of the representative track (docs/closed_loop.md, Ch. 10 trends)


def ch10_noise(seed):
    """Yazhemsky 2017 §10.3's sensor and disturbance noise with a seed."""
    return Noise(acceleration=0.05, position=0.01, speed=0.01, seed=seed, period=1.0, accelerometer=0.01)


class EstimatorTrip(NamedTuple):
    """A trip's relative errors of the mass estimate (estimate / true - 1) at the marks [m], the
    final position [m] and stop error [m] (None when stopped early by ``until``)."""

    seed: int
    errors: dict
    position: float
    stop_error_m: object


def estimate_at(history, mark):
    """The estimate in use when the train reached ``mark`` [m]: after the last cycle that started
    before it (``history``: the estimator's (position, estimate) per cycle)."""
    before = [e for x, e in history if x is not None and x < mark]
    return before[-1] if before else 1.0


def estimator_trip(root, seed, choice="state", points=300, marks=(2000.0, 5000.0), until=None, mass=1.2, delay=1):
    """One Ch. 10 trip (``root``: the project folder with tracks/ and trains/) with estimator
    ``choice`` (``control.estimators``); ``until`` [m]: stop there (the marks beyond are not reached)."""
    train = load_train(root / "trains" / "yazhemsky2017_commuter.yaml")
    segment = make_segment(load_track(root / "tracks" / "yazhemsky2017_5km_representative.yaml"), train, "A", "B")
    noise = ch10_noise(seed)
    estimator = make_estimator(choice, noise)
    controller = Convex(ConvexProgram(segment, train, trapezoid_grid(segment, points), ConvexWeights(time=1.0, energy=0.1)),
                        (0.0, LATEST), estimator=estimator, hold=SAMPLE_TIME)
    result = run_loop(Plant(segment, train, Truth(mass=mass)), controller, SAMPLE_TIME, noise, plant_step=SAMPLE_TIME,
                      estimator=estimator, delay=delay, until=until)
    end = result.states[-1].position
    errors = {m: float(estimate_at(estimator.history, m) / mass - 1.0) for m in marks if until is None or m <= end}
    return EstimatorTrip(seed, errors, float(end), None if until is not None else float(result.stop_error_m))
