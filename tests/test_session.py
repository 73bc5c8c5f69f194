"""The NLP Ipopt sees is the model Pyomo holds (ocp/session.py)."""
import numpy as np
import pyomo.environ as pyo
import pytest

from ecostudy.ocp import session


def _shared_expressions_with_a_fixed_variable():
    """A leg's last step in miniature: the mean speed holds a fixed end speed, two named powers
    share it and a constraint uses their difference (the joint optimum's power balance)."""
    m = pyo.ConcreteModel()
    m.v = pyo.Var([0, 1], initialize=2.0)
    m.f = pyo.Var(initialize=3.0)
    m.v[1].fix(0.0)
    m.vbar = pyo.Expression(expr=0.5 * (m.v[0] + m.v[1]))
    m.traction = pyo.Expression(expr=m.f * m.vbar / 0.85)
    m.regen = pyo.Expression(expr=0.8 * m.f * m.vbar)
    m.y = pyo.Var(initialize=1.0)
    m.z = pyo.Var(initialize=1.0)
    m.balance = pyo.Constraint(expr=m.y * m.z == (m.traction - m.regen) / 1e3)
    m.objective = pyo.Objective(expr=m.traction - m.regen + m.y ** 2)
    return m


@pytest.mark.parametrize("options, agrees", [(session.NL_OPTIONS, True), (None, True),
                                             ({"export_defined_variables": True}, False)])
def test_the_written_nlp_evaluates_as_the_pyomo_model(options, agrees):
    """Pyomo 6.10's NL writer with named expressions as AMPL defined variables (Pyomo's default)
    hands Ipopt another constraint and objective on this model; ecostudy writes them inline
    (``session.NL_OPTIONS``, and the writer's default once ``ocp.session`` is imported: ``None``,
    as Pyomo's own cyipopt interface under MindtPy writes) and the values agree. The disagreement
    is asserted too, so this test notices when a Pyomo release fixes it."""
    m = _shared_expressions_with_a_fixed_variable()
    CyIpoptNLP, PyomoNLP = session._imports()
    nlp = PyomoNLP(m, nl_file_options=options)
    nlp.set_primals(np.array([v.value for v in nlp.get_pyomo_variables()], float))
    residual = nlp.evaluate_constraints()[0] - nlp.constraints_lb()[0]
    expected = pyo.value(m.balance.body) - pyo.value(m.balance.lower)
    same = bool(residual == pytest.approx(expected, abs=1e-12)) and \
        bool(nlp.evaluate_objective() == pytest.approx(pyo.value(m.objective), rel=1e-12))
    assert same is agrees


def test_the_same_nlp_solved_again_gives_the_same_bits(metro, amsterdam):
    """MUMPS orders the KKT matrix with Scotch here, which ran threads and a random generator that
    went on from call to call: four solves of one NLP from one start ended in four different
    points 1e-15 apart (a network study's supervisor rounds amplified that to 1 %).
    ``ocp.session`` runs Scotch on one thread and resets its generator before each solve."""
    from ecostudy.ocp import problem
    case = problem.prepare(amsterdam, metro, "Rokin", "Centraal", 1000)
    m = problem.build(case, problem.capped_guess(case, 80.0), "net_energy", {}, running_time=80.0)
    nlp = session.Session(m)
    start = nlp.x.copy()
    points = []
    for _ in range(4):
        assert nlp.solve(x0=start).optimal
        points.append(nlp.x.copy())
    assert all(np.array_equal(points[0], p) for p in points[1:])
