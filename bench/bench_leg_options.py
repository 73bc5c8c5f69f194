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
import functools
import sys
from pathlib import Path

import numpy as np
import pyomo.environ as pyo

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
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


def study_fleet(study):
    """The fleet of a network study file."""
    st = load_network_study(Path(study))
    return fleet.plan(st.track, st.train, st.stops, st.running_times, st.dwell, st.offsets, st.names, st.dt,
                      st.supply, st.points, st.buffer, supplement=st.supplement)


@functools.lru_cache(maxsize=2)
def prepared(study, rule, n):
    """(session, start point, base options) of the first ``n`` legs of ``rule``'s first round (shared by
    the option sets: each NLP written once)."""
    return sessions(round_tasks(study_fleet(study), rule)[:n])


def setup(p):
    return prepared(str(p["study"]), p["rule"], p["legs"]), parse(p["options"])


def solve_legs(state):
    """Every leg solved once with one option set: Ipopt seconds summed, iterations and cost per leg."""
    solved, options = state
    total, iterations, costs = 0.0, [], []
    for s, x0, base in solved:
        out = s.solve({**base, **options}, x0=x0)
        total += out.seconds
        iterations.append(out.iterations)
        costs.append(float(pyo.value(s.model.objective)))
    return {"ipopt_s": total, "iterations": " / ".join(map(str, iterations)), "costs": np.array(costs)}


def name(text):
    return "leg_options." + (text.replace("=", "_").replace(",", "+") or "none")


def register(text):
    """The case of one option set ('' for none added), against the set with none added."""
    return harness.register(name(text), solve_legs, setup=setup, reference=None if not text else name(""),
                            params={"study": str(ROOT / "studies/network_metro_3trains.yaml"), "rule": "receptivity",
                                    "legs": 6, "options": text},
                            doc=f"Ipopt seconds over the first legs of a supervisor round, options: {text or 'none added'}")


for _text in ("", "mumps_scaling=0"):
    register(_text)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study")
    p.add_argument("--rule", default="receptivity")
    p.add_argument("--legs", type=int, default=6, help="the first N legs of the round")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--options", nargs="+", default=["", "mumps_scaling=0"],
                   help="option sets added to a warm leg's NEAR_START, each 'name=value,name=value' ('' for none)")
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    names = [register(text).name for text in args.options]
    runs = harness.measure(names, args.repeat, {"study": args.study, "rule": args.rule, "legs": args.legs})
    first = runs[names[0]]
    table = harness.Table(["options", "Ipopt s (median)", "ratio", "iterations per leg", "largest cost difference"])
    for text, n in zip(args.options, names):
        diff = float(np.max(np.abs(runs[n].last("costs") - first.last("costs"))))
        table.add(text or "none added", f"{runs[n].median('ipopt_s'):.2f}",
                  f"{runs[n].median('ipopt_s') / first.median('ipopt_s'):.2f}", runs[n].last("iterations"), f"{diff:.1e}")


if __name__ == "__main__":
    main()
