"""A re-planner from a notebook: the same call gives the same plan whatever came before (a mass
scale and an arrival stuck from earlier calls, `ok` over other numbers), and an argument no plan
answers is one line naming it (a negative mass gave an `ok` plan; a clock past the arrival ran
Ipopt for minutes; a float end speed was a TypeError). Real solves."""
import pytest

from ecostudy import api
from ecostudy.core.errors import InputError

from .conftest import TRACKS, TRAINS

S = api.State(400.0, 15.0, 30.0)


@pytest.fixture(scope="module")
def planner():
    return api.replanner(api.load_track(TRACKS / "amsterdam_rokin_centraal.yaml"),
                         api.load_train(TRAINS / "amsterdam_metro.yaml"), running_time=80.0, points=100)


def test_the_same_call_gives_the_same_plan(planner):
    first = planner.solve(S)
    heavier = planner.solve(S, mass_scale=1.2)
    later = planner.solve(S, arrival=100.0)
    again = planner.solve(S)
    assert first.status.ok and again.status.ok
    assert again.dt.sum() == pytest.approx(first.dt.sum(), abs=1e-6)  # the constructor's 80 s, not 100
    assert again.start_time + again.dt.sum() == pytest.approx(80.0, abs=1e-6)
    work = [float((p.ft * (p.nodes[1:] - p.nodes[:-1])).sum()) for p in (first, heavier, later, again)]
    assert work[3] == pytest.approx(work[0], rel=1e-6) and work[1] > work[0] > work[2], work


@pytest.mark.parametrize("call, words", [
    (dict(mass_scale=-1), "arguments: mass_scale: the train's mass over the model's, a number above 0"),
    (dict(arrival="90"), "arguments: arrival: a time or an (earliest, latest) pair"),
    (dict(end_speed=0.0), "arguments: end_speed: a (lowest, highest) pair of speeds"),
    (dict(state=(1.0, 2.0, 3.0)), "arguments: state: a State(position, speed, time)"),
    (dict(state=api.State(400.0, float("nan"), 30.0)), "arguments: state: finite numbers"),
    (dict(state=api.State(400.0, 15.0, 120.0)), "arguments: arrival: the latest arrival 80 s is not after the state's clock"),
])
def test_an_argument_no_plan_answers_is_named(planner, call, words):
    state = call.pop("state", S)
    with pytest.raises(InputError, match=words.replace("(", r"\(").replace(")", r"\)")):
        planner.solve(state, **call)
