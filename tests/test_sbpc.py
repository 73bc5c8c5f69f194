"""SBPC (thesis 000 Ch. 4): the blocked FHOCP from any sample and state, and the loop."""
import numpy as np
import pytest

from ecostudy.analysis.single import solve_run
from ecostudy.control.controllers import Quantised
from ecostudy.control.loop import run_loop
from ecostudy.control.sbpc import Sbpc
from ecostudy.core.physics import moving_share
from ecostudy.core.plant import Plant
from ecostudy.core.types import State, Timing
from ecostudy.ocp.blocked import handle_at, samples, set_blocked_start, set_objective
from ecostudy.ocp.problem import prepare

TS = 1.52  # four of the thesis's samples: k_f = 50 keeps the loop short


@pytest.fixture(scope="module")
def amsterdam_case(metro, amsterdam):
    ato = solve_run(amsterdam, metro, "Rokin", "Centraal", Timing(running_time=76.0), points=200)
    case = prepare(amsterdam, metro, "Rokin", "Centraal", 200)
    return case, np.interp(case.nodes, ato.trajectory.nodes, ato.trajectory.v)


def test_samples_floor_the_running_time():
    assert samples(76.0, 0.38) == 200 and samples(76.0, 0.4) == 190


def test_a_plan_from_a_later_sample_keeps_the_past_and_the_blocks(amsterdam_case):
    """From sample 7 of k_f = 50 with L = 5, at the state the first plan predicted there: the
    states before it are the measured one, the blocks already run are zero, the plan reaches the
    stop, and each block holds one value."""
    case, speeds = amsterdam_case
    controller = Sbpc(case, 76.0, TS, 5, speeds)
    controller.plan(State())
    m = controller.model
    x, v = m.s[7].value, m.v[7].value
    u = controller.plan(State(x, v, 7 * TS))
    assert -1.0 <= u <= 1.0 and controller.failures == 0
    assert controller.softened == 0
    assert all(m.s[i].value == pytest.approx(x) and m.v[i].value == pytest.approx(v) for i in range(8))
    assert m.up[0].value == 0.0 and m.um[0].value == 0.0  # block 0 (samples 0-4) is over
    assert m.s[50].value == pytest.approx(case.segment.distance, abs=1e-3) and m.v[50].value == pytest.approx(0.0, abs=1e-3)
    assert handle_at(m, 7) == handle_at(m, 9)  # samples 5-9 share block 1
    # each variable meets a handful of others in the Lagrangian's Hessian: alpha times the whole
    # work sum made it dense (825 variables: 172 595 entries at k_f = 200, 17 s a sample more)
    nlp = controller.session.nlp
    assert nlp.nnz_hessian_lag() < 12 * nlp.n_primals()


def test_a_train_standing_at_the_stop_before_kf_may_wait_there(amsterdam_case):
    """The standstill of ``physics.moving_share``: from sample 40 of k_f = 50, standing at the stop,
    the nominal problem (gamma = 0) is solved by waiting with the handle off; without it the
    Davis term at v = 0 would drive the speed below zero and no plan would exist."""
    case, speeds = amsterdam_case
    controller = Sbpc(case, 76.0, TS, 5, speeds)
    m = controller.model
    set_blocked_start(controller.session, m, 40, State(case.segment.distance, 0.0, 40 * TS))
    set_objective(controller.session, m, 1.0, 0.0, 0.0)
    assert controller.session.solve(controller.options).usable
    assert max(m.v[i].value for i in range(40, 51)) < 1e-4
    assert m.s[50].value == pytest.approx(case.segment.distance, abs=1e-3)
    assert m.up[8].value < 1e-4 and m.up[9].value < 1e-4


def test_moving_share_is_zero_at_a_stand_and_one_when_moving():
    assert moving_share(0.0) == 0.0 and moving_share(0.1) > 0.99 and moving_share(20.0) == pytest.approx(1.0)


@pytest.mark.slow
def test_the_nominal_loop_ends_at_the_stop_and_quantised_handles_stay_within_metres(amsterdam_case, metro):
    case, speeds = amsterdam_case
    nominal = Sbpc(case, 76.0, TS, 1, speeds)
    result = run_loop(Plant(case.segment, metro), nominal, TS, plant_step=TS)
    assert abs(result.stop_error_m) < 0.1 and result.max_overspeed_kmh == 0.0
    assert result.arrival_time_s == pytest.approx(76.0, abs=2 * TS)
    relaxed = Sbpc(case, 76.0, TS, 4, speeds, "two_step")
    quantised = run_loop(Plant(case.segment, metro), Quantised(relaxed, metro.das_levels), TS, plant_step=TS)
    assert relaxed.failures == 0 and abs(quantised.stop_error_m) < 15.0  # 1.52 s of a held DAS level


def test_absolute_blocks_are_eq_4_8s_blocks():
    """ocp/blocked.py holds sample i in block floor(i / L); eq. 4.8 (control/blocking.py) counts
    the blocks from the one holding k: the same blocks, and N(k) of them ahead."""
    from ecostudy.control.blocking import blocks, free_moves
    for kf, block in ((60, 20), (50, 20), (200, 45), (17, 1)):
        for k in range(kf):
            absolute = [(k + j) // block for j in range(kf - k)]
            assert [b - 1 + k // block for b in blocks(k, kf, block)] == absolute
            assert len(set(absolute)) == free_moves(k, kf, block)
