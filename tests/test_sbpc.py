"""SBPC (Farooqi 2018 Ch. 4): the blocked FHOCP from any sample and state, and the loop."""
import numpy as np
import pytest

from ecostudy.analysis.single import solve_run
from ecostudy.control.controllers import Quantised
from ecostudy.control.loop import run_loop
from ecostudy.control.sbpc import Sbpc
from ecostudy.core.physics import moving_share
from ecostudy.core.plant import Plant
from ecostudy.core.types import State, Timing
from ecostudy.core.kinematics import samples
from ecostudy.ocp.blocked import handle_at, set_blocked_start, set_objective
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
    m = controller.program.model
    x, v = m.s[7].value, m.v[7].value
    u = controller.plan(State(x, v, 7 * TS))
    assert -1.0 <= u <= 1.0 and controller.failures == 0
    assert controller.softened == 0
    assert all(m.s[i].value == pytest.approx(x) and m.v[i].value == pytest.approx(v) for i in range(8))
    assert m.up[0].value == 0.0 and m.um[0].value == 0.0  # block 0 (samples 0-4) is over
    assert m.s[50].value == pytest.approx(case.segment.distance, abs=1e-3) and m.v[50].value == pytest.approx(0.0, abs=1e-3)
    assert handle_at(m, 7) == handle_at(m, 9)  # samples 5-9 share block 1
    assert list(controller.program.handles(7)) == [handle_at(m, j) for j in range(7, 50)]
    # each variable meets a handful of others in the Lagrangian's Hessian: alpha times the whole
    # work sum made it dense (825 variables: 172 595 entries at k_f = 200, 17 s a sample more)
    nlp = controller.program.session.nlp
    assert nlp.nnz_hessian_lag() < 12 * nlp.n_primals()


def test_a_train_standing_at_the_stop_before_kf_may_wait_there(amsterdam_case):
    """The standstill of ``physics.moving_share``: from sample 40 of k_f = 50, standing at the stop,
    the nominal problem (gamma = 0) is solved by waiting with the handle off; without it the
    Davis term at v = 0 would drive the speed below zero and no plan would exist."""
    case, speeds = amsterdam_case
    controller = Sbpc(case, 76.0, TS, 5, speeds)
    m = controller.program.model
    set_blocked_start(controller.program.session, m, 40, State(case.segment.distance, 0.0, 40 * TS))
    set_objective(controller.program.session, m, 1.0, 0.0, 0.0)
    assert controller.program.session.solve(controller.options).usable
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
    assert abs(result.stop_error_m) < 0.1 and result.overspeed_max_kmh == 0.0
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


def test_condensed_sensitivities_are_the_simulations_derivatives(amsterdam_case):
    """The condensed FHOCP's forward sensitivities (implicit differentiation of each trapezoid
    step) against central differences of its own simulation, from a moving mid-trip state."""
    from ecostudy.ocp.blocked import time_guess
    from ecostudy.ocp.condensed import Condensed
    case, speeds = amsterdam_case
    kf = samples(76.0, TS)
    program = Condensed(case, TS, kf, 5, time_guess(case, speeds, kf, TS))
    program.start(12, State(300.0, 14.0, 12 * TS))
    free = program.nb - 12 // 5
    z = np.concatenate([program.u[12 // 5:program.nb], program.u[program.nb + 12 // 5:]])
    z = np.clip(z + 0.05, 0.0, 0.95)  # traction and braking partly on, away from the bounds
    s, v, ds, dv, work, dwork = program.simulate(z)
    assert len(z) == 2 * free and ds.shape == (kf - 12 + 1, 2 * free)
    for col in (0, 3, free, free + 4):
        step = np.zeros_like(z)
        step[col] = 1e-6
        hi, lo = program.simulate(z + step), program.simulate(z - step)
        assert np.allclose((hi[1] - lo[1]) / 2e-6, dv[:, col], rtol=1e-4, atol=1e-5)
        assert np.allclose((hi[0] - lo[0]) / 2e-6, ds[:, col], rtol=1e-4, atol=1e-4)
        assert (hi[4] - lo[4]) / 2e-6 == pytest.approx(dwork[col], rel=1e-4, abs=1e-3)


def test_condensed_and_simultaneous_plans_agree_and_the_plant_follows(amsterdam_case, metro):
    """One nominal plan from the stand (L = 5, k_f = 50) by each transcription, on the same grade
    and speed bounds (the simultaneous program's settled profile): both stop at the platform on
    time with the same energy (0.1 %: two solvers, the envelopes interpolated); the condensed
    plan's handles driven open loop through the plant (an independent integrator on the same
    physics) end within a metre of its prediction."""
    case, speeds = amsterdam_case
    simultaneous = Sbpc(case, 76.0, TS, 5, speeds)
    condensed = Sbpc(case, 76.0, TS, 5, speeds, transcription="condensed")
    condensed.program.profile = simultaneous.program.model.profile
    for controller in (simultaneous, condensed):
        controller.program.start(0, State())
        assert controller._solve(1.0, 0.0, 0.0).usable
    program = condensed.program
    s, v, _, _, work, _ = program.simulate(program.u)
    assert s[-1] == pytest.approx(case.segment.distance, abs=1e-3) and v[-1] == pytest.approx(0.0, abs=1e-3)
    import pyomo.environ as pyo
    assert work == pytest.approx(pyo.value(simultaneous.program.model.work), rel=1e-3)

    class Replay:
        solve_seconds = []

        def plan(self, measured):
            return program.handle(int(round(measured.time / TS)))
    result = run_loop(Plant(case.segment, metro), Replay(), TS, plant_step=TS / 20)
    assert abs(result.stop_error_m) < 1.0
