"""Warm network legs started from their previous run's multipliers too, against the primal start alone.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_warm_duals.py studies/network_metro_3trains.yaml \
        triggering [receptivity ...] [--variants 1e-3:1e-6 1e-4:1e-6 1e-5:1e-6 1e-4:1e-9 1e-5:1e-9]
        [--partial] [--carry [MU:PUSH]]

Plays each named strategy as ``ecostudy network`` does (``strategies.one_strategy``, one process),
noting the multipliers (constraint duals, lower and upper bound duals) of the solve behind every leg
run and every warm leg task (a leg started from its previous run). Then each warm task's NLP is
written once and solved, alternating in this process: (a) as the strategy solves it (the legs' own
``near_start`` + ``leg`` options, primal start), (b) per variant ``MU:PUSH``, the same primal start
with the previous run's multipliers, ``warm_start_init_point yes``, ``mu_init`` MU and every
``warm_start_*_bound_push`` / ``_frac`` PUSH. The multipliers apply only where the previous run's
NLP has the same variables and rows (by name, put in this NLP's order: a leg's one-handle rows and
separation rows may come and go between rounds); else the task is counted as primal only and (b)
is (a), not solved again.
``--partial``: where only rows differ, the rows both have keep their multipliers, new rows start at 0.

``--carry MU:PUSH`` plays the strategies only, each warm solve whose previous run's multipliers fit
made from them (where that fails, as the legs are: primal start, then Ipopt's defaults);
``--carry`` alone plays them as they are: substation kWh per round, the legs' Ipopt iterations and
CPU seconds.

Per variant: Ipopt iterations over the tasks (exact), CPU seconds of the solves (this process,
inflated on a busy machine), solves that failed (not usable), and each task's cost against (a):
how many lower, equal within 0.1 %, higher, and the largest rise.
"""
import argparse
import hashlib
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyomo.environ as pyo

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.core.units import signed  # noqa: E402
from ecostudy.ocp import solver  # noqa: E402

solver.configure()

from ecostudy.network import fleet, legs  # noqa: E402
from ecostudy.ocp import timedomain  # noqa: E402
from ecostudy.network.strategies import one_strategy, solve_independent  # noqa: E402
from ecostudy.studies.network import expand_network  # noqa: E402

DUALS: dict = {}   # run key -> ((variable names, row names), (mult_g, z_L, z_U)) of the solve that gave that run
TASKS: list = []   # (strategy, warm task) in the order solved
MISSES = [0, 0]    # warm tasks whose previous run was not noted, whose NLP differs
PLAYED = {"iterations": 0, "cpu_s": 0.0, "carried": 0, "failed": 0}  # a strategy's leg solves (``--carry``)


def run_key(arrays):
    """A leg run's identity by value (the independent runs reach the rounds as deep copies)."""
    digest = hashlib.sha1()
    for a in arrays[:5]:
        digest.update(np.ascontiguousarray(a, dtype=float).tobytes())
    return digest.hexdigest()


def names(nlp):
    """The NLP's variables and rows by name, in its order (the NL writer puts the nonlinear variables
    first: a cost term that vanishes between rounds reorders the same variables)."""
    p = nlp.session.nlp
    return tuple(p.primals_names()), tuple(p.constraint_names())


def fitted(known, nlp, partial=False):
    """The multipliers noted with a previous run, ordered for ``nlp``; None unless it has the same
    variables and rows (in any order). ``partial``: rows of ``nlp`` the previous NLP lacks (the
    one-handle and separation rows that come and go) start at 0, the rows it had and ``nlp`` lacks
    are dropped; the variables must still be the same."""
    (columns, rows), (mult_g, z_l, z_u) = known
    here = names(nlp)
    if set(here[0]) != set(columns) or (set(here[1]) != set(rows) and not partial):
        return None
    place = [{name: i for i, name in enumerate(old)} for old in (columns, rows)]
    col = np.array([place[0][name] for name in here[0]], dtype=int)
    g = np.array([mult_g[place[1][name]] if name in place[1] else 0.0 for name in here[1]])
    return g, z_l[col], z_u[col]


def noting(solve_one, carry=None):
    """``legs._solve`` noting the multipliers behind each run; ``carry`` (MU:PUSH): a warm solve
    whose previous run's multipliers fit is made from them first (:func:`options`), and where that
    fails as the legs are (primal start, then Ipopt's defaults)."""
    def wrapper(nlp, cold=False, retry=True):
        known = DUALS.get(run_key(nlp.task[4])) if carry and nlp.task[5] and not cold else None
        duals = fitted(known, nlp) if known is not None else None
        out = None
        if duals is not None:
            nlp.session.multipliers = duals
            outcome = nlp.solve(options(*map(float, carry.split(":"))), nlp.own)
            if outcome.usable:
                out = timedomain.leg_arrays(nlp.block), outcome, float(pyo.value(nlp.model.objective))
            PLAYED["carried"] += 1
            PLAYED["failed"] += not outcome.usable
        out = out or solve_one(nlp, cold, retry=retry)
        DUALS[run_key(out[0])] = (names(nlp), tuple(np.array(a, float) for a in nlp.session.multipliers))
        return out
    return wrapper


def counting(solve_one):
    """``LegNLP.solve`` adding its Ipopt iterations and CPU seconds to :data:`PLAYED`."""
    def wrapper(self, opts, x0=None):
        c0 = time.process_time()
        out = solve_one(self, opts, x0)
        PLAYED["iterations"] += out.iterations
        PLAYED["cpu_s"] += time.process_time() - c0
        return out
    return wrapper


def keeping(solve_leg, name):
    def wrapper(task):
        if task[5]:
            TASKS.append((name[0], task))
        return solve_leg(task)
    return wrapper


def options(mu, push):
    warm = {"warm_start_init_point": "yes", "mu_init": mu}
    for key in ("warm_start_bound_push", "warm_start_bound_frac", "warm_start_mult_bound_push",
                "warm_start_slack_bound_push", "warm_start_slack_bound_frac"):
        warm[key] = push
    return {**legs.NEAR_START, **legs.KKT, **warm}


def solve(nlp, opts, duals):
    """(iterations, CPU s, cost, usable) of one solve of ``nlp`` from its own start."""
    nlp.session.multipliers = duals
    c0 = time.process_time()
    out = nlp.solve(opts, nlp.own)
    return out.iterations, time.process_time() - c0, float(pyo.value(nlp.model.objective)), out.usable


def replay(tasks, variants, partial=False):
    """Per variant name: list of (iterations, CPU s, cost, usable, multipliers applied) per task."""
    rows = {"a": []} | {v: [] for v in variants}
    MISSES[:] = [0, 0]
    for n, (_, task) in enumerate(tasks):
        nlp = legs.LegNLP(task)
        known = DUALS.get(run_key(task[4]))
        duals = fitted(known, nlp, partial) if known is not None else None
        fits = duals is not None
        MISSES[0 if known is None else 1] += not fits
        order = ["a"] + list(variants) if fits else ["a"]
        order = order[n % len(order):] + order[:n % len(order)]  # alternate who goes first
        for v in order:
            if v == "a":
                rows[v].append((*solve(nlp, {**legs.NEAR_START, **legs.KKT}, None), False))
            else:
                mu, push = map(float, v.split(":"))
                rows[v].append((*solve(nlp, options(mu, push), duals), True))
        if not fits:  # primal only: (b) is (a)
            for v in variants:
                rows[v].append(rows["a"][-1])
        print(f"  {task[1]:22s} fits {fits!s:5s} " + " ".join(f"{v} {rows[v][-1][0]:4d} it {signed(rows[v][-1][2], 5)}"
                                                           for v in rows), flush=True)
    return rows


def table(strategy, rows):
    base = rows["a"]
    print(f"\n{strategy}: {len(base)} warm legs, multipliers applied to {sum(r[4] for r in rows[list(rows)[-1]])}; "
          f"previous run not noted {MISSES[0]}, other variables or rows {MISSES[1]}")
    print("| variant | iterations | vs (a) | CPU s | failed | costs lower / within 0.1 % / higher | largest rise |")
    print("|---|---:|---:|---:|---:|---|---:|")
    it0 = sum(r[0] for r in base)
    for v, rs in rows.items():
        it = sum(r[0] for r in rs)
        rel = [(r[2] - b[2]) / max(abs(b[2]), 1e-9) for r, b in zip(rs, base)]
        lower = sum(x < -1e-3 for x in rel)
        higher = sum(x > 1e-3 for x in rel)
        name = "(a) primal start" if v == "a" else f"(b) mu_init {v.split(':')[0]}, push {v.split(':')[1]}"
        print(f"| {name} | {it} | {signed(100 * (it / it0 - 1), 1)} % | {sum(r[1] for r in rs):.1f} | "
              f"{sum(not r[3] for r in rs)} | {lower} / {len(rs) - lower - higher} / {higher} | "
              f"{signed(100 * max(rel, default=0.0), 3)} % |", flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study")
    p.add_argument("strategies", nargs="+")
    p.add_argument("--variants", nargs="+", default=["1e-3:1e-6", "1e-4:1e-6", "1e-5:1e-6", "1e-4:1e-9", "1e-5:1e-9"],
                   help="MU:PUSH per variant (b)")
    p.add_argument("--carry", nargs="?", const="none", default=None, metavar="MU:PUSH",
                   help="play the strategies only, warm legs from their previous run's multipliers where they fit "
                        "(MU:PUSH; 'none': as the strategies are): substation kWh, leg iterations, CPU s")
    p.add_argument("--partial", action="store_true",
                   help="multipliers also where rows came or went (new rows from 0), the variables the same")
    a = p.parse_args()
    carry = a.carry if a.carry != "none" else None
    legs._solve = noting(legs._solve, carry)
    legs.LegNLP.solve = counting(legs.LegNLP.solve)
    name = [""]
    fleet.solve_leg = keeping(fleet.solve_leg, name)
    with tempfile.TemporaryDirectory() as out:
        fl = expand_network(a.study, out=out).cases[0]["fleet"]
        ind, wall = solve_independent(fl)
        for strategy in a.strategies:
            name[0] = strategy
            PLAYED.update(iterations=0, cpu_s=0.0, carried=0, failed=0)
            res = one_strategy(fl, strategy, ind, wall)
            print(f"{strategy}: substation {res.get('totals', {}).get('substation_kWh')} kWh, "
                  f"rounds {res.get('info', {}).get('rounds_substation_kWh')}, leg solves {PLAYED}", flush=True)
        for strategy in a.strategies if a.carry is None else ():
            table(strategy, replay([t for t in TASKS if t[0] == strategy], a.variants, a.partial))


if __name__ == "__main__":
    main()
