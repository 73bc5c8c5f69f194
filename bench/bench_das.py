"""DAS methods against ATO on the shipped metro and regional cases (issue: driver advice).

    .venv/bin/python bench/bench_das.py [--points 1000] [--time-limit 60]

For each case at its published running time: the ATO optimum at K and at 4K (the finer one
bounds the grid error of the ATO reference), then `round`, `phases` and `minlp`, each re-simulated
as a driver follows the advice. Wall time per method excludes the ATO solve it starts from.
"""
import argparse
import shlex
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.das.methods import das_run  # noqa: E402
from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402

CASES = {"Amsterdam metro 76 s": ("amsterdam_metro", "amsterdam_rokin_centraal", "Rokin", "Centraal", 76.0),
         "regional 80 s": ("regional_alstom", "regional_808m", "Origin", "Destination", 80.0)}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    p.add_argument("--time-limit", type=float, default=60.0)
    args = p.parse_args()
    print(f"`python bench/bench_das.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    minlp_rows = []
    for name, (trn, trk, a, b, t) in CASES.items():
        train, track = load_train(ROOT / f"trains/{trn}.yaml"), load_track(ROOT / f"tracks/{trk}.yaml")
        t0 = time.perf_counter()
        ato = solve_run(track, train, a, b, Timing(running_time=t), points=args.points)
        t_ato = time.perf_counter() - t0
        fine = solve_run(track, train, a, b, Timing(running_time=t), points=4 * args.points)
        s = ato.summary
        print(f"**{name}**, K = {args.points}: ATO {s['traction_energy_kWh']:.4f} kWh ({t_ato:.2f} s, "
              f"regimes {s['regimes']['sequence']}); ATO at K = {4 * args.points}: "
              f"{fine.summary['traction_energy_kWh']:.4f} kWh; marginal dE/dT "
              f"{s['marginal_energy_kWh_per_s']:.4f} kWh/s\n")
        print("| method | traction kWh | gap to ATO % | gap, lateness charged % | vs ATO 4K % | arrival error s "
              "| stop error m | mode changes | wall s | status |\n|---|---|---|---|---|---|---|---|---|---|")
        for method in ("round", "phases", "minlp"):
            t0 = time.perf_counter()
            d = das_run(ato, method, time_limit=args.time_limit)[0]
            wall = time.perf_counter() - t0
            vs_fine = 100 * (d["traction_energy_kWh"] / fine.summary["traction_energy_kWh"] - 1)
            print(f"| {method} | {d['traction_energy_kWh']:.4f} | {d['gap_to_ato_pct']:+.3f} | "
                  f"{d['gap_to_ato_on_time_pct']:+.3f} | {vs_fine:+.3f} | {d['arrival_error_s']:+.3f} | "
                  f"{d['stop_error_m']:+.3f} | {d['mode_changes']} | {wall:.1f} | {d['status']} |")
            if method == "minlp":
                minlp_rows.append((name, d))
        print()
    print(f"MINLP search (MindtPy OA, HiGHS master, cyipopt subproblems, time limit {args.time_limit:.0f} s):\n")
    print("| case | search s | OA iterations | best kWh | OA master bound kWh | gap % | note |\n|---|---|---|---|---|---|---|")
    for name, d in minlp_rows:
        bound = "-" if d["oa_master_bound_kWh"] is None else f"{d['oa_master_bound_kWh']:.4f}"
        gap = "-" if d["gap_pct"] is None else f"{d['gap_pct']:.2f}"
        print(f"| {name} | {d['search_s']:.1f} | {d['oa_iterations']} | {d['traction_energy_kWh']:.4f} | {bound} | "
              f"{gap} | {d['bound_note']} |")


if __name__ == "__main__":
    main()
