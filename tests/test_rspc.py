"""RSPC (Farooqi 2018 Ch. 6): the six DAS modes enumerated over a short receding horizon, with the
braking-distance trigger and adaptive sampling of Alg. 6, driving real plants."""
import numpy as np
import pytest

from ecostudy.control.loop import run_loop
from ecostudy.control.rspc import Rspc
from ecostudy.core.plant import Plant, Truth
from ecostudy.core.types import State
from ecostudy.heuristics.ecodrive import drive, eco_coasting
from ecostudy.io.loaders import load_track, load_train
from ecostudy.ocp.problem import prepare
from tests.conftest import ROOT

TS = 0.38
MODES = {"traction 1", "traction 0.75", "traction 0.5", "cruise", "coast", "brake"}


@pytest.fixture(scope="module")
def case(metro, amsterdam):
    return prepare(amsterdam, metro, "Rokin", "Centraal", 400)


def test_prediction_steps_end_at_sector_boundaries_and_the_first_is_one_sample(case):
    """Alg. 6 rows 1-2: steps of D, shortened where a sector (gradient, curve or limit) ends; the
    first is the distance run in one loop sample."""
    c = Rspc(case, 76.0, TS, horizon=4, distance=25.0)
    edge = float(case.segment.breakpoints()[0])
    starts, lengths, held = c.steps(edge - 30.0, 10.0)
    assert lengths[0] == pytest.approx(10.0 * TS) and held == 1
    ends = np.add(starts, lengths)
    assert edge in ends  # one step ends exactly on the boundary
    assert all(not (s < edge < e) for s, e in zip(starts, ends))  # none straddles it
    assert max(lengths) <= 25.0 + 1e-9
    starts, lengths, held = c.steps(edge - 2.0, 10.0)  # the sample's run crosses the boundary
    assert held == 2 and lengths[:2] == pytest.approx([2.0, 10.0 * TS - 2.0]) and starts[1] == pytest.approx(edge)
    last = c.steps(case.segment.distance - 10.0, 5.0)
    assert last[0][-1] + last[1][-1] == pytest.approx(case.segment.distance)  # the horizon ends at the stop


def test_the_braking_trigger_fires_where_the_braking_distance_reaches_the_stop(case):
    """Eqs. 6.15-6.16: delta D = D_p - D_b <= 0 brakes; well before it the RSPC does not."""
    c = Rspc(case, 76.0, TS)
    x_stop = case.segment.distance
    assert not c.must_brake(x_stop - 300.0, 16.0)
    assert c.must_brake(x_stop - 60.0, 16.0)
    assert c.plan(State(x_stop - 60.0, 16.0, 60.0)) == -1.0 and c.braking
    assert Rspc(case, 76.0, TS).plan(State(0.0, 0.0, 0.0)) in (1.0, 0.75, 0.5)  # from the stand: traction


def test_no_admissible_sequence_brakes(case):
    """A train above a limit's braking curve (and not yet at the stop's) has no sequence in X
    (6.9e): the controller brakes and counts it."""
    c = Rspc(case, 76.0, TS)
    drop = next(x for x in case.segment.breakpoints()
                if case.segment.limit(x) < case.segment.limit(x - 1e-6))  # a limit that falls
    states = [(x, float(np.sqrt(np.interp(x, case.nodes, c.cap_sq))) + 0.3) for x in np.arange(drop - 60.0, drop, 1.0)]
    x, v = next((x, v) for x, v in states if not c.must_brake(x, v))
    assert c.best(x, v, 50.0) is None
    assert c.plan(State(x, v, 50.0)) == -1.0 and c.failures == 1 and not c.braking


@pytest.mark.parametrize("where", ["amsterdam", pytest.param("regional", marks=pytest.mark.slow)])
def test_the_loop_applies_only_das_modes_arrives_on_time_and_costs_between_coasting_and_all_out(where, metro,
                                                                                                 amsterdam):
    """Only allowed modes are applied; arrival on time or early; energy between the
    coasting-only industrial strategy (Farooqi 2018 Table 6.1's 'eco-drive coasting') and all-out;
    stops on the mark. Both the model train and the corners of +-10 % parameters."""
    if where == "amsterdam":
        case, arrival = prepare(amsterdam, metro, "Rokin", "Centraal", 400), 76.0
    else:
        track, train = load_track(ROOT / "tracks/regional_808m.yaml"), load_train(ROOT / "trains/regional_alstom.yaml")
        case, arrival = prepare(track, train, "Origin", "Destination", 400), 80.0
    coasting = eco_coasting(case, arrival).trace.traction_energy
    all_out = drive(case, case.envelope)[1].traction_energy
    for truth in (Truth(), Truth(1.1, 0.9, 0.9, 0.9), Truth(0.9, 1.1, 1.1, 1.1)):
        c = Rspc(case, arrival, TS)
        result = run_loop(Plant(case.segment, case.train, truth), c, TS, plant_step=TS)
        assert set(c.chosen) <= MODES and len(set(c.chosen)) >= 4
        levels = set(case.train.das_levels)
        assert all(u in levels for u, m in zip(result.handles, c.chosen) if m != "cruise")
        assert result.arrival_time_s <= arrival
        assert abs(result.stop_error_m) < 0.5
        assert result.overspeed_max_kmh < 0.5
        if truth == Truth():
            assert coasting < result.traction_work < all_out
            assert c.failures == 0
