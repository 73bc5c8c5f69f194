"""A network study's leg tasks round by round, one strategy at a time in one process.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_rounds.py studies/network_metro_3trains.yaml \
        receptivity triggering voltage dissension joint following [--tasks FILE] [--terms FILE]

Plans the study's fleet, solves the independent runs, then each named strategy from them as
``ecostudy network --workers 1`` does (``strategies.one_strategy``), noting every leg task solved
(``legs.solve_leg``): its strategy, supervisor round (the how-manieth ``solve_train`` of its train
in the strategy), leg, start (cold, warm, checked), Ipopt iterations of each of its solves and CPU
seconds. Prints per strategy its substation energy per round [kWh], CPU seconds, and per round the
tasks, solves, iterations and CPU seconds of its leg tasks, the iterations of the checked legs'
cold solves, and the tasks handed over from another strategy (``network.shared``). ``--terms
FILE``: per supervised leg task, whether the NLP's data (``legs.cost_coefficients``, the one-handle
steps, the train ahead on the leg's steps) are those of the same leg's previous task in the
strategy, and on how many steps they differ (JSON). Iterations and energies do not depend on the
machine; seconds do.
"""
import argparse
import collections
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.ocp import solver  # noqa: E402

solver.configure()

from ecostudy.network import fleet as fleets, legs, rules  # noqa: E402
from ecostudy.network.strategies import one_strategy, solve_independent  # noqa: E402
from ecostudy.ocp import session  # noqa: E402
from ecostudy.studies.network import expand_network  # noqa: E402

NOW = {"strategy": "independent", "round": 1}
TASKS: list = []  # one dict per leg task solved
TERMS: list = []  # one dict per supervised leg task posed
ITERATIONS: list = []  # the Ipopt iterations of the task being solved


def noted_session(solve):
    def wrapper(self, options=None, x0=None):
        out = solve(self, options, x0)
        ITERATIONS.append(out.iterations)
        return out
    return wrapper


def noted_leg(solve_leg):
    def wrapper(task):
        ITERATIONS.clear()
        c0 = time.process_time()
        run, outcome = solve_leg(task)
        TASKS.append({**NOW, "label": task[1], "warm": str(task[5]), "iterations": list(ITERATIONS),
                      "cpu_s": time.process_time() - c0})
        return run, outcome
    return wrapper


def nlp_data(leg, weights, allowance, credit, ahead):
    """(cost coefficients, one-handle steps, the train ahead on the leg's steps) of a leg task."""
    span = slice(leg.start, leg.start + leg.steps)
    own = [None if a is None else np.asarray(a, float)[span] for a in (weights, allowance, credit)]
    return (legs.cost_coefficients(leg, weights, allowance, credit),
            np.asarray(legs.pumping_pays(leg.case.train, *own)),
            None if ahead is None else np.asarray(ahead, float)[leg.start:leg.start + leg.steps + 1])


def noted_train(solve_train, calls, last):
    def wrapper(fleet, i, weights=None, guesses=None, ahead=None, allowance=None, credit=None, **kw):
        calls[(NOW["strategy"], i)] += 1
        NOW["round"] = calls[(NOW["strategy"], i)]
        for k, leg in enumerate(fleet.legs[i]):
            data = nlp_data(leg, weights, allowance, credit, ahead)
            old = last.get((NOW["strategy"], i, k))
            if old is not None:
                TERMS.append({**NOW, "train": i, "leg": k,
                              "cost_same": bool(np.array_equal(old[0], data[0])),
                              "cost_steps_changed": int(np.sum(np.any(old[0] != data[0], axis=0))),
                              "one_handle_same": bool(np.array_equal(old[1], data[1])),
                              "ahead_same": (old[2] is None) == (data[2] is None) and (
                                  data[2] is None or bool(np.array_equal(old[2], data[2], equal_nan=True)))})
            last[(NOW["strategy"], i, k)] = data
        return solve_train(fleet, i, weights=weights, guesses=guesses, ahead=ahead, allowance=allowance,
                           credit=credit, **kw)
    return wrapper


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study")
    p.add_argument("strategies", nargs="+")
    p.add_argument("--tasks", help="JSON file: every leg task solved")
    p.add_argument("--terms", help="JSON file: per supervised leg task, whether its NLP's data changed")
    a = p.parse_args()
    session.Session.solve = noted_session(session.Session.solve)
    fleets.solve_leg = noted_leg(fleets.solve_leg)
    rules.solve_train = noted_train(fleets.solve_train, collections.Counter(), {})
    with tempfile.TemporaryDirectory() as out:
        fleet = expand_network(a.study, out=out).cases[0]["fleet"]
        c0 = time.process_time()
        ind, wall = solve_independent(fleet)
        print(f"independent  cpu {time.process_time() - c0:6.1f}", flush=True)
        for name in a.strategies:
            NOW.update(strategy=name, round=1)
            hits, c0 = fleet.solved.hits, time.process_time()
            res = one_strategy(fleet, name, ind, wall)
            cpu = time.process_time() - c0
            rounds = (res.get("info") or {}).get("rounds_substation_kWh")
            kwh = res.get("totals", {}).get("substation_kWh")
            print(f"{name:12s} kWh {kwh if kwh is None else round(kwh, 3)} cpu {cpu:6.1f} handed over "
                  f"{fleet.solved.hits - hits}" + (f" rounds {[round(r, 3) for r in rounds]}" if rounds else ""),
                  flush=True)
            if res.get("info", {}).get("rounds_stopped"):
                print(f"{'':12s} {res['info']['rounds_stopped']}", flush=True)
    per = collections.defaultdict(lambda: collections.Counter())
    for t in TASKS:
        c = per[(t["strategy"], t["round"])]
        c.update(tasks=1, solves=len(t["iterations"]), iterations=sum(t["iterations"]), cpu_s=t["cpu_s"],
                 checked_cold_iterations=sum(t["iterations"][1:]) if t["warm"] == "checked" else 0)
    for (name, number), c in per.items():
        print(f"{name:12s} round {number}: {c['tasks']} tasks, {c['solves']} solves, {c['iterations']} iterations "
              f"({c['checked_cold_iterations']} in checked legs' cold solves), {c['cpu_s']:.1f} CPU s", flush=True)
    if TERMS:
        same = sum(t["cost_same"] and t["one_handle_same"] and t["ahead_same"] for t in TERMS)
        print(f"supervised leg tasks after their first: {len(TERMS)}, NLP data unchanged {same}, cost unchanged "
              f"{sum(t['cost_same'] for t in TERMS)}; cost rows changed on a median "
              f"{np.median([t['cost_steps_changed'] for t in TERMS]):.0f} steps")
    if a.tasks:
        Path(a.tasks).write_text(json.dumps(TASKS))
    if a.terms:
        Path(a.terms).write_text(json.dumps(TERMS))


if __name__ == "__main__":
    main()
