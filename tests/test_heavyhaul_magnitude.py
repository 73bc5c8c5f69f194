"""Eq. 11's effort term as Zhang & Zhuan print it, K_e (sum_loco |u| + K_b sum_wagon |u|)
(``effort_penalty: magnitude``): the term by hand, the condensed QP's two solvers against each other and
against the program written out by hand for a third solver, and a study."""
import numpy as np
import pytest
from scipy.optimize import minimize
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.heavyhaul.condensed import ClarabelSolver, CondensedHorizon
from ecostudy.heavyhaul.linear import fence
from ecostudy.heavyhaul.loop import horizon, limits, reduced_state
from ecostudy.heavyhaul.plant import CascadePlant
from ecostudy.heavyhaul.reference import table_reference
from ecostudy.heavyhaul.rhc import MAGNITUDE_CURVATURE, objective_terms, objective_values
from ecostudy.io.loaders import load_consist

from .test_heavyhaul_study import PAPER, besides_adhesion, level, study


def test_a_magnitude_by_hand():
    """Paper units (100 kN), f = 10 per real car: a virtual wagon of ten braking 1800 kN costs K_e K_b
    1800 / 100 per second, whatever it stands for (the sum of its wagons' |u|), plus eq. 4's square at
    MAGNITUDE_CURVATURE; a locomotive group pulling 300 kN costs K_e 300 / 100."""
    consist = load_consist(PAPER)
    reduction = fence(consist, 10, 20.0)
    r = reduction.represented(consist.mass)
    terms = objective_terms(reduction.model, reduction.kinds, (10.0, 60.0, 10.0, 40.0), r, effort="magnitude")
    n = len(reduction.kinds)
    moves = np.zeros((1, n))
    moves[0, 2], moves[0, 0] = -1800.0, 300.0
    wagons = np.array([k != "locomotive" for k in reduction.kinds])
    values = objective_values(terms, wagons, np.zeros((1, 2 * n - 1)), moves, np.zeros(2), 1.0)
    square = MAGNITUDE_CURVATURE * 10.0 * 40.0 * r.effort[2] * 18.0 ** 2
    assert values["braking"] == pytest.approx(10.0 * 40.0 * 18.0 + square, rel=1e-12)
    assert values["energy"] == pytest.approx(10.0 * 3.0 + MAGNITUDE_CURVATURE * 10.0 * r.effort[0] * 9.0, rel=1e-12)
    with pytest.raises(ValueError, match="effort penalty"):
        objective_terms(reduction.model, reduction.kinds, (10.0, 60.0, 10.0, 40.0), r, effort="cubed")


def on_a_descent(grade):
    """The ore train at 20 m/s on a constant ``grade``, v_r 15 m/s, f = 10, Np = 4: (the fence, the
    arguments of a QP form's ``solve``)."""
    consist = load_consist(PAPER)
    plant = CascadePlant(consist, level(grade))
    reduction = fence(consist, 10, 20.0)
    state = plant.initial(5000.0, 20.0)
    x0 = reduced_state(plant, reduction, state)
    offsets, vr = horizon(plant, reduction, table_reference([0.0, 1e6], [54.0, 54.0]), state,
                          x0[:len(reduction.kinds)], 4)
    low, high = limits(plant, reduction, state)
    return reduction, (x0, offsets / 1e3, low / 1e3, high / 1e3, vr)


def test_the_condensed_qp_with_magnitudes_against_the_program_written_out():
    """The ore train on a 6 per-mille descent at 20 m/s, v_r 15 m/s (f = 10, Np = 4, Nc = 2, K_b = 60):
    DAQP and Clarabel on the condensed QP with the magnitudes' variables give the same moves, and so
    does SciPy's SLSQP on the program written out over the moves alone, min 1/2 u'Hu + g'u + sum_i
    w_i |u_i| with w by hand (Ts / Np times the samples a move is held times K_e (1 or K_b) / 100 kN),
    |u| smoothed at 1e-3 kN, under the same rate, mean-speed and input bounds; the magnitude moves the
    wagons' braking to the locomotives."""
    reduction, args = on_a_descent(-0.006)
    weights = (10.0, 60.0, 10.0, 60.0)

    def form(effort, solver=None):
        return CondensedHorizon(reduction.model, reduction.kinds, np_=4, nc=2, weights=weights, effort=effort,
                                **({"solver": solver} if solver else {}))

    moves = {(effort, name): form(effort, solver).solve(*args) for effort in ("squared", "magnitude")
             for name, solver in (("daqp", None), ("clarabel", ClarabelSolver))}
    assert np.max(np.abs(moves["magnitude", "daqp"] - moves["magnitude", "clarabel"])) < 0.5  # kN
    wagons = np.array([k != "locomotive" for k in reduction.kinds])
    assert -moves["magnitude", "daqp"][wagons].sum() < -moves["squared", "daqp"][wagons].sum()

    # the squared part as the condensed QP builds it, recorded on the way to its solver (no force row binds)
    qp = form("magnitude")
    seen = {}
    linear, solve = qp.magnitude.linear, qp.solver.solve

    def record_linear(g, high_kN):
        seen["g"] = g.copy()
        return linear(g, high_kN)

    def record_solve(*a):
        seen["solver"] = a
        seen["x"] = solve(*a)[0]
        return solve(*a)

    qp.magnitude.linear, qp.solver.solve = record_linear, record_solve
    qp.solve(*args)
    assert not qp.binding
    n, nu, extra = qp.n, 2 * qp.n, qp.magnitude.extra
    assert extra == 2 * len(qp.locos)  # a |u| variable per locomotive group and move
    _, lo, hi, rows, c_lo, c_hi = seen["solver"]
    H, g = qp.magnitude.hessian[:nu, :nu], seen["g"]
    own = len(rows) - 2 * extra  # the rate and mean-speed rows; the magnitudes' rows after them
    R, r_lo, r_hi = rows[:own, :nu], c_lo[:own], c_hi[:own]
    assert not rows[:own, nu:].any()
    held = np.array([1.0, 3.0])  # Np = 4, Nc = 2: move 0 held one sample, move 1 three
    w = np.concatenate([20.0 / 4 * c * 10.0 * np.where(wagons, 60.0, 1.0) / 100.0 for c in held])

    def J(u):
        return 0.5 * u @ H @ u + g @ u + w @ np.sqrt(u ** 2 + 1e-6)

    lower, upper = np.isfinite(r_lo), np.isfinite(r_hi)
    cons = [{"type": "ineq", "fun": lambda u: r_hi[upper] - R[upper] @ u},
            {"type": "ineq", "fun": lambda u: R[lower] @ u - r_lo[lower]}]
    bounds = list(zip(lo[:nu], hi[:nu]))
    x = minimize(J, np.clip(np.zeros(nu), lo[:nu], hi[:nu]), bounds=bounds, constraints=cons, method="SLSQP",
                 options={"maxiter": 3000, "ftol": 1e-14})
    u = seen["x"][:nu]
    assert np.allclose(seen["x"][nu:], np.abs(u[[m * n + i for m in range(2) for i in qp.locos]]), atol=1e-6)
    assert J(u) <= J(x.x) + 1e-6 * abs(J(x.x))
    assert np.max(np.abs(x.x - u)) < 5.0  # kN: the smoothing's and SLSQP's tolerance


def runs_besides_adhesion(tmp_path, **changes):
    """The 5 km study with ``changes`` run by the CLI: every run flagged for adhesion alone (the paper's
    plant asks more than dry rail gives); runs.csv by K_b."""
    import pandas as pd
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["heavyhaul", str(study(tmp_path, **changes)), "--out", str(out), "--no-progress",
                                      "--no-plot"])
    assert result.exit_code == 1, result.output
    runs = pd.read_csv(out / "runs.csv").set_index("K_b")
    assert (runs["status"] == "flagged").all() and all(besides_adhesion(r) == [] for r in runs["reason"])
    return runs


def refused_in_one_line(tmp_path, field, **changes):
    """The 5 km study with ``changes`` refused by the CLI in one line naming ``field``, before any computing."""
    refused = CliRunner().invoke(app, ["heavyhaul", str(study(tmp_path, **changes)), "--out", str(tmp_path / "no"),
                                       "--no-progress"])
    assert refused.exit_code == 2 and field in refused.output and "Traceback" not in refused.output
    assert len(refused.output.strip().splitlines()) == 1, refused.output
    assert not (tmp_path / "no").exists()


def test_a_study_with_magnitudes_and_a_form_without_them(tmp_path):
    """The 5 km line, K_b 1 and 60, eq. 11's magnitudes: both runs miss nothing but adhesion and the wagons
    brake less at 60; the Pyomo form (squares only) refused in one line naming the field, before any computing."""
    runs = runs_besides_adhesion(tmp_path, effort_penalty="magnitude")
    assert runs.loc[60, "wagon_brake_kWh"] < 0.8 * runs.loc[1, "wagon_brake_kWh"]
    refused_in_one_line(tmp_path, "effort_penalty", effort_penalty="magnitude", qp_solver="ipopt")
