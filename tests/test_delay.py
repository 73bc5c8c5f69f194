"""The measured computation delay (``compute_delay: measured``, control/loop.py): a control acts
when its solve time has elapsed, the previous control holding until then, and the samples during a
solve plan nothing. Driven by a controller that takes a declared time per plan (an embedded
controller with a fixed cycle), so the schedule is deterministic here; with a real solver it is
the solve's own time and not repeatable."""
import pytest

from ecostudy.control.loop import run_loop
from ecostudy.core.plant import Plant

from .test_convex import advanced, commuter  # noqa: F401 (fixtures: the thesis train on the advanced trip)


class FixedCycle:
    """Full traction to 10 m/s, then coasting; every plan takes ``seconds`` of computing."""

    def __init__(self, seconds):
        self.seconds, self.solve_seconds, self.asked = seconds, [], []

    def plan(self, state):
        self.asked.append(state)
        self.solve_seconds.append(self.seconds)
        return 1.0 if state.speed < 10.0 else 0.0


def test_a_control_acts_when_its_solve_time_has_elapsed(commuter, advanced):
    _, segment = advanced
    controller = FixedCycle(0.25)
    result = run_loop(Plant(segment, commuter), controller, 0.1, plant_step=0.01, max_time=3.0, delay="measured")
    # solves start at 0, 0.3, 0.6, ... (a 0.25 s solve keeps the next two samples busy)
    assert len(controller.asked) == pytest.approx(len(result.handles) / 3, abs=1)
    # the first solve planned from the state predicted for its own end (nothing was planned before: 0)
    assert controller.asked[0].time == pytest.approx(0.0)
    assert controller.asked[1].time == pytest.approx(0.3 + 0.25)
    # nothing acts before 0.25 s: the train stands through the first two samples and moves in the third
    speeds = {round(s.time, 6): s.speed for s in result.states}
    assert speeds[0.1] == 0.0 and speeds[0.2] == 0.0 and speeds[0.3] > 0.0
    assert result.handles[:3] == [0.0, 0.0, 0.0]  # a sample's first piece: the control held at its start
    assert result.handles[3] == 1.0  # from 0.3 s the traction planned at 0 acts from the sample's start


def test_samples_and_measured_delay_differ_as_their_schedules_say(commuter, advanced):
    _, segment = advanced
    fast = run_loop(Plant(segment, commuter), FixedCycle(0.05), 0.1, plant_step=0.01, max_time=3.0, delay="measured")
    one = run_loop(Plant(segment, commuter), FixedCycle(0.05), 0.1, plant_step=0.01, max_time=3.0, delay=1)
    # a 0.05 s solve acts half a sample after its measurement, one sample of delay a whole sample after
    assert fast.states[1].speed > 0.0 and one.states[1].speed == 0.0
    assert fast.states[2].speed > one.states[2].speed > 0.0
