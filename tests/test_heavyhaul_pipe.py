"""The brake pipe in the design model (``design_pipe``, heavyhaul.linear.pipe_model): each wagon car's
command reaches its brake its signal delay into a sample and the brake builds up as a first-order
lag; the condensed QP predicts with it (heavyhaul.condensed.CondensedHorizon, ``pipe``)."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ecostudy.core.units import KN
from ecostudy.heavyhaul.airbrake import signal_delays, virtual_delays
from ecostudy.heavyhaul.condensed import CondensedHorizon
from ecostudy.heavyhaul.linear import design_model, fence, pipe_model

from .test_heavyhaul_intrain import consist

MASS, C1, STIFF = np.array([2e5, 8e5, 8e5, 8e5]), np.full(4, 1e-3), np.full(3, 8e7)
WAGONS, DELAYS, TAU = np.array([False, True, True, True]), np.array([0.0, 2.0, 5.0, 9.0]), 8.0


def delayed_lag(model, z0, u_before, u, offsets):
    """The continuous linear train with the wagons' brakes as states, each following u_before until
    its delay and u after, as a first-order lag; integrated over Ts."""
    ns = len(model.Ac)

    def rate(t, z):
        x, b = z[:ns], z[ns:]
        seen = np.where(t < DELAYS - 1e-9, u_before, u)
        dx = model.Ac @ x + model.Bc @ (np.where(WAGONS, 0.0, u) - offsets) + model.Bc[:, WAGONS] @ b
        return np.concatenate([dx, (seen[WAGONS] - b) / TAU])
    z, edges = np.asarray(z0, float), np.unique(np.r_[0.0, DELAYS, model.ts])
    for a, b in zip(edges[:-1], edges[1:]):  # piece by piece: the seen command jumps at each delay
        z = solve_ivp(rate, (a, b), z, method="DOP853", rtol=1e-12, atol=1e-10, max_step=0.05).y[:, -1]
    return z


def test_a_sample_of_the_pipe_model_is_the_delayed_lagged_brake_integrated():
    model = design_model(MASS, C1, STIFF, 20.0)
    pipe = pipe_model(model, WAGONS, DELAYS, TAU)
    z0 = np.array([10, 10.2, 9.9, 10.1, 0.01, -0.02, 0.0, -3e4, -1e4, 0.0])
    before, u, offsets = np.array([0, -5e4, -2e4, -8e4]), np.array([3e5, -1e5, -6e4, 0.0]), np.array([1e4, 2e4, 3e4, 4e4])
    predicted = pipe.A @ z0 + pipe.B0 @ u + pipe.B1 @ before - pipe.Bo @ offsets
    exact = delayed_lag(model, z0, before, u, offsets)
    assert predicted[:4] == pytest.approx(exact[:4], abs=1e-7)  # speeds [m/s]
    assert predicted[4:7] == pytest.approx(exact[4:7], abs=1e-9)  # couplers [m]
    assert predicted[7:] == pytest.approx(exact[7:], abs=1e-2)  # brakes [N]
    # without delay and with a build-up far shorter than Ts it is eq. 2
    instant = pipe_model(model, WAGONS, np.zeros(4), 1e-4)
    eq2 = model.A @ z0[:7] + model.B @ (u - offsets)
    assert (instant.A @ np.r_[z0[:7], 0, 0, 0] + instant.B0 @ u + instant.B1 @ before - instant.Bo @ offsets)[:7] == \
        pytest.approx(eq2, abs=1e-4)


def test_a_delay_of_a_sample_or_more_is_refused():
    with pytest.raises(ValueError, match="design_pipe"):
        pipe_model(design_model(MASS, C1, STIFF, 5.0), WAGONS, DELAYS, TAU)


def test_the_condensed_prediction_steps_the_pipe_model_sample_by_sample():
    """x(k) = G[k-1] U + d(k) against the PipeModel's recursion with u(-1) the command sent before,
    u(j) the moves (the last held to Np) and the measured brakes as b(0): in kN, as the QP is."""
    model = design_model(MASS, C1, STIFF, 20.0)
    pipe = pipe_model(model, WAGONS, DELAYS, TAU, KN)
    qp = CondensedHorizon(model, ["locomotive", "wagon", "wagon", "wagon"], np_=4, nc=2, pipe=pipe)
    rng = np.random.default_rng(3)
    x0, brakes, before = rng.normal(size=7), -rng.uniform(0, 50, 4), -rng.uniform(0, 50, 4)
    offsets, moves = rng.normal(size=(4, 4)) * 10, rng.normal(size=(2, 4)) * 100
    qp.seen(brakes, before)
    d = qp.free(x0, offsets)
    z, last = np.r_[x0, brakes[1:]], before
    for k in range(4):
        u = moves[min(k, 1)]
        z, last = pipe.A @ z + pipe.B0 @ u + pipe.B1 @ last - pipe.Bo @ offsets[k], u
        assert qp.G[k] @ moves.ravel() + d[k] == pytest.approx(z[:7], rel=1e-9, abs=1e-9)


def test_a_virtual_wagons_delay_is_its_wagons_weighted_by_their_brakes():
    """The ore train at f = 10: the first ten wagons' centres' mean delay; a locomotive group 0 brake, its delay."""
    c = consist()
    f = fence(c, 10, 20.0)
    delays, d = virtual_delays(c, f.members), signal_delays(c, c.air_brake.signal_speed)
    first = f.kinds.index("wagon")
    assert delays[first] == pytest.approx(d[f.members[first]].mean(), rel=1e-12)
    assert max(delays) < 20.0


def test_design_pipe_needs_air_brakes_and_the_condensed_qp(tmp_path):
    from typer.testing import CliRunner

    from ecostudy.cli import app

    from .test_heavyhaul_study import study
    runner = CliRunner()
    for changes, told in (({}, "air_brake: false, daqp"), ({"air_brake": True, "qp_solver": "clarabel"}, "air_brake: true, clarabel")):
        out = runner.invoke(app, ["heavyhaul", str(study(tmp_path, design_pipe=True, **changes)), "--no-progress"])
        assert out.exit_code == 2 and "design_pipe" in out.output and told in out.output and "Traceback" not in out.output
