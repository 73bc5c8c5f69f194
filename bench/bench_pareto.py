"""Pareto sweep timings (cold/warm, serial/parallel) and the savings of +5 % and +10 % supplements.

    .venv/bin/python bench/bench_pareto.py [--count 20] [--points 500] [--repeat 3]

Cold: every point its own model, NL file and capped-speed start (as `ecostudy solve` would).
Warm: one model and NL file per chain, only the running-time bound changes, each solve starts
from the previous point. Wall time includes the all-out run, verification of every point and
process start-up for workers, not the plots.
"""
import argparse
import shlex
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.studies.pareto import is_monotone, saving_at, sweep  # noqa: E402

CASES = {"Amsterdam metro": ("amsterdam_metro", "amsterdam_rokin_centraal", "Rokin", "Centraal"),
         "regional": ("regional_alstom", "regional_808m", "Origin", "Destination"),
         "Yazhemsky 2017 advanced": ("thesis001_commuter", "thesis001_advanced_1km", "A", "B")}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=20)
    p.add_argument("--points", type=int, default=500)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args()
    print(f"`python bench/bench_pareto.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    load = lambda c: (load_track(ROOT / f"tracks/{c[1]}.yaml"), load_train(ROOT / f"trains/{c[0]}.yaml"))  # noqa: E731
    track, train = load(CASES["Amsterdam metro"])
    print(f"Amsterdam metro, {args.count} points, K = {args.points}, supplement 0-40 %\n")
    print("| mode | workers | wall s (median) | iterations | monotone | all verified |\n|---|---|---|---|---|---|")
    for warm in (False, True):
        for workers in (1, 2):
            walls, table = [], None
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                table, _ = sweep(track, train, "Rokin", "Centraal", count=args.count, supplement_max=0.4,
                                 points=args.points, workers=workers, warm=warm)
                walls.append(time.perf_counter() - t0)
            print(f"| {'warm' if warm else 'cold'} | {workers} | {statistics.median(walls):.2f} | "
                  f"{table['iterations'].sum()} | {is_monotone(table)} | {table['verified'].all()} |", flush=True)
    print("\nSavings against the all-out run (traction energy at the wheel; 41 points over 0-40 %, K = 1000)\n")
    print("| case | all-out s | all-out kWh | +5 %: kWh | +5 %: saving % | +10 %: kWh | +10 %: saving % |\n"
          "|---|---|---|---|---|---|---|")
    for name, c in CASES.items():
        track, train = load(c)
        table, _ = sweep(track, train, c[2], c[3], count=41, supplement_max=0.4, points=1000, workers=2)
        row = {s: table.loc[(table["supplement_pct"] - s).abs().idxmin()] for s in (5, 10)}
        print(f"| {name} | {table['running_time_s'][0]:.2f} | {table['traction_energy_kWh'][0]:.2f} | "
              f"{row[5]['traction_energy_kWh']:.2f} | {saving_at(table, 5):.1f} | "
              f"{row[10]['traction_energy_kWh']:.2f} | {saving_at(table, 10):.1f} |", flush=True)


if __name__ == "__main__":
    main()
