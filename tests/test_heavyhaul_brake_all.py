"""K_b on every brake (``brake_penalty_on: all``, a departure from Zhang & Zhuan's eq. 5): a braking
locomotive costs K_e K_b u^2 as a braking wagon does, a pulling one K_e u^2. The term by hand, the
condensed QP's two solvers against each other and against the program written out over the moves for
a third solver, and a study with the forms that cannot solve it refused."""
import numpy as np
import pytest
from scipy.optimize import minimize
from ecostudy.heavyhaul.condensed import ClarabelSolver, CondensedHorizon
from ecostudy.heavyhaul.linear import fence
from ecostudy.heavyhaul.rhc import RecedingHorizon, objective_terms, objective_values
from ecostudy.io.loaders import load_consist

from .test_heavyhaul_magnitude import on_a_descent, refused_in_one_line, runs_besides_adhesion
from .test_heavyhaul_study import PAPER

WEIGHTS = (10.0, 60.0, 10.0, 60.0)


def test_a_braking_locomotive_by_hand():
    """Paper units (100 kN), f = 10 per real car: a locomotive group braking 300 kN costs K_e K_b 3^2 times
    its effort weight, pulling 300 kN K_e 3^2, and the braking one is the braking term's; with the
    wagons only (eq. 5) it costs K_e 3^2 either way, in the energy term. K_b < 1 refused."""
    consist = load_consist(PAPER)
    reduction = fence(consist, 10, 20.0)
    r = reduction.represented(consist.mass)
    n = len(reduction.kinds)
    wagons = np.array([k != "locomotive" for k in reduction.kinds])
    moves = np.zeros((1, n))
    moves[0, 0], moves[0, n - 1] = -300.0, 300.0  # head group braking, rear group pulling
    states = np.zeros((1, 2 * n - 1))
    for on, braking in (("all", 10.0 * 60.0 * r.effort[0] * 9.0), ("wagons", 0.0)):
        terms = objective_terms(reduction.model, reduction.kinds, WEIGHTS, r, brake_on=on)
        values = objective_values(terms, wagons, states, moves, np.zeros(2), 1.0)
        pulling = 10.0 * r.effort[n - 1] * 9.0
        assert values["braking"] == pytest.approx(braking, rel=1e-12)
        assert values["energy"] == pytest.approx(pulling + (0.0 if braking else 10.0 * r.effort[0] * 9.0), rel=1e-12)
    with pytest.raises(ValueError, match="K_b >= 1"):
        objective_terms(reduction.model, reduction.kinds, (10.0, 60.0, 10.0, 0.5), r, brake_on="all")
    with pytest.raises(ValueError, match="brake penalty on"):
        objective_terms(reduction.model, reduction.kinds, WEIGHTS, r, brake_on="head")
    with pytest.raises(ValueError, match="this QP form"):
        RecedingHorizon(reduction.model, reduction.kinds, np_=2, nc=1, brake_on="all")


def test_the_condensed_qp_with_every_brake_against_the_program_written_out():
    """The ore train on a 10 per-mille descent at 20 m/s, v_r 15 m/s (f = 10, Np = 4, Nc = 2, K_b = 60):
    DAQP and Clarabel give the same moves; each braking variable is max(-u, 0) of its locomotive move;
    SciPy's SLSQP on the program written out over the moves alone, 1/2 u'Hu + g'u + sum_l w_l min(u_l, 0)^2
    with w by hand (Ts / Np times the samples a move is held times K_e (K_b - 1) / (100 kN)^2), finds no lower
    cost; the locomotives brake less than with the wagons only."""
    reduction, args = on_a_descent(-0.010)

    def form(on, solver=None):
        return CondensedHorizon(reduction.model, reduction.kinds, np_=4, nc=2, weights=WEIGHTS, brake_on=on,
                                **({"solver": solver} if solver else {}))

    qp = form("all")
    seen = {}
    solve = qp.solver.solve

    def record_solve(*a):
        seen["solver"], seen["x"] = a, solve(*a)[0]
        return solve(*a)

    qp.solver.solve = record_solve
    first = qp.solve(*args)
    assert np.max(np.abs(first - form("all", ClarabelSolver).solve(*args))) < 0.5  # kN
    assert not qp.binding
    n, nu = qp.n, 2 * qp.n
    cols = [m * n + i for m in range(2) for i in qp.locos]
    assert qp.magnitude.extra == len(cols) == 4 and qp.size["inputs"] == nu + 4
    u = seen["x"][:nu]
    assert np.allclose(seen["x"][nu:], np.maximum(-u[cols], 0.0), atol=1e-6)
    assert (u[cols] < -1.0).any()  # the locomotives do brake here
    _, lo, hi, rows, c_lo, c_hi = seen["solver"]
    plain = form("wagons")  # the same program without the braking term: its H and g over the moves
    H = plain.solver.hessian
    g = seen["solver"][0][:nu]
    held = np.array([1.0, 3.0])  # each virtual car weighed as one car (no ``represented``)
    w = np.array([20.0 / 4 * held[m] * 10.0 * 59.0 / 1e4 for m in range(2) for i in qp.locos])

    def J(v):
        return 0.5 * v @ H @ v + g @ v + w @ np.minimum(v[cols], 0.0) ** 2

    own = len(rows) - len(cols)  # the rate and mean-speed rows; the braking rows after them
    R, r_lo, r_hi = rows[:own, :nu], c_lo[:own], c_hi[:own]
    lower, upper = np.isfinite(r_lo), np.isfinite(r_hi)
    cons = [{"type": "ineq", "fun": lambda v: r_hi[upper] - R[upper] @ v},
            {"type": "ineq", "fun": lambda v: R[lower] @ v - r_lo[lower]}]
    x = minimize(J, np.clip(np.zeros(nu), lo[:nu], hi[:nu]), bounds=list(zip(lo[:nu], hi[:nu])), constraints=cons,
                 method="SLSQP", options={"maxiter": 3000, "ftol": 1e-14})
    assert J(u) <= J(x.x) + 1e-7 * abs(J(x.x))
    assert np.max(np.abs(x.x - u)) < 1.0  # kN
    wagons_only = form("wagons").solve(*args)
    assert -first[qp.locos].sum() < -wagons_only[qp.locos].sum() - 1.0


def test_a_study_with_every_brake_and_forms_that_refuse_it(tmp_path):
    """The 5 km line, K_b 1 and 60 on every brake: both runs miss nothing but adhesion and the locomotives'
    dynamic braking does not grow with K_b; the Pyomo form, eq. 11's magnitudes and K_b < 1 refused in one
    line naming the field, before any computing."""
    runs = runs_besides_adhesion(tmp_path, brake_penalty_on="all")
    assert runs.loc[60, "dynamic_brake_kWh"] <= runs.loc[1, "dynamic_brake_kWh"] + 1.0
    for changes in ({"qp_solver": "ipopt"}, {"brake_penalty": [0.5, 60]}, {"effort_penalty": "magnitude"}):
        refused_in_one_line(tmp_path, "brake_penalty_on", brake_penalty_on="all", **changes)
