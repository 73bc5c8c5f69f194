"""Does the space NLP written with its named expressions as AMPL defined variables (Pyomo's NL writer,
``export_defined_variables``) evaluate as the one written inline and as the Pyomo model? Objective,
constraints, gradient, Jacobian and Hessian of the Lagrangian at the start and at random points within
the bounds, on the space NLPs of the default study (metro, energy), the long case of bench/bench_lean.py
(regional line S01-S20, net energy) and regional_80s (net energy); each as ``ocp.space`` builds it
(standstill at both ends: the end speeds fixed) and with the end speeds held by equal bounds instead
(``--ends bounds``), the form without a fixed variable.

    PYTHONPATH=$PWD .venv/bin/python bench/check_defined.py [--points 1000] [--draws 3] [--ends fixed bounds]

Prints, per case and point, the largest relative difference of each quantity (defined against
inline; the objective and constraints, each row's body less its bound, also against Pyomo's own
``value``) and the number of defined variables in the NL file.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import problem, session, solver  # noqa: E402
from pyomo.opt import WriterFactory  # noqa: E402

DEFINED = {"export_defined_variables": True}

CASES = {  # track, train, from, to, running time [s] (None: 1.15 x the envelope's), objective
    "default": ("tracks/amsterdam_rokin_centraal.yaml", "trains/amsterdam_metro.yaml", "Rokin", "Centraal", 76.0, "energy"),
    "long": ("tracks/regional_line_20stops.yaml", "trains/regional_alstom.yaml", "S01", "S20", None, "net_energy"),
    "regional_80s": ("tracks/regional_808m.yaml", "trains/regional_alstom.yaml", "Origin", "Destination", 80.0,
                     "net_energy"),
}


def held_by_bounds(m) -> None:
    """The fixed end speeds of ``m`` unfixed and held at their value by equal bounds."""
    for var in (m.v[m.K.first()], m.v[m.K.last()]):
        if var.fixed:
            value = var.value
            var.unfix()
            var.setlb(value)
            var.setub(value)


def relative(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b), initial=0.0) / max(float(np.max(np.abs(b), initial=0.0)), 1e-300))


def sparse_relative(a, b) -> float:
    a, b = a.tocsr(), b.tocsr()
    d = abs(a - b)
    return float(d.max() / max(abs(b).max(), 1e-300)) if d.nnz else 0.0


def residual(nlp):
    """Each row's body less its bound (the lower one where it has one): the NL writer moves a
    row's constant into its bounds, differently with and without defined variables."""
    lb, ub = nlp.constraints_lb(), nlp.constraints_ub()
    return nlp.evaluate_constraints() - np.where(np.isfinite(lb), lb, ub)


def check(name: str, points: int, draws: int, ends: str) -> None:
    import pyomo.core as pyo
    track, train, start, end, running_time, objective = CASES[name]
    case = problem.prepare(load_track(ROOT / track), load_train(ROOT / train), start, end, points)
    running_time = running_time or round(1.15 * case.estimate)
    m = problem.build(case, problem.capped_guess(case, running_time), objective, {}, running_time=running_time)
    if ends == "bounds":
        held_by_bounds(m)
    _, PyomoNLP = session._imports()
    path = Path(f"/tmp/check_defined_{name}_{ends}.nl")
    WriterFactory("nl")(m, str(path), lambda x: True, DEFINED)
    segments = sum(line.startswith("V") for line in path.read_text().splitlines())
    path.unlink()
    inline = PyomoNLP(m, nl_file_options=solver.NL_OPTIONS)
    defined = PyomoNLP(m, nl_file_options=DEFINED)
    assert [v.name for v in inline.get_pyomo_variables()] == [v.name for v in defined.get_pyomo_variables()]
    assert [c.name for c in inline.get_pyomo_constraints()] == [c.name for c in defined.get_pyomo_constraints()]
    rng = np.random.default_rng(0)
    lb, ub = inline.primals_lb(), inline.primals_ub()
    x0 = np.array(inline.init_primals(), float)
    fixed = sum(1 for v in m.component_data_objects(pyo.Var) if v.fixed)
    print(f"{name}, end speeds {ends}: K = {points}, {inline.n_primals()} variables ({fixed} fixed), "
          f"{inline.n_constraints()} constraints, {segments} defined variables")
    worst = 0.0
    for i in range(draws + 1):
        x = x0 if i == 0 else np.clip(x0 + rng.normal(0.0, 0.05, x0.size) * np.maximum(np.abs(x0), 1.0),
                                      lb, np.where(np.isfinite(ub), ub, np.inf))
        y = rng.normal(0.0, 1.0, inline.n_constraints())
        for nlp in (inline, defined):
            nlp.set_primals(x)
            nlp.set_duals(y)
        variables = inline.get_pyomo_variables()
        for var, value in zip(variables, x):
            var.set_value(float(value), skip_validation=True)
        rows = inline.get_pyomo_constraints()
        pyomo_c = np.array([pyo.value(c.body) - pyo.value(c.lower if c.has_lb() else c.upper) for c in rows])
        pyomo_f = float(pyo.value(m.objective))
        out = {
            "objective": relative(defined.evaluate_objective(), inline.evaluate_objective()),
            "objective vs Pyomo": relative(defined.evaluate_objective(), pyomo_f),
            "constraints": relative(residual(defined), residual(inline)),
            "constraints vs Pyomo": relative(residual(defined), pyomo_c),
            "gradient": relative(defined.evaluate_grad_objective(), inline.evaluate_grad_objective()),
            "Jacobian": sparse_relative(defined.evaluate_jacobian(), inline.evaluate_jacobian()),
            "Hessian": sparse_relative(defined.evaluate_hessian_lag(), inline.evaluate_hessian_lag()),
        }
        worst = max(worst, *out.values())
        print(f"  point {i} ({'start' if i == 0 else 'random'}): " + ", ".join(f"{k} {v:.1e}" for k, v in out.items()))
    print(f"  largest relative difference {worst:.1e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1000)
    parser.add_argument("--draws", type=int, default=3)
    parser.add_argument("--case", nargs="+", default=list(CASES))
    parser.add_argument("--ends", nargs="+", default=["fixed", "bounds"], choices=["fixed", "bounds"])
    args = parser.parse_args()
    solver.configure()
    print(f"`python bench/check_defined.py --points {args.points} --draws {args.draws}`")
    for name in args.case:
        for ends in args.ends:
            check(name, args.points, args.draws, ends)


if __name__ == "__main__":
    main()
