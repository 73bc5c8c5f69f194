"""Clarabel proves the convex controller's plans optimal (status ``Solved``, its 1e-8 tolerances)
on the shipped closed-loop study's program: ``studies/yazhemsky2017_closed_loop.yaml``'s track, train,
K = 500 and both weight sets, from the stand and the next samples of a train pulling away. With the
force-limit rows in newtons (coefficients up to 1e6 against 1 elsewhere) the dual residual stalled
above 1e-8 and 10 of these 24 plans ended ``AlmostSolved``."""
import numpy as np
import pytest

from ecostudy.core.grid import make_segment
from ecostudy.core.types import State
from ecostudy.io.loaders import load_track, load_train
from ecostudy.ocp.convex import EXACT, ConvexProgram, ConvexWeights, trapezoid_grid

from .conftest import TRACKS, TRAINS


@pytest.mark.parametrize("time_weight", [1.0, 10.0])
def test_the_plans_of_a_train_pulling_away_end_solved(time_weight):
    train = load_train(TRAINS / "yazhemsky2017_commuter.yaml")
    segment = make_segment(load_track(TRACKS / "yazhemsky2017_advanced_1km.yaml"), train, "A", "B")
    program = ConvexProgram(segment, train, trapezoid_grid(segment, 500), ConvexWeights(time=time_weight, energy=1.0))
    ends, x, v = [], 0.0, 0.0
    for k in range(12):  # 0.99 m/s^2 from the stand, sampled at 10 Hz
        plan = program.solve(State(position=x, speed=v, time=0.1 * k), (0.0, 200.0), hold=0.1)
        ends.append((plan.status, plan.gap))
        x, v = x + 0.1 * v + 0.5 * 0.99 * 0.01, v + 0.099
    assert all(status == "Solved" for status, _ in ends), ends
    assert max(gap for _, gap in ends) <= EXACT, ends


def test_the_assembled_rows_are_scaled_by_physics():
    """Every coefficient of the program is within 1e3 of 1 (accelerations, speeds, clocks, inverse
    speeds; no row in newtons)."""
    train = load_train(TRAINS / "yazhemsky2017_commuter.yaml")
    segment = make_segment(load_track(TRACKS / "yazhemsky2017_advanced_1km.yaml"), train, "A", "B")
    program = ConvexProgram(segment, train, trapezoid_grid(segment, 500), ConvexWeights(time=10.0, energy=1.0))
    A, b, q, _, _ = program.assemble(program.grid_from(0.0), State(), (0.0, 200.0), 0.0, 1.0, None)
    entries = np.abs(A.data[A.data != 0.0])
    assert entries.max() <= 1e3 and entries.min() >= 1e-3, (entries.min(), entries.max())
