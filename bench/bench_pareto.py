"""Pareto sweep timings (cold/warm, serial/parallel) and the savings of +5 % and +10 % supplements.

    .venv/bin/python bench/bench_pareto.py [--count 20] [--points 500] [--repeat 3]
    .venv/bin/python bench/bench_pareto.py --cold-points [--count 20] [--points 500]

Cold: every point its own model, NL file and capped-speed start (as `ecostudy solve` would).
Warm: one model and NL file per chain, only the running-time bound changes, each solve starts
from the previous point. Wall time includes the all-out run, verification of every point and
process start-up for workers, not the plots.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import Written  # noqa: E402
from ecostudy.studies.pareto import front_supplements, is_monotone, saving_at, sweep  # noqa: E402

TRIPS = {"Amsterdam metro": ("amsterdam_metro", "amsterdam_rokin_centraal", "Rokin", "Centraal"),
         "regional": ("regional_alstom", "regional_808m", "Origin", "Destination"),
         "Yazhemsky 2017 advanced": ("yazhemsky2017_commuter", "yazhemsky2017_advanced_1km", "A", "B")}
PARAMS = {"count": 20, "points": 500, "workers": 1}


def load(c):
    return load_track(ROOT / f"tracks/{c[1]}.yaml"), load_train(ROOT / f"trains/{c[0]}.yaml")


def front(p, warm):
    """The Amsterdam metro front over 0-40 % supplement: iterations, monotone, all verified."""
    table, _ = sweep(*load(TRIPS["Amsterdam metro"]), "Rokin", "Centraal", count=p["count"], supplement_max=0.4,
                     points=p["points"], workers=p["workers"], warm=warm)
    return {"iterations": int(table["iterations"].sum()), "monotone": bool(is_monotone(table)),
            "verified": bool(table["verified"].all())}


harness.register("pareto.cold", lambda p: front(p, False), params=PARAMS,
                 doc="A Pareto front, cold: every point its own model, NL file and capped-speed start")
harness.register("pareto.warm", lambda p: front(p, True), params=PARAMS, reference="pareto.cold",
                 doc="A Pareto front, warm: one model and NL file per chain, each solve from the previous point")


def cold_points(count, points):
    """The command's front (every point cold on one written model per process, as a case of the
    ``pareto`` study kind solves it) against the warm-started chain, in this process: the largest
    relative energy difference, CPU seconds and iterations of each."""
    table = harness.Table(["trip", "largest energy difference", "CPU s chained", "CPU s cold",
                           "iterations chained / cold"])
    for name, c in TRIPS.items():
        track, train = load(c)
        cpu = time.process_time()
        chained, _ = sweep(track, train, c[2], c[3], count=count, supplement_max=0.4, points=points)
        cpu_chained, cpu = time.process_time() - cpu, time.process_time()
        allout = solve_run(track, train, c[2], c[3], Timing(), objective="time", points=points)
        written, runs = Written(), [allout]
        for s in front_supplements(count, 0.4)[1:]:
            runs.append(solve_run(track, train, c[2], c[3], Timing(running_time=allout.facts.running_time_s * (1 + s)),
                                  points=points, written=written, structure=name))
        cpu_cold = time.process_time() - cpu
        energy = np.array([r.facts.traction_energy_kWh for r in runs])
        gap = np.max(np.abs(energy / chained["traction_energy_kWh"].to_numpy() - 1))
        table.add(name, f"{gap:.1e}", f"{cpu_chained:.2f}", f"{cpu_cold:.2f}",
                  f"{int(chained['iterations'].sum())} / {sum(r.facts.solver.iterations for r in runs)}")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=20)
    p.add_argument("--points", type=int, default=500)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--cold-points", action="store_true", help="the command's cold points against the chain")
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    if args.cold_points:
        return cold_points(args.count, args.points)
    print(f"Amsterdam metro, {args.count} points, K = {args.points}, supplement 0-40 %\n")
    table = harness.Table(["mode", "workers", "wall s (median)", "iterations", "monotone", "all verified"])
    for warm in (False, True):
        for workers in (1, 2):
            name = f"pareto.{'warm' if warm else 'cold'}"
            r = harness.measure([name], args.repeat, {"count": args.count, "points": args.points, "workers": workers},
                                 references=False)[name]
            table.add(name[7:], workers, f"{r.median('wall_s'):.2f}", r.last("iterations"), r.last("monotone"),
                      r.last("verified"))
    print("\nSavings against the all-out run (traction energy at the wheel; 41 points over 0-40 %, K = 1000)\n")
    table = harness.Table(["case", "all-out s", "all-out kWh", "+5 %: kWh", "+5 %: saving %", "+10 %: kWh",
                           "+10 %: saving %"])
    for name, c in TRIPS.items():
        front_table, _ = sweep(*load(c), c[2], c[3], count=41, supplement_max=0.4, points=1000, workers=2)
        row = {s: front_table.loc[(front_table["supplement_pct"] - s).abs().idxmin()] for s in (5, 10)}
        table.add(name, f"{front_table['running_time_s'][0]:.2f}", f"{front_table['traction_energy_kWh'][0]:.2f}",
                  f"{row[5]['traction_energy_kWh']:.2f}", f"{saving_at(front_table, 5):.1f}",
                  f"{row[10]['traction_energy_kWh']:.2f}", f"{saving_at(front_table, 10):.1f}")


if __name__ == "__main__":
    main()
