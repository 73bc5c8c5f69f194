"""A re-plan from a state over the speed limit, or one that cannot brake down to a limit ahead in
time, follows what full braking reaches (ocp/restart.py set_start): over the limit. Such a plan is
flagged saying where and by how much, never ok (a plan from 144 km/h in an 80 km/h section was
`ok`); a plan within the limits stays ok. A state off the segment is refused naming ``state``.
Real solves, K = 100."""
import numpy as np
import pytest

from ecostudy import api

from .conftest import TRACKS, TRAINS


@pytest.fixture(scope="module")
def planner():
    return api.replanner(api.load_track(TRACKS / "amsterdam_rokin_centraal.yaml"),
                         api.load_train(TRAINS / "amsterdam_metro.yaml"), running_time=80.0, points=100)


def test_a_plan_from_over_the_limit_is_flagged_with_where_it_gets_back_under(planner):
    plan = planner.solve(api.State(position=400.0, speed=40.0, time=30.0))  # 144 km/h where 80 km/h holds
    assert plan.outcome.optimal and not plan.ok and plan.status.kind == "flagged"
    nodes, kmh, limit = plan.nodes, plan.v * 3.6, plan.limits * 3.6
    ahead = np.flatnonzero(nodes > 400.0)
    back = ahead[np.argmax(kmh[ahead] <= limit[ahead] + 0.5)]  # the first node ahead under its limit again
    assert plan.reason.startswith(f"starts 64.0 km/h over the 80 km/h limit at 400 m; braking back under it by "
                                  f"{nodes[back]:.0f} m"), plan.reason
    assert repr(plan).endswith(f"; flagged: {plan.reason})")


def test_a_plan_that_cannot_brake_down_to_a_limit_ahead_is_flagged(planner):
    plan = planner.solve(api.State(position=900.0, speed=22.0, time=60.0))  # 79.2 km/h, 50 m before 60 km/h
    assert plan.outcome.optimal and plan.status.kind == "flagged"
    over = np.where(plan.nodes > 900.0, plan.v - plan.limits, -np.inf) * 3.6  # the nodes behind hold the start
    worst = int(np.argmax(over))
    assert over[worst] > 0.5 and plan.reason.startswith(f"{over[worst]:.1f} km/h over the 60 km/h limit at 950-"), \
        plan.reason


def test_a_plan_within_the_limits_stays_ok(planner):
    plan = planner.solve(api.State(position=400.0, speed=15.0, time=30.0))
    ahead = plan.nodes > 400.0
    assert plan.ok and plan.reason == "" and np.all(plan.v[ahead] <= plan.limits[ahead] + 1e-6)


def test_a_state_off_the_segment_names_the_state(planner):
    with pytest.raises(api.InputError, match=r"^arguments: state: the position 2000\.0 m is not on the segment "
                                             r"\[0, 1106\.0\) m$"):
        planner.solve(api.State(position=2000.0, speed=1.0, time=1.0))
