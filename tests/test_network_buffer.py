"""buffer_m in a network study: a strategy whose trains come closer than the buffer (without
overlapping) is flagged with its closest approach, and the strategies that keep the buffer keep it
(real solves: two metro trains 30 s apart on one segment, dt 1 s, buffer_m 150, which the
independent runs break by some 35 m)."""
import pytest

from ecostudy.core.types import Supply
from ecostudy.io.loaders import load_track, load_train
from ecostudy.network import fleet, strategies

from .conftest import TRACKS, TRAINS

BUFFER = 150.0
SLACK = 1e-3  # [m] what Ipopt may leave a separation row violated


def _fleet():
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    return fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 30.0], ["T1", "T2"], 1.0,
                      Supply(position=300.0), points=200, buffer=BUFFER)


def test_independent_runs_closer_than_the_buffer_are_flagged_with_the_closest_approach():
    """Each train alone ignores the other: T2's head comes within about 115 m of T1's tail, closer
    than buffer_m 150 m but no overlap; the result is flagged and says which trains, when, where."""
    out = strategies.run_strategies(_fleet(), ["independent"], progress=None)["independent"]
    gap = out["totals"]["min_separation_m"]
    assert 0.0 < gap < BUFFER - 10.0
    status = out["totals"]["status"]
    assert status.startswith("flagged") and "buffer_m 150 m" in status, status
    assert f"{gap:.1f} m" in status and "T2" in status and "T1" in status and " s" in status, status
    assert "overlap" not in status, status


@pytest.fixture(scope="module")
def buffered():
    return strategies.run_strategies(_fleet(), ["independent", "receptivity", "joint", "following"], progress=None)


@pytest.mark.slow
def test_the_rules_keep_the_buffer_and_never_return_the_independent_start_that_breaks_it(buffered):
    """The supervisor keeps its best round, the start included: the start (the independent runs)
    is cheaper here but breaks the buffer, so it is not a candidate."""
    rounds = buffered["receptivity"]["info"]["rounds_substation_kWh"]
    assert rounds[0] < min(rounds[1:])  # the independent start is the cheapest of the history
    totals = buffered["receptivity"]["totals"]
    assert totals["min_separation_m"] >= BUFFER - SLACK and totals["status"] == "ok", totals
    assert totals["substation_kWh"] == pytest.approx(min(rounds[1:]), rel=1e-9)


@pytest.mark.slow
def test_the_joint_optimum_keeps_the_buffer_and_bounds_the_strategies_that_keep_it(buffered):
    joint = buffered["joint"]["totals"]
    assert joint["min_separation_m"] >= BUFFER - SLACK and joint["status"] == "ok", joint
    for name in ("receptivity", "following"):
        assert buffered[name]["totals"]["status"] == "ok", (name, buffered[name]["totals"]["status"])
        assert joint["substation_kWh"] <= buffered[name]["totals"]["substation_kWh"] * (1 + 1e-4), name
