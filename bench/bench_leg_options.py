"""Ipopt and MUMPS options on the legs of a network study's supervisor round, each leg's NLP written
once and solved with every option set in turn (alternating, so a busy machine slows all alike).

    .venv/bin/python bench/bench_leg_options.py studies/network_metro_3trains.yaml
        [--rule receptivity] [--legs 6] [--repeat 3] [--options "" "mumps_scaling=0" ...]

The legs are those the first round of ``--rule`` solves (from the independent runs, with the
rule's costs; warm solves keep ``legs.NEAR_START``). Per option set: Ipopt seconds summed over the
legs (median of the repeats), the ratio to the first set, the iterations per leg, and the largest
difference of a leg's cost from the first set's.
"""
import argparse
import shlex
import statistics
import sys
from pathlib import Path

import numpy as np
import pyomo.environ as pyo

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.io.loaders import load_network_study  # noqa: E402
from ecostudy.network import fleet, legs, rules  # noqa: E402
from ecostudy.ocp import session  # noqa: E402


def parse(text):
    """'a=1,b=x' -> {'a': 1, 'b': 'x'} (ints and floats as numbers)."""
    out = {}
    for item in filter(None, text.split(",")):
        key, value = item.split("=")
        for kind in (int, float):
            try:
                value = kind(value)
                break
            except ValueError:
                pass
        out[key] = value
    return out


def round_tasks(fl, rule):
    """The leg tasks (``legs.solve_leg``'s argument) of the first supervisor round of ``rule``."""
    start = rules.independent(fl)
    tasks = []
    solve = fleet.solve_leg

    def keep(task):
        tasks.append(task)
        return solve(task)

    fleet.solve_leg = keep
    try:
        rules.supervised(fl, rule, start, rounds=1)
    finally:
        fleet.solve_leg = solve
    return tasks


def sessions(tasks):
    """(session, start point, base options) per leg task: each NLP built and written once."""
    out = []
    for task in tasks:
        s = session.Session(legs.leg_model(task)[0])
        out.append((s, s.x.copy(), legs.NEAR_START if task[5] else {}))
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study")
    p.add_argument("--rule", default="receptivity")
    p.add_argument("--legs", type=int, default=6, help="the first N legs of the round")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--options", nargs="+", default=["", "mumps_scaling=0"],
                   help="option sets added to a warm leg's NEAR_START, each 'name=value,name=value' ('' for none)")
    args = p.parse_args()
    print(f"`python bench/bench_leg_options.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    st = load_network_study(Path(args.study))
    fl = fleet.plan(st.track, st.train, st.stops, st.running_times, st.dwell, st.offsets, st.names, st.dt,
                    st.supply, st.points, st.buffer, supplement=st.supplement)
    solved = sessions(round_tasks(fl, args.rule)[:args.legs])
    sets = [parse(text) for text in args.options]
    seconds = [[] for _ in sets]
    result = [None] * len(sets)
    for _ in range(args.repeat):
        for n, options in enumerate(sets):
            total, iterations, costs = 0.0, [], []
            for s, x0, base in solved:
                out = s.solve({**base, **options}, x0=x0)
                total += out.seconds
                iterations.append(out.iterations)
                costs.append(float(pyo.value(s.model.objective)))
            seconds[n].append(total)
            result[n] = (iterations, np.array(costs))
    reference = statistics.median(seconds[0])
    print("| options | Ipopt s (median) | ratio | iterations per leg | largest cost difference |")
    print("|---|---|---|---|---|")
    for text, times, (iterations, costs) in zip(args.options, seconds, result):
        diff = float(np.max(np.abs(costs - result[0][1])))
        print(f"| {text or 'none added'} | {statistics.median(times):.2f} | {statistics.median(times) / reference:.2f} "
              f"| {' / '.join(map(str, iterations))} | {diff:.1e} |")


if __name__ == "__main__":
    main()
