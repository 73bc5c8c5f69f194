"""Heuristics against the optimum on the shipped cases: eco-drive coasting and MARECO-style.

    .venv/bin/python bench/bench_heuristics.py [--points 1000]

For each case and running time: the ATO optimum (traction energy), eco-drive coasting and the
MARECO-style heuristic (ecostudy/mareco.py), each re-simulated; gap to the optimum, arrival
error and wall time of the heuristic (the optimum's solve excluded).
"""
import argparse
import shlex
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.heuristics import ecodrive  # noqa: E402
from ecostudy.core.errors import InfeasibleError  # noqa: E402
from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402

CASES = [("amsterdam_metro", "amsterdam_rokin_centraal", "Rokin", "Centraal", (76.0, 80.0, 85.0, 90.0)),
         ("regional_alstom", "regional_808m", "Origin", "Destination", (80.0, 90.0)),
         ("thesis001_commuter", "thesis001_flat_1km", "A", "B", (77.99, 95.0)),
         ("thesis001_commuter", "thesis001_advanced_1km", "A", "B", (84.92, 100.87))]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    args = p.parse_args()
    print(f"`python bench/bench_heuristics.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    print("| case | time (s) | optimum (kWh) | strategy | energy (kWh) | gap (%) | arrival error (s) | wall (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for trn, trk, a, b, times in CASES:
        train, track = load_train(ROOT / f"trains/{trn}.yaml"), load_track(ROOT / f"tracks/{trk}.yaml")
        case = prepare(track, train, a, b, args.points)
        for t in times:
            opt = solve_run(track, train, a, b, Timing(running_time=t), points=args.points).summary
            e_opt = opt["traction_energy_kWh"]
            for heuristic in (ecodrive.eco_coasting, ecodrive.mareco):
                t0 = time.perf_counter()
                try:
                    row = heuristic(case, t).row(train, case.segment.distance)
                except InfeasibleError as exc:
                    print(f"| {trk} | {t:.2f} | {e_opt:.4f} | {heuristic.__name__} | {exc} | | | |")
                    continue
                wall = time.perf_counter() - t0
                print(f"| {trk} | {t:.2f} | {e_opt:.4f} | {row['strategy']} | {row['traction_energy_kWh']:.4f} | "
                      f"{100 * (row['traction_energy_kWh'] / e_opt - 1):+.2f} | "
                      f"{row['running_time_s'] - t:+.3f} | {wall:.2f} |")


if __name__ == "__main__":
    main()
