"""ecostudy against published results: Yazhemsky 2017 Ch.9 trips (energy per unit mass).

    .venv/bin/python bench/compare_published.py [--points 1000]

Prints a markdown table: published arrival time and energy (tests/data/yazhemsky2017_published.csv)
beside ecostudy's energy-optimal run at the same time, with solver status and verification.
"""
import argparse
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    args = p.parse_args()
    train = load_train(ROOT / "trains/yazhemsky2017_commuter.yaml")
    table = harness.Table(["trip", "figure", "time s", "published J/kg", "ecostudy J/kg", "difference %", "status",
                           "verified"], show=False)
    for case in pd.read_csv(ROOT / "tests/data/yazhemsky2017_published.csv").to_dict("records"):
        track = load_track(ROOT / f"tracks/{case['track']}.yaml")
        r = solve_run(track, train, "A", "B", Timing(running_time=case["running_time_s"]), points=args.points)
        e = r.summary["traction_energy_J_per_kg"]
        pub = case["published_energy_J_per_kg"]
        table.add(case["track"], case["figure"], case["running_time_s"], f"{pub:.2f}", f"{e:.2f}",
                  signed(100 * (e / pub - 1), 1), r.summary["solver"]["status"], r.summary["verification"]["passed"])
    print(f"`python bench/compare_published.py --points {args.points}`\n")
    print(table.text())


if __name__ == "__main__":
    main()
