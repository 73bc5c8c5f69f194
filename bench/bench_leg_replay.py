"""A network study's leg tasks recorded once, then replayed under a variant of the leg solve.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_replay.py record studies/network_regional_20stops.yaml \
        receptivity dissension --out TASKS.pkl
    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_replay.py pick --tasks TASKS.pkl dissension --dearest 30 \
        --typical 30 > PICK
    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_replay.py replay --tasks TASKS.pkl --which $(cat PICK) \
        [--variant NAME] [--leg-options JSON] [--warm-options JSON] [--per-task]

``diagnose``: per strategy, what its tasks' NLPs hold (the weights' range and change per step, the
one-handle steps, the allowance and credit hinges and how many of them the kept run lies within five
kW of, the start's cost above the kept run's) and their correlation with the iterations.
Variants: ``penalty:K`` (the one-handle rows replaced by K [kW per kN^2] x F_T F_B in the cost),
``warmpen:K`` (that penalty added, the rows lifted in warm solves only), ``floor:F`` (the rows
F x 1e-3 <= F_T F_B <= 1e-3, the start lifted onto the curve), ``smooth:KW`` (the cost's maxima
smoothed over KW kW instead of exact, with no tie-break: the legs' cost before ``legs.leg_cost``
kept them exact, at KW = 10), ``tie:E`` (``legs.TIE_BREAK`` = E; 0: the exact maxima alone). A
variant's cost is the one its solves minimise and every cost it evaluates.

``record``: plays the independent runs and the named strategies as ``ecostudy network --workers 1``
does in one process and keeps every leg task it solves (``legs.solve_leg``'s argument: the leg, its
start, weights, allowance, credit, train ahead) with its strategy, supervisor round, the Ipopt
iterations of each of its solves, CPU seconds and the run it kept. ``pick``: the indices of a
strategy's dearest tasks (most iterations) and of tasks spread evenly over the rest. ``replay``:
solves the chosen tasks again as ``legs.solve_leg`` does under a variant (``--variant``: a named
change of the leg NLP or its solve, :data:`VARIANTS`; ``--leg-options``/``--warm-options``: Ipopt
options added to ``legs.KKT``/``legs.NEAR_START``), and prints per task and in sum its iterations,
CPU seconds, its cost (the task's objective at the kept run, evaluated in a fresh model of the task
as written) and the run's net pantograph energy [kWh], each against the recorded run. Iterations,
costs and energies do not depend on the machine; seconds do.
"""
import argparse
import collections
import json
import pickle
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.ocp import solver  # noqa: E402

solver.configure()

import pyomo.environ as pyo  # noqa: E402

from ecostudy.network import fleet as fleets, legs, rules  # noqa: E402
from ecostudy.core.physics import hinge  # noqa: E402
from ecostudy.ocp import session, timedomain  # noqa: E402

from bench.bench_leg_rounds import ITERATIONS, noted_session  # noqa: E402  (each solve's iterations noted)

NOW = {"strategy": "independent", "round": 1}


def cost_of(task, run):
    """The task's objective (as ``legs.leg_model`` writes it) at ``run``."""
    m, b = PLAIN_LEG_MODEL(task)
    for var, vals in ((b.s, run.s), (b.v, run.v)):
        for j in b.K:
            if not var[j].fixed:
                var[j].set_value(float(vals[j]))
    forces = ((b.ft, run.ft), (b.fb, run.fb)) + (() if b.fr.is_reference() else ((b.fr, run.fr),))
    for var, vals in forces:
        for j in b.I:
            var[j].set_value(float(vals[j]) / 1e3)
    legs.start_maxima(b)  # the cost's exact maxima at the run (none under ``smooth``)
    return float(pyo.value(m.objective))


def energy_kwh(task, run):
    """Net pantograph energy of a leg's run [kWh]."""
    return float(np.sum(run.p)) * task[2] / 3.6e6


def record(a):
    from ecostudy.network.strategies import one_strategy, solve_independent
    from ecostudy.studies.network import expand_network
    kept = []
    plain_leg, plain_train = fleets.solve_leg, rules.solve_train
    calls = collections.Counter()

    def leg(task):
        ITERATIONS.clear()
        c0 = time.process_time()
        run, outcome = plain_leg(task)
        kept.append({**NOW, "task": task, "iterations": list(ITERATIONS), "cpu_s": time.process_time() - c0,
                     "run": run, "status": outcome.status})
        return run, outcome

    def train(fleet, i, *args, **kw):
        calls[(NOW["strategy"], i)] += 1
        NOW["round"] = calls[(NOW["strategy"], i)]
        return plain_train(fleet, i, *args, **kw)

    session.Session.solve = noted_session(session.Session.solve)
    fleets.solve_leg, rules.solve_train = leg, train
    with tempfile.TemporaryDirectory() as out:
        fleet = expand_network(a.study, out=out).cases[0]["fleet"]
        ind, wall = solve_independent(fleet)
        for name in a.strategies:
            NOW.update(strategy=name, round=1)
            res = one_strategy(fleet, name, ind, wall)
            print(name, res.get("totals", {}).get("substation_kWh"), (res.get("info") or {}).get("rounds_substation_kWh"),
                  flush=True)
    Path(a.out).write_bytes(pickle.dumps(kept))
    for strategy in ["independent", *a.strategies]:
        its = [sum(k["iterations"]) for k in kept if k["strategy"] == strategy]
        print(f"{strategy:12s} tasks {len(its)} iterations {sum(its)}")


def pick(a):
    kept = pickle.loads(Path(a.tasks).read_bytes())
    mine = [(sum(k["iterations"]), n) for n, k in enumerate(kept) if k["strategy"] == a.strategy]
    mine.sort(reverse=True)
    dear = [n for _, n in mine[:a.dearest]]
    rest = mine[a.dearest:]
    step = max(len(rest) // max(a.typical, 1), 1)
    typical = [n for _, n in rest[::step][:a.typical]]
    print(" ".join(str(n) for n in sorted(dear + typical)))


NEAR = 50.0  # [kW] a max of the cost whose argument is within this of 0 at the kept run is near its kink


def diagnose(a):
    """Per strategy (and per chosen task), what its leg NLPs hold: weights' range and step-to-step
    change, one-handle steps, allowance and credit hinges, the start's cost against the kept run's."""
    kept = pickle.loads(Path(a.tasks).read_bytes())
    which = a.which or range(len(kept))
    per = collections.defaultdict(list)
    for n in which:
        k = kept[n]
        leg, _, dt, _, guess, warm, weights, allowance, credit, ahead = k["task"]
        span = slice(leg.start, leg.start + leg.steps)
        own = [None if x is None else np.asarray(x, float)[span] for x in (weights, allowance, credit)]
        omega, alpha, at, rho, eta, c = legs.cost_coefficients(leg, weights, allowance, credit)
        w = own[0] if own[0] is not None else np.ones(leg.steps)
        held = np.broadcast_to(np.asarray(legs.pumping_pays(leg.case.train, *own)), (leg.steps,))
        run = k["run"]
        start = legs.LegNLP(k["task"])
        start_cost = float(pyo.value(start.model.objective))
        cost = cost_of(k["task"], run)
        traction = run.p > 0
        row = {"n": n, "strategy": k["strategy"], "round": k["round"], "label": k["task"][1], "warm": str(warm),
               "steps": leg.steps, "iterations": sum(k["iterations"]), "solves": len(k["iterations"]),
               "w_min": float(w.min()), "w_mean": float(w.mean()), "dw_mean": float(np.mean(np.abs(np.diff(w)))),
               "one_handle": int(held.sum()), "alpha_rows": int(np.sum(alpha != 0)), "eta_rows": int(np.sum(eta != 0)),
               "rho_rows": int(np.sum(rho != 0)),
               # maxima near their kink at the kept run (within NEAR kW)
               "alpha_near": int(np.sum((alpha != 0) & (np.abs(run.p / 1e3 - at) < NEAR) & traction)),
               "eta_near": int(np.sum((eta != 0) & (np.abs(-run.p / 1e3 - c) < NEAR) & ~traction)),
               "start_cost": start_cost, "cost": cost,
               "start_gap_pct": 100 * (start_cost - cost) / max(abs(cost), 1e-9)}
        per[k["strategy"]].append(row)
        if a.per_task:
            print(json.dumps(row), flush=True)
    for name, rows in per.items():
        print(f"{name}: {len(rows)} tasks")
        for key in ("steps", "iterations", "w_min", "w_mean", "dw_mean", "one_handle", "alpha_rows", "eta_rows",
                    "rho_rows", "alpha_near", "eta_near", "start_gap_pct"):
            v = np.array([r[key] for r in rows], float)
            print(f"   {key:14s} median {np.median(v):9.4g}  p10 {np.percentile(v, 10):9.4g}  p90 {np.percentile(v, 90):9.4g}"
                  f"  mean {v.mean():9.4g}")
        its = np.array([r["iterations"] for r in rows], float)
        for key in ("one_handle", "alpha_rows", "eta_rows", "alpha_near", "dw_mean", "start_gap_pct", "steps"):
            v = np.array([r[key] for r in rows], float)
            if v.std() > 0:
                print(f"   corr(iterations, {key}) {np.corrcoef(its, v)[0, 1]:+.2f}")


PLAIN_LEG_MODEL = legs.leg_model  # the leg NLP as written: every cost is evaluated in it (``cost_of``)


def warm_penalty(k):
    """Variant ``warmpen:K``: K [kW per kN^2] x F_T F_B added to the cost of each one-handle step
    and the rows kept; a warm solve lifts the rows (upper bound ``LIFTED``) and leaves the
    complementarity to the penalty, a cold one solves with the rows as ``legs._relaxed_first`` does."""
    def leg_model(task):
        m, b = PLAIN_LEG_MODEL(task)
        rows = getattr(b, "one_handle", None)
        if rows is not None and len(rows):
            obj = m.objective.expr
            m.del_component(m.objective)
            scale = task[2] / legs.leg_energy_ref(task[0])
            m.objective = pyo.Objective(expr=obj + k * scale * sum(b.ft[j] * b.fb[j] for j in rows.keys()))
        return m, b
    legs.leg_model = leg_model
    plain = legs._solve

    def solve(nlp, cold=False, retry=True):
        if cold or not nlp.task[5] or not nlp.relax(LIFTED):
            return plain(nlp, cold, retry)
        try:
            return plain(nlp, cold, retry)
        finally:
            nlp.relax(timedomain.ONE_HANDLE)
    legs._solve = solve


LIFTED = 1e6  # [kN^2] a one-handle row's upper bound where the penalty holds the forces apart


def one_handle_penalty(k):
    """Variant ``penalty:K``: the one-handle rows left out, K [kW per kN^2] x F_T F_B added to the
    cost of each step that held one (an exact penalty of the complementarity where a force is
    positive; from both at 0, pumping dF = gain / (2 K) pays: below 0.02 kN at K = 1000)."""
    def leg_model(task):
        m, b = PLAIN_LEG_MODEL(task)
        rows = getattr(b, "one_handle", None)
        if rows is not None and len(rows):
            idx = list(rows.keys())
            b.del_component(rows)
            obj = m.objective.expr
            m.del_component(m.objective)
            scale = task[2] / legs.leg_energy_ref(task[0])
            m.objective = pyo.Objective(expr=obj + k * scale * sum(b.ft[j] * b.fb[j] for j in idx))
        return m, b
    return leg_model


def lift(b, steps, product):
    """Set a leg block's F_T, F_B at ``steps`` onto F_T F_B = ``product`` [kN^2] keeping F_T - F_B:
    F_T = hinge(u, e), F_B = hinge(-u, e) with u = F_T - F_B, e^2 / 4 = product."""
    width = 2.0 * product ** 0.5
    for j in steps:
        u = b.ft[j].value - b.fb[j].value
        b.ft[j].set_value(min(float(hinge(u, width)), b.ft[j].ub))
        b.fb[j].set_value(min(float(hinge(-u, width)), b.fb[j].ub))


def one_handle_floor(fraction):
    """Variant ``floor:F``: the one-handle rows F x 1e-3 <= F_T F_B <= 1e-3 kN^2 (a smoothing of the
    complementarity instead of its relaxation: F_T and F_B never reach their bound 0 on those steps),
    every start lifted onto F_T F_B = (1 + F) / 2 x 1e-3 (:func:`lift`)."""
    low = fraction * timedomain.ONE_HANDLE
    target = 0.5 * (1.0 + fraction) * timedomain.ONE_HANDLE

    def leg_model(task):
        m, b = PLAIN_LEG_MODEL(task)
        rows = getattr(b, "one_handle", None)
        if rows is not None and len(rows):
            for j, row in rows.items():
                row.set_value((low, b.ft[j] * b.fb[j], timedomain.ONE_HANDLE))
            lift(b, list(rows.keys()), target)
        return m, b
    legs.leg_model = leg_model
    plain_start = legs.LegNLP.start

    def start(self, cold):
        fresh = cold and self.cold is None
        x = plain_start(self, cold)
        rows = getattr(self.block, "one_handle", None)
        if fresh and rows is not None and len(rows):
            lift(self.block, list(rows.keys()), target)
            self.cold = np.array([var.value for var in self.session.variables], dtype=float)
            x = self.cold
        return x
    legs.LegNLP.start = start


def smoothed_cost(kw):
    """Variant ``smooth:KW``: the leg's cost with each max smoothed over KW kW (``physics.hinge``)
    and no tie-break, in the solves and in every evaluated cost."""
    def leg_cost(b, coefficients):
        omega, alpha, a, rho, eta, c = np.asarray(coefficients, float).tolist()
        out = sum(omega[j] * b.traction_kw[j] - rho[j] * b.regen_kw[j] for j in b.I)
        out = out + sum(alpha[j] * hinge(b.traction_kw[j] - a[j], kw) for j in b.I if alpha[j] != 0.0)
        return out + sum(eta[j] * hinge(b.regen_kw[j] - c[j], kw) for j in b.I if eta[j] != 0.0)
    legs.leg_cost = leg_cost
    legs.TIE_BREAK = 0.0  # the one-handle rows where they paid without it (``legs.pumping_pays``)


VARIANTS = {  # name -> function(arg) that patches the leg solve
    "penalty": lambda arg: setattr(legs, "leg_model", one_handle_penalty(float(arg))),
    "smooth": lambda arg: smoothed_cost(float(arg)),
    "tie": lambda arg: setattr(legs, "TIE_BREAK", float(arg)),
    "warmpen": lambda arg: warm_penalty(float(arg)),
    "floor": lambda arg: one_handle_floor(float(arg)),
}


def replay(a):
    kept = pickle.loads(Path(a.tasks).read_bytes())
    which = a.which or range(len(kept))
    legs.KKT.update(json.loads(a.leg_options))
    legs.NEAR_START.update(json.loads(a.warm_options))
    if a.variant:
        name, _, arg = a.variant.partition(":")
        VARIANTS[name](arg)
    session.Session.solve = noted_session(session.Session.solve)
    rows = []
    for n in which:
        k = kept[n]
        task = k["task"]
        ITERATIONS.clear()
        c0 = time.process_time()
        try:
            run, outcome = legs.solve_leg(task)
            status = outcome.status
        except Exception as exc:  # a failed leg: noted
            run, status = None, f"failed: {exc}"
        cpu = time.process_time() - c0
        old_cost, old_e = cost_of(task, k["run"]), energy_kwh(task, k["run"])
        cost = cost_of(task, run) if run is not None else float("nan")
        e = energy_kwh(task, run) if run is not None else float("nan")
        rows.append((n, sum(k["iterations"]), sum(ITERATIONS), k["cpu_s"], cpu, old_cost, cost, old_e, e))
        if a.per_task:
            print(f"{n:4d} {k['strategy'][:5]} r{k['round']} {task[1]:18s} warm={str(task[5]):7s} it {sum(k['iterations']):4d} -> "
                  f"{sum(ITERATIONS):4d} {ITERATIONS} cpu {cpu:5.1f} cost {old_cost:.5f} -> {cost:.5f} "
                  f"({100 * (cost - old_cost) / max(abs(old_cost), 1e-9):+.2f} %) kWh {old_e:.4f} -> {e:.4f} {status}",
                  flush=True)
    r = np.array([row[1:] for row in rows], float)
    rel = (r[:, 5] - r[:, 4]) / np.maximum(np.abs(r[:, 4]), 1e-9)
    print(f"tasks {len(rows)} iterations {r[:, 0].sum():.0f} -> {r[:, 1].sum():.0f} ({100 * (r[:, 1].sum() / r[:, 0].sum() - 1):+.1f} %) "
          f"cpu {r[:, 3].sum():.1f} s (recorded {r[:, 2].sum():.1f}) costs lower/equal/higher (0.1 %) "
          f"{np.sum(rel < -1e-3)}/{np.sum(np.abs(rel) <= 1e-3)}/{np.sum(rel > 1e-3)} largest rise "
          f"{100 * np.nanmax(rel):+.2f} % largest fall {100 * np.nanmin(rel):+.2f} % sum cost {np.nansum(r[:, 4]):.4f} -> "
          f"{np.nansum(r[:, 5]):.4f} energy {np.nansum(r[:, 6]):.3f} -> {np.nansum(r[:, 7]):.3f} kWh", flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="mode", required=True)
    r = sub.add_parser("record")
    r.add_argument("study")
    r.add_argument("strategies", nargs="+")
    r.add_argument("--out", required=True)
    k = sub.add_parser("pick")
    k.add_argument("strategy")
    k.add_argument("--tasks", required=True)
    k.add_argument("--dearest", type=int, default=30)
    k.add_argument("--typical", type=int, default=30)
    y = sub.add_parser("replay")
    y.add_argument("--tasks", required=True)
    y.add_argument("--which", type=int, nargs="*", default=[])
    y.add_argument("--variant", help="NAME[:ARG] of VARIANTS")
    y.add_argument("--leg-options", default="{}")
    y.add_argument("--warm-options", default="{}")
    y.add_argument("--per-task", action="store_true")
    d = sub.add_parser("diagnose")
    d.add_argument("--tasks", required=True)
    d.add_argument("--which", type=int, nargs="*", default=[])
    d.add_argument("--per-task", action="store_true")
    a = p.parse_args()
    {"record": record, "pick": pick, "replay": replay, "diagnose": diagnose}[a.mode](a)


if __name__ == "__main__":
    main()
