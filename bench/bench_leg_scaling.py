"""The network legs' NLP scaling: magnitudes as Ipopt sees them, and replays under other scalings.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_scaling.py dump studies/network_metro_3trains.yaml \
        triggering --tasks /tmp/tasks.pkl
    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_scaling.py audit --tasks /tmp/tasks.pkl [--which 7]
    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_scaling.py replay --tasks /tmp/tasks.pkl \
        --variant '{}' --variant '{"scale": {"leg.s": 1e-3}}' --variant '{"options": {"obj_scaling_factor": 100}}'

``dump``: plays the independent runs and the named strategy as ``ecostudy network`` does in one
process, keeping every leg task (``legs.solve_leg``'s argument) in a pickle. ``audit``: per row
family of a task's leg NLP at its start, the largest Jacobian entry (median and largest over the
rows), the factor Ipopt's gradient-based scaling gives it (min(1, 100 / largest entry),
``nlp_scaling_max_gradient`` 100), the objective's gradient, the variables' magnitudes.
``replay``: every task solved again as ``legs.solve_leg`` solves it, per variant: ``options``
(Ipopt options added to the legs' own) and ``scale`` (user scaling: variable families and row
families by component name, e.g. ``leg.s``, ``leg.dynamics``, ``objective``, multiplied into the
gradient-based factors computed as Ipopt computes them at the start; Ipopt then runs with
``nlp_scaling_method user-scaling``). Prints iterations and costs against the first variant.
"""
import argparse
import json
import pickle
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.core.units import signed  # noqa: E402
from ecostudy.ocp import solver  # noqa: E402

solver.configure()

import numpy as np  # noqa: E402
import pyomo.environ as pyo  # noqa: E402

from ecostudy.network import fleet as fleet_module, legs  # noqa: E402
from ecostudy.ocp import session  # noqa: E402

MAX_GRADIENT = 100.0  # Ipopt's nlp_scaling_max_gradient default
SCALE: dict = {}      # the variant's user scaling, by family name (empty: Ipopt's own scaling)
ITERATIONS: list = []


def family(name):
    return name.split("[")[0]


def gradient_factors(nlp, x):
    """Ipopt's gradient-based factors at ``x``: objective, rows (min(1, 100 / largest |entry|))."""
    nlp.set_primals(x)
    g = np.abs(nlp.evaluate_grad_objective())
    obj = min(1.0, MAX_GRADIENT / g.max()) if g.max() > 0 else 1.0
    jac = nlp.evaluate_jacobian().tocsr()
    rows = np.ones(nlp.n_constraints())
    for i in range(nlp.n_constraints()):
        big = np.abs(jac.data[jac.indptr[i]:jac.indptr[i + 1]]).max(initial=0.0)
        if big > MAX_GRADIENT:
            rows[i] = MAX_GRADIENT / big
    return obj, rows


def scaled_problem_class(base):
    """``CyIpoptNLP`` that hands Ipopt the user scaling of :data:`SCALE` (gradient-based factors
    at the start times the family factors)."""
    class Scaled(base):
        def __init__(self, nlp, *args, **kwargs):
            super().__init__(nlp, *args, **kwargs)
            if SCALE:
                x0 = START[0]
                obj, rows = gradient_factors(nlp, x0)
                obj *= SCALE.get("objective", 1.0)
                xs = np.array([SCALE.get(family(v.name), 1.0) for v in nlp.get_pyomo_variables()])
                cs = rows * np.array([SCALE.get(family(c.name), 1.0) for c in nlp.get_pyomo_constraints()])
                self.set_problem_scaling(obj_scaling=obj, x_scaling=xs, g_scaling=cs)
    return Scaled


START = [None]


def patch():
    """Sessions solve with :data:`SCALE`; each solve's iterations noted."""
    plain_imports, plain_solve = session._imports, session.Session.solve

    def imports():
        cy, pyomo_nlp = plain_imports()
        return scaled_problem_class(cy), pyomo_nlp
    session._imports = imports

    def solve(self, options=None, x0=None):
        START[0] = self.x if x0 is None else np.asarray(x0, float)
        opts = dict(options or {})
        if SCALE:
            opts["nlp_scaling_method"] = "user-scaling"
        out = plain_solve(self, opts, x0)
        ITERATIONS.append(out.iterations)
        return out
    session.Session.solve = solve


def dump(a):
    from ecostudy.network.strategies import one_strategy, solve_independent
    from ecostudy.studies.network import expand_network
    import tempfile
    tasks = []
    plain = fleet_module.solve_leg

    def keep(task):
        run, outcome = plain(task)
        tasks.append((task, outcome.iterations, run.notes))
        return run, outcome
    fleet_module.solve_leg = keep
    with tempfile.TemporaryDirectory() as out:
        fleet = expand_network(a.study, out=out).cases[0]["fleet"]
        ind, wall = solve_independent(fleet)
        for name in a.strategies:
            res = one_strategy(fleet, name, ind, wall)
            print(name, res.get("totals", {}).get("substation_kWh"), len(tasks), "tasks so far", flush=True)
    Path(a.tasks).write_bytes(pickle.dumps([t for t, *_ in tasks]))
    for k, (task, its, notes) in enumerate(tasks):
        print(k, task[1], "warm" if task[5] else "cold", its, notes or "")


def audit(a):
    tasks = pickle.loads(Path(a.tasks).read_bytes())
    for k in a.which:
        task = tasks[k]
        nlp_obj = legs.LegNLP(task)
        nlp = nlp_obj.session.nlp
        x = nlp_obj.own
        nlp.set_primals(x)
        obj, rows = gradient_factors(nlp, x)
        grad = nlp.evaluate_grad_objective()
        print(f"task {k} {task[1]} warm={task[5]} n={nlp.n_primals()} m={nlp.n_constraints()} "
              f"objective {nlp.evaluate_objective():.4g}")
        names = [v.name for v in nlp.get_pyomo_variables()]
        by = defaultdict(list)
        for i, name in enumerate(names):
            by[family(name)].append(i)
        lb, ub = nlp.primals_lb(), nlp.primals_ub()
        print("  variables: family, count, |x| median / max, bounds, objective gradient |.| median / max")
        for fam, idx in by.items():
            idx = np.array(idx)
            g = np.abs(grad[idx])
            print(f"    {fam:14s} {len(idx):4d} |x| {np.median(np.abs(x[idx])):9.3g} {np.abs(x[idx]).max():9.3g} "
                  f"[{lb[idx].min():g}, {ub[idx].max():g}]  grad f {np.median(g):9.3g} {g.max():9.3g}")
        print(f"  objective: largest gradient {np.abs(grad).max():.3g}, Ipopt factor {obj:.3g}")
        jac = nlp.evaluate_jacobian().tocsr()
        cons = [c.name for c in nlp.get_pyomo_constraints()]
        rowfam = defaultdict(list)
        for i, name in enumerate(cons):
            rowfam[family(name)].append(i)
        print("  rows: family, count, largest |entry| median / max, smallest nonzero |entry| median, Ipopt factor min / median")
        for fam, idx in rowfam.items():
            big = [np.abs(jac.data[jac.indptr[i]:jac.indptr[i + 1]]).max(initial=0) for i in idx]
            small = [np.abs(d[d != 0]).min(initial=np.inf) for d in (jac.data[jac.indptr[i]:jac.indptr[i + 1]] for i in idx)]
            f = rows[idx]
            print(f"    {fam:22s} {len(idx):4d} {np.median(big):9.3g} {np.max(big):9.3g} {np.median(small):9.3g}  "
                  f"{f.min():8.3g} {np.median(f):8.3g}")
        # the entries per variable family in the dynamics rows
        for fam in ("leg.dynamics", "leg.kinematics"):
            if fam not in rowfam:
                continue
            sub = jac[rowfam[fam]].tocoo()
            per = defaultdict(list)
            for c, d in zip(sub.col, sub.data):
                per[family(names[c])].append(abs(d))
            print(f"    {fam} entries by variable: " + ", ".join(f"{v} {np.median(d):.3g}..{np.max(d):.3g}" for v, d in per.items()))


def replay(a):
    tasks = pickle.loads(Path(a.tasks).read_bytes())
    if a.which:
        tasks = [tasks[k] for k in a.which]
    patch()
    variants = [json.loads(v) for v in a.variant]
    base_costs = None
    for variant in variants:
        SCALE.clear()
        SCALE.update(variant.get("scale", {}))
        extra = variant.get("options", {})
        saved = dict(legs.KKT)
        legs.KKT.update(extra)
        ITERATIONS.clear()
        costs, its, c0 = [], [], time.process_time()
        for task in tasks:
            n0 = len(ITERATIONS)
            try:
                run, outcome = legs.solve_leg(task)
                m, b = legs.leg_model(task)
                # the cost of the kept run, evaluated in a fresh model of the task
                for var, vals in ((b.s, run.s), (b.v, run.v)):
                    for j in b.K:
                        var[j].set_value(float(vals[j]))
                for var, vals in ((b.ft, run.ft), (b.fb, run.fb)) + (() if b.fr.is_reference() else ((b.fr, run.fr),)):
                    for j in b.I:
                        var[j].set_value(float(vals[j]) / 1e3)
                costs.append(float(pyo.value(m.objective)))
            except Exception as exc:  # a failed leg: noted
                costs.append(float("nan"))
                print("   failed", task[1], exc)
            its.append(sum(ITERATIONS[n0:]))
        legs.KKT.clear()
        legs.KKT.update(saved)
        cpu = time.process_time() - c0
        costs = np.array(costs)
        line = f"{json.dumps(variant):70s} iterations {sum(its):6d} solves {len(ITERATIONS):4d} cpu {cpu:6.1f}"
        if base_costs is None:
            base_costs, base_its = costs, its
        else:
            rel = (costs - base_costs) / np.maximum(np.abs(base_costs), 1e-9)
            line += (f" costs lower/equal/higher (0.1 %) {np.sum(rel < -1e-3)}/{np.sum(np.abs(rel) <= 1e-3)}/"
                     f"{np.sum(rel > 1e-3)} largest rise {signed(100 * np.nanmax(rel), 2)} % sum cost {np.nansum(costs):.5f} "
                     f"vs {np.nansum(base_costs):.5f}")
        print(line, flush=True)
        if a.per_task:
            print("    ", its)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("mode", choices=("dump", "audit", "replay"))
    p.add_argument("study", nargs="?")
    p.add_argument("strategies", nargs="*")
    p.add_argument("--tasks", required=True)
    p.add_argument("--which", type=int, nargs="*", default=[])
    p.add_argument("--variant", action="append", default=[])
    p.add_argument("--per-task", action="store_true")
    a = p.parse_args()
    {"dump": dump, "audit": audit, "replay": replay}[a.mode](a)


if __name__ == "__main__":
    main()
