"""A sweep of running times with the NL file written once per structure against a fresh build and
write per case, in one process.

    .venv/bin/python bench/bench_written.py [--points 1000] [--times 76 78 80 82 84 86 88 90 92 94]
        [--repeat 3]

Each case is ``analysis.single.solve_run`` on the Amsterdam case (traction energy); "written" passes
one ``ocp.problem.Written`` through the sweep, so every case after the first changes T's bounds and
the start point of the model written for the first. Prints per variant the seconds of the whole
sweep (median of ``--repeat``), the stage sums, the Ipopt iterations and the largest energy
difference between the variants.
"""
import argparse
import shlex
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import Written  # noqa: E402

STAGES = ("build", "nl_write", "solve", "verify")


def sweep(track, train, points, times, written):
    t0 = time.perf_counter()
    runs = [solve_run(track, train, "Rokin", "Centraal", Timing(running_time=t), points=points,
                      written=written, structure="sweep" if written is not None else None) for t in times]
    return time.perf_counter() - t0, runs


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--times", type=float, nargs="+", default=[76, 78, 80, 82, 84, 86, 88, 90, 92, 94])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"`{shlex.join(['python', 'bench/bench_written.py'] + sys.argv[1:])}`\n")
    track = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    train = load_train(ROOT / "trains/amsterdam_metro.yaml")
    rows = {"fresh build and write per case": [], "written once (ocp.problem.Written)": []}
    for _ in range(args.repeat):  # alternating, so that both see the same machine
        rows["fresh build and write per case"].append(sweep(track, train, args.points, args.times, None))
        rows["written once (ocp.problem.Written)"].append(sweep(track, train, args.points, args.times, Written()))
    print(f"{len(args.times)} running times, K = {args.points}; seconds for the whole sweep (median of {args.repeat})\n")
    print("| variant | sweep s | ratio | " + " | ".join(f"{s} s" for s in STAGES) + " | iterations | all verified |")
    print("|---|---|---|" + "---|" * len(STAGES) + "---|---|")
    base = statistics.median(r[0] for r in rows["fresh build and write per case"])
    for name, results in rows.items():
        wall = statistics.median(r[0] for r in results)
        runs = results[-1][1]
        sums = [sum(r.stages.get(s, 0.0) for r in runs) for s in STAGES]
        print(f"| {name} | {wall:.2f} | {wall / base:.2f} | " + " | ".join(f"{x:.2f}" for x in sums)
              + f" | {sum(r.summary['solver']['iterations'] for r in runs)} | {all(r.ok for r in runs)} |")
    fresh, kept = rows["fresh build and write per case"][-1][1], rows["written once (ocp.problem.Written)"][-1][1]
    diff = max(abs(a.summary["traction_energy_kWh"] / b.summary["traction_energy_kWh"] - 1) for a, b in zip(kept, fresh))
    print(f"\nlargest relative energy difference between the variants: {diff:.1e}")


if __name__ == "__main__":
    main()
