"""Supervisor rules of a network study, each leg's one-handle constraint where doing both could pay
(``legs.pumping_pays``, what the legs do) against at every step (what they did before), in one process.

    .venv/bin/python bench/bench_rules.py studies/network_metro_2trains.yaml
        [--rules receptivity triggering voltage dissension] [--variants everywhere pays]

Per rule and variant: wall seconds of the supervisor rounds (``rules.supervised``, three rounds,
legs serially), Ipopt iterations summed over the leg solves, the number of solves and the
substation energy of each round (the start first).
"""
import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from bench.bench_leg_options import study_fleet  # noqa: E402
from ecostudy.network import legs, rules  # noqa: E402
from ecostudy.ocp import session  # noqa: E402

PAYS = legs.pumping_pays


def everywhere(train, weights=None, allowance=None, credit=None):
    """The earlier rule: the constraint at every step of a leg with weights (the rules' legs)."""
    return weights is not None


@harness.case("rules.supervised", setup=lambda p: (study_fleet(p["study"]), p),
              params={"study": str(ROOT / "studies/network_metro_3trains.yaml"), "rule": "receptivity"})
def supervised(state):
    """A supervisor rule's rounds (Farooqi 2018 Ch. 7) from the independent runs: rounds, substation energy."""
    fl, p = state
    _, history, _, _ = rules.supervised(fl, p["rule"], rules.independent(fl))
    return {"rounds": len(history), "substation_kWh": history[-1]}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study")
    p.add_argument("--rules", nargs="+", default=["receptivity", "triggering", "voltage", "dissension"])
    p.add_argument("--variants", nargs="+", default=["everywhere", "pays"], choices=["everywhere", "pays"])
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    fl = study_fleet(args.study)
    counts = []
    solve = session.Session.solve

    def counted(self, options=None, x0=None):
        out = solve(self, options, x0)
        counts.append(out.iterations)
        return out

    session.Session.solve = counted
    start = rules.independent(fl)
    table = harness.Table(["rule", "one-handle", "wall s", "Ipopt iterations", "leg solves", "rounds (substation kWh)"])
    for rule in args.rules:
        for variant in args.variants:
            legs.pumping_pays = PAYS if variant == "pays" else everywhere
            counts.clear()
            (_, history, _, _), _, wall = harness.timed(lambda: rules.supervised(fl, rule, start))
            table.add(rule, variant, f"{wall:.1f}", sum(counts), len(counts), ", ".join(f"{h:.3f}" for h in history))
    legs.pumping_pays = PAYS


if __name__ == "__main__":
    main()
