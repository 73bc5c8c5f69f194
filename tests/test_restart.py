"""Formulations from any state: one movable model re-solved from mid-run states and towards other
terminal conditions by bounds alone (ocp/restart.py), against the run's own optimum (Bellman:
the tail of an optimal run is optimal for the rest of the trip)."""
import numpy as np
import pytest

from ecostudy.analysis.single import solve_run
from ecostudy.core.errors import InputError
from ecostudy.core.types import State, Timing, Window
from ecostudy.io.loaders import load_track, load_train
from ecostudy.ocp.problem import prepare
from ecostudy.ocp.restart import Replanner, start_interval

from .conftest import TRACKS, TRAINS

K = 500


@pytest.fixture(scope="module")
def planned(metro, amsterdam):
    """The Amsterdam case (76 s) as a movable model, and its plan from standstill."""
    replanner = Replanner(prepare(amsterdam, metro, "Rokin", "Centraal", K), running_time=76.0)
    return replanner, replanner.solve()


@pytest.fixture(scope="module")
def regional_ato():
    train = load_train(TRAINS / "regional_alstom.yaml")
    track = load_track(TRACKS / "regional_808m.yaml")
    return solve_run(track, train, "Origin", "Destination", Timing(running_time=80.0), points=500), train


def test_movable_model_from_standstill_is_the_ordinary_optimum(planned, metro, amsterdam):
    _, full = planned
    ordinary = solve_run(amsterdam, metro, "Rokin", "Centraal", Timing(running_time=76.0), points=K)
    assert full.outcome.optimal
    assert full.traction_energy / 3.6e6 == pytest.approx(ordinary.summary["traction_energy_kWh"], rel=1e-7)
    assert full.time[-1] == pytest.approx(76.0, abs=1e-6)


@pytest.mark.parametrize("position, between", [(50.0, 0.0), (130.0, 0.37), (220.0, 0.81)])
def test_resolve_from_a_mid_run_state_gives_the_tail_without_a_rebuild(planned, position, between):
    replanner, full = planned
    nlp, model, build_s = replanner.session.nlp, replanner.model, replanner.stages["build"]
    ds = np.diff(full.nodes)
    k = int(np.searchsorted(full.nodes, position))
    # the state on the optimum a share ``between`` into interval k (constant acceleration: v^2 linear in x)
    x = full.nodes[k] + between * ds[k]
    v = np.sqrt(full.v[k] ** 2 + between * (full.v[k + 1] ** 2 - full.v[k] ** 2))
    t = full.time[k] + 2 * (x - full.nodes[k]) / (full.v[k] + v)
    tail = float(np.sum(full.ft[k + 1:] * ds[k + 1:]) + full.ft[k] * (full.nodes[k + 1] - x))
    assert tail > 0.1 * full.traction_energy  # a state with work still to do

    plan = replanner.solve(State(x, v, t))
    assert plan.outcome.optimal
    assert plan.traction_energy == pytest.approx(tail, rel=1e-3)
    assert plan.time[-1] == pytest.approx(76.0, abs=1e-6)
    assert np.max(np.abs(plan.v[k + 1:] - full.v[k + 1:])) < 0.01  # [m/s]: the same profile ahead
    assert np.allclose(plan.shares[:k], 0.0) and plan.shares[k] == pytest.approx(1 - between)
    # re-used: the same model and NL file, no build since
    assert replanner.session.nlp is nlp and replanner.model is model and replanner.stages["build"] == build_s


def test_other_terminal_conditions_and_a_standing_start(planned):
    replanner, full = planned
    passing = replanner.solve(State(), end_speed=(5.0, 10.0), arrival=(60.0, 70.0))
    assert passing.outcome.optimal
    assert 5.0 - 1e-6 <= passing.v[-1] <= 10.0 + 1e-6 and 60.0 - 1e-6 <= passing.time[-1] <= 70.0 + 1e-6
    assert passing.traction_energy > full.traction_energy  # arriving sooner and faster costs more
    standing = replanner.solve(State(400.0, 0.0, 30.0), arrival=110.0)  # held at a signal mid-way
    assert standing.outcome.optimal and standing.time[-1] == pytest.approx(110.0, abs=1e-6)
    k, _ = start_interval(full.nodes, 400.0)
    assert np.all(standing.v[:k + 1] < 1e-6)
    back = replanner.solve(State(), end_speed=(0.0, 0.0), arrival=76.0)
    assert back.traction_energy == pytest.approx(full.traction_energy, rel=1e-7)


def test_a_window_behind_the_start_or_a_start_off_the_segment_is_refused(metro, amsterdam):
    case = prepare(amsterdam, metro, "Rokin", "Centraal", 200, windows=[Window(300.0, latest=40.0)])
    replanner = Replanner(case, running_time=80.0)
    assert replanner.solve().outcome.optimal
    with pytest.raises(InputError, match="behind the start"):
        replanner.solve(State(500.0, 15.0, 40.0))
    with pytest.raises(InputError, match="not on the segment"):
        replanner.solve(State(case.segment.distance + 5.0, 0.0, 0.0))


@pytest.mark.slow  # over 7 s: make test stays under 3 min; CI runs it
def test_the_das_phases_nlp_replans_from_a_mid_run_state(regional_ato):
    """The phases NLP (Farooqi 2018 Ch. 5) as a movable model: from states on its own optimum in the
    first sector (where traction is still to come) the tail's traction work is the same."""
    from ecostudy.analysis.regimes import guess_from_result
    from ecostudy.ocp import phases
    from ecostudy.ocp.restart import set_end, set_phases_start
    from ecostudy.ocp.session import Session
    ato, train = regional_ato
    layout = phases.Layout.make(phases.sectors(ato.segment, train), phases.sequence(train), 1)
    layout.substeps = phases.substeps_for(500, len(layout.phases))
    m = phases.build(ato.segment, train, layout, guess_from_result(ato, layout), running_time=80.0, movable=True)
    session = Session(m)
    assert session.solve().optimal
    _, x, v, dt, ft, _ = phases.solution(m, layout)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    for k in (3, 5):
        tail = float(np.sum(ft[k:] * np.diff(x)[k:]))
        set_phases_start(session, m, layout, State(x[k], v[k], t[k]))
        set_end(session, m, (0.0, 0.0), 80.0)
        assert session.solve().optimal
        lengths, _, v2, dt2, ft2, _ = phases.solution(m, layout)
        x2 = phases.node_positions(layout, lengths, origin=x[k])
        assert float(np.sum(ft2 * np.diff(x2))) == pytest.approx(tail, rel=1e-3)
        assert t[k] + dt2.sum() == pytest.approx(80.0, abs=1e-6) and x2[-1] == pytest.approx(x[-1], abs=1e-6)
