"""Yazhemsky 2017's convex controller program (ocp/convex.py, eq. 6.10) solved by Clarabel: the
relaxation is exact, the plan drives the independent plant to the stop, its all-out time is the
Ipopt NLP's, the envelope pieces, the grid ahead, a leading train's clock, and bad study input."""
import numpy as np
import pytest

from ecostudy.analysis.single import solve_run
from ecostudy.control.controllers import Convex, ForceReplay, leader_clock
from ecostudy.control.loop import run_loop
from ecostudy.core.errors import InputError
from ecostudy.core.grid import make_segment
from ecostudy.core.physics import Envelope
from ecostudy.core.plant import Plant
from ecostudy.core.types import State, Timing
from ecostudy.io.loaders import load_track, load_train
from ecostudy.ocp.problem import prepare
from ecostudy.ocp.convex import FASTEST, ConvexProgram, ConvexWeights, envelope_pieces, trapezoid_grid
from ecostudy.studies.closedloop import expand

from .conftest import TRACKS, TRAINS



@pytest.fixture(scope="module")
def commuter():
    return load_train(TRAINS / "yazhemsky2017_commuter.yaml")


@pytest.fixture(scope="module")
def advanced(commuter):
    track = load_track(TRACKS / "yazhemsky2017_advanced_1km.yaml")
    return track, make_segment(track, commuter, "A", "B")


def _energy_per_kg(plan, train):
    return float(np.sum(np.maximum(plan.force, 0.0) * np.diff(plan.nodes)) / train.mass)


def _replayed(segment, train, scheme):
    program = ConvexProgram(segment, train, trapezoid_grid(segment, 500), ConvexWeights(), scheme=scheme)
    plan = program.solve(State(), (0.0, 200.0))
    driven = run_loop(Plant(segment, train), ForceReplay(train, plan.nodes, plan.force), 0.02, plant_step=0.02)
    return plan, driven


def test_the_relaxation_is_exact_and_the_plan_drives_the_plant_to_the_stop(commuter, advanced):
    """rho s = 1 to 1e-6 on every interval; the plan's forces replayed by position on the plant
    (DOP853, independent of the program's discretisation) stop near the stop on the plan's time.
    The printed forward-Euler form ("left", eq. 6.1k with s = v_i) is measurably coarser."""
    _, segment = advanced
    plan, driven = _replayed(segment, commuter, "midpoint")
    assert plan.usable and plan.gap <= 1e-6
    assert np.all(plan.v[1:-1] <= segment.limit(plan.nodes[1:-1]) + 1e-6)
    assert abs(driven.stop_error_m) < 1.0
    assert driven.arrival_time_s == pytest.approx(plan.t[-1], rel=0.01)
    assert driven.traction_work / commuter.mass == pytest.approx(_energy_per_kg(plan, commuter), rel=0.02)
    left, euler = _replayed(segment, commuter, "left")
    assert left.usable and left.gap <= 1e-6
    assert abs(euler.stop_error_m) > 2 * abs(driven.stop_error_m)


def test_the_socp_all_out_time_is_the_kinematic_envelope_time(commuter, advanced):
    """Two computations of the fastest run (the SOCP by Clarabel, the forward-backward envelope of
    ``core.kinematics`` on the NLP's grid) agree to 0.5 %."""
    track, segment = advanced
    plan = ConvexProgram(segment, commuter, trapezoid_grid(segment, 1000), FASTEST, margin=0.0).solve(State())
    assert plan.gap <= 1e-6
    assert plan.t[-1] == pytest.approx(prepare(track, commuter, "A", "B", 1000).estimate, rel=0.005)


@pytest.mark.slow
def test_the_socp_all_out_time_is_the_ipopt_nlp_all_out_time(commuter, advanced):
    """Two formulations, two solvers, one physics: the fastest runs agree to 0.5 %. (The NLP's
    all-out solve of this train takes about 200 iterations at K = 500, the SOCP one 0.1 s.)"""
    track, segment = advanced
    plan = ConvexProgram(segment, commuter, trapezoid_grid(segment, 500), FASTEST, margin=0.0).solve(State())
    nlp = solve_run(track, commuter, "A", "B", Timing(), objective="time", points=500)
    assert plan.gap <= 1e-6
    assert plan.t[-1] == pytest.approx(nlp.summary["running_time_s"], rel=0.005)


def test_a_later_arrival_costs_less_and_the_window_binds(commuter, advanced):
    _, segment = advanced
    program = ConvexProgram(segment, commuter, trapezoid_grid(segment, 300), ConvexWeights(time=10.0, energy=1.0))
    free = program.solve(State(), (0.0, 200.0))
    late = program.solve(State(), (90.0, 200.0))
    assert late.t[-1] == pytest.approx(90.0, abs=1e-4) and free.t[-1] < 85.0
    assert _energy_per_kg(late, commuter) < _energy_per_kg(free, commuter)


def _upper(pieces, v):
    return np.min([np.asarray(a) + np.asarray(b) * v + np.asarray(c) * v ** 2 for a, b, c in pieces], axis=0)


def test_the_thesis_envelope_is_its_two_pieces_and_convex_envelopes_are_touched_below():
    train = load_train(TRAINS / "yazhemsky2017_commuter.yaml")
    v = np.linspace(0.0, 23.0, 200)
    pieces = envelope_pieces(train.traction)(v)
    assert len(pieces) == 2  # F_max and the quadratic R(v) (eqs. 6.1h, 6.1j)
    assert np.max(np.abs(_upper(pieces, v) - train.traction.force(v))) <= 0.003 * train.traction.peak
    power = Envelope("force_power", max_force=300e3, max_power=3e6)
    table = Envelope("table", speeds=(0.0, 10.0, 20.0, 30.0), forces=(300e3, 300e3, 150e3, 100e3))
    v = np.linspace(0.5, 30.0, 300)
    for envelope in (power, table):
        for w in (12.0, 25.0):  # the reference speed of an interval
            upper = _upper(envelope_pieces(envelope)(np.full_like(v, w)), v)
            assert np.all(upper <= envelope.force(v) + 1e-6 * envelope.peak)
            assert _upper(envelope_pieces(envelope)(np.array([w])), np.array([w]))[0] == pytest.approx(
                float(envelope.force(np.array([w]))[0]), rel=1e-3)


def test_a_power_limited_train_plans_within_its_power(metro, amsterdam):
    """The Amsterdam metro (force and power limits): every planned traction force is at most
    P / v at the interval's speed, and the tangents are tight where the plan runs at full power."""
    segment = make_segment(amsterdam, metro, "Rokin", "Centraal")
    program = ConvexProgram(segment, metro, trapezoid_grid(segment, 200), FASTEST)
    for _ in range(3):  # each solve moves the tangents to the last plan's speeds
        plan = program.solve(State(), (0.0, 300.0))
    s = 0.5 * (plan.v[:-1] + plan.v[1:])
    top = metro.traction.force(s)
    assert plan.usable and np.all(plan.force <= top + 1e-3 * metro.traction.peak)
    assert np.max(plan.force / top) > 0.99


def test_the_grid_ahead_starts_with_the_held_sample_and_always_reaches_the_stop(commuter, advanced):
    _, segment = advanced
    program = ConvexProgram(segment, commuter, trapezoid_grid(segment, 100), ConvexWeights())
    x = program.grid_from(300.0, reach=1.5)
    assert x[0] == 300.0 and x[1] == pytest.approx(301.5) and x[-1] == segment.distance
    assert np.all(np.diff(x) > 0)
    near = program.grid_from(segment.distance - 1e-4, reach=1.0)
    assert len(near) == 2 and near[-1] >= segment.distance
    plan = program.solve(State(segment.distance - 0.3, 0.5, 80.0), hold=0.1)
    assert plan.usable and plan.v[-1] == pytest.approx(0.0, abs=1e-6) and plan.gap < 1e-6


def test_a_following_train_never_passes_the_leaders_clock(commuter, advanced):
    """Eq. 6.9: t_i >= T_lead(x_i + X_sep) at every node ahead."""
    _, segment = advanced
    program = ConvexProgram(segment, commuter, trapezoid_grid(segment, 300), ConvexWeights(time=10.0, energy=1.0))
    leader = program.solve(State(), (0.0, 200.0))
    slow = [State(x, 0.0, t + 15.0) for x, t in zip(leader.nodes, leader.t)]  # the same run, 15 s later
    lead = leader_clock(slow, 100.0)
    plan = program.solve(State(0.0, 0.0, 20.0), (0.0, 300.0), lead=lead)
    assert plan.usable
    assert np.all(plan.t[1:] >= lead(plan.nodes[1:]) - 1e-6)


def test_the_convex_controller_closes_the_loop_on_a_coarse_grid(commuter, advanced):
    _, segment = advanced
    program = ConvexProgram(segment, commuter, trapezoid_grid(segment, 120), ConvexWeights())
    controller = Convex(program, (0.0, 200.0), hold=0.5)
    result = run_loop(Plant(segment, commuter), controller, 0.5, plant_step=0.5)
    assert abs(result.stop_error_m) < 0.5 and result.overspeed_max_kmh == 0.0
    assert controller.failures == 0 and max(controller.gaps) < 1e-3


def _study(tmp_path, **changes):
    import yaml
    doc = {"name": "t", "track": str(TRACKS / "yazhemsky2017_flat_1km.yaml"), "train": str(TRAINS / "yazhemsky2017_commuter.yaml"),
           "window_s": [0, 200], "points": 60, "sample_time_s": 0.5,
           "controllers": [{"name": "c", "kind": "convex"}], **changes}
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_window_below_the_all_out_time_is_refused_by_name(tmp_path):
    with pytest.raises(InputError, match=r"window_s.*below the all-out time"):
        expand(_study(tmp_path, window_s=[0, 40]))
    with pytest.raises(InputError, match="sample_time_s"):
        expand(_study(tmp_path, sample_time_s=300))


def test_every_controller_meets_the_same_draws(tmp_path):
    _, _, cases = expand(_study(tmp_path, draws=3, seed=5, controllers=[{"name": "a", "kind": "convex"},
                                                                         {"name": "b", "kind": "open_loop"}],
                                deviations={"mass": {"low": 0.9, "high": 1.1}}))
    a = [c["truth"]["mass"] for c in cases if c["scenario"] == "a"]
    b = [c["truth"]["mass"] for c in cases if c["scenario"] == "b"]
    assert a == b and len(set(a)) == 3 and all(0.9 <= m <= 1.1 for m in a)
    assert len({c["key"] for c in cases}) == 6
