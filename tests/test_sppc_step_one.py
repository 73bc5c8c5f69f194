"""SPPC's step one (Farooqi 2018 Alg. 4, eq. 5.22) skipped where a closed-form reckoning knows its
answer: the earliest stand on the mark (``control.reach``) against the step one NLP, and the plan
of a sample with the step skipped against the plan of the same sample with it solved."""
import numpy as np
import pytest

from ecostudy.analysis.single import solve_run
from ecostudy.control.sppc import STEP_ONE_MARGIN, Sppc
from ecostudy.core.types import State, Timing
from ecostudy.ocp import phases

ARRIVAL = 76.0


@pytest.fixture(scope="module")
def ato(metro, amsterdam):
    return solve_run(amsterdam, metro, "Rokin", "Centraal", Timing(running_time=ARRIVAL), points=300)


def test_the_earliest_stand_in_closed_form_is_the_step_one_nlp_s_arrival(ato):
    """Where a stop is reachable, step one's answer is gamma = 0 and its earliest arrival: the
    closed form gives that arrival within a few hundredths of a second (the margin is 0.1 s)."""
    controller = Sppc(ato, ARRIVAL, points=150, variant="two_step")
    for state in (State(), State(300.0, 19.0, 25.0), State(900.0, 18.0, 57.0)):
        gamma, arrival = controller._closest(state)
        earliest = state.time + controller.reach(state.position, state.speed)
        assert gamma < 1e-6
        assert abs(arrival - earliest) < 0.5 * STEP_ONE_MARGIN


def test_a_train_above_the_stopping_curve_has_no_earliest_stand(ato):
    controller = Sppc(ato, ARRIVAL, points=150, variant="two_step")
    state = State(1080.0, 14.0, 70.0)  # 14 m/s, 30 m before the mark: it cannot stand on it
    assert controller.reach(state.position, state.speed) == np.inf
    gamma, _ = controller._closest(state)
    assert gamma > 1.0


def test_a_sample_with_step_one_skipped_drives_the_plan_step_two_gives_after_it(ato):
    """The skip solves the NLP step two would be given (end speed within the tolerance, arrival by
    the timetable), from the same warm start: the same plan."""
    skipping, solving = (Sppc(ato, ARRIVAL, points=150, variant="two_step") for _ in range(2))
    for state in (State(), State(0.4, 0.6, 0.38)):
        assert skipping._relaxed(state, skip=True).usable and solving._relaxed(state).usable
        np.testing.assert_allclose(phases.solution(skipping.model, skipping.layout)[0],
                                   phases.solution(solving.model, solving.layout)[0], atol=1e-6)
    assert skipping.skipped == 2 and skipping.closest is None and solving.skipped == 0


def test_the_two_step_loop_skips_step_one_until_the_approach(ato):
    controller = Sppc(ato, ARRIVAL, points=150, variant="two_step")
    for k, x in enumerate((0.0, 100.0, 500.0)):
        run = ato.trajectory
        state = State(x, float(np.interp(x, run.nodes, run.v)), float(np.interp(x, run.nodes, run.time)))
        controller.plan(state)
        assert controller.skipped == k + 1
    controller.plan(State(1080.0, 14.0, 70.0))  # cannot stand on the mark: step one decides
    assert controller.skipped == 3 and controller.closest is not None and controller.failures == 0



def test_a_train_over_the_limit_on_a_downgrade_has_no_plan_and_no_nlp_is_solved(ato):
    """At 190-210 m the line falls (the grade pulls 32 kN) under a 50 km/h limit: a train read a few
    hundredths of a m/s over it cannot coast under it, and the phases NLP brakes only at a sector's
    end, so it has no plan (the step one NLP ends infeasible); the controller solves none."""
    probe, controller = (Sppc(ato, ARRIVAL, points=150, variant="two_step") for _ in range(2))
    limit = float(ato.segment.limit(200.0))
    assert controller.reach.coasting_over_limit(200.0, limit + 0.04)
    assert not controller.reach.coasting_over_limit(200.0, limit - 0.01)
    state = State(200.0, limit + 0.04, 20.5)
    assert probe._closest(state) is None  # the NLP: no plan
    controller.plan(state)
    assert controller.failures == 1 and controller.iterations == [] and controller.fallbacks["full_brake"] == 1
