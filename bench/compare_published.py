"""ecostudy against published results: Yazhemsky 2017 Ch.9 trips (energy per unit mass).

    .venv/bin/python bench/compare_published.py [--points 1000]

Prints a markdown table: published arrival time and energy (tests/data/thesis001_published.csv)
beside ecostudy's energy-optimal run at the same time, with solver status and verification.
"""
import argparse
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    args = p.parse_args()
    train = load_train(ROOT / "trains/thesis001_commuter.yaml")
    rows = ["| trip | figure | time s | published J/kg | ecostudy J/kg | difference % | status | verified |",
            "|---|---|---|---|---|---|---|---|"]
    for case in pd.read_csv(ROOT / "tests/data/thesis001_published.csv").to_dict("records"):
        track = load_track(ROOT / f"tracks/{case['track']}.yaml")
        r = solve_run(track, train, "A", "B", Timing(running_time=case["running_time_s"]), points=args.points)
        e = r.summary["traction_energy_J_per_kg"]
        pub = case["published_energy_J_per_kg"]
        rows.append(f"| {case['track']} | {case['figure']} | {case['running_time_s']} | {pub:.2f} | {e:.2f} | "
                    f"{100 * (e / pub - 1):+.1f} | {r.summary['solver']['status']} | {r.summary['verification']['passed']} |")
    print(f"`python bench/compare_published.py --points {args.points}`\n")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
