"""DAS methods against ATO on the shipped metro and regional cases (docs/benchmarks.md "Driver advice (DAS)").

    .venv/bin/python bench/bench_das.py [--points 1000] [--time-limit 60]

For each case at its published running time: the ATO optimum at K and at 4K (the finer one
bounds the grid error of the ATO reference), then `round`, `phases` and `minlp`, each re-simulated
as a driver follows the advice. Wall time per method excludes the ATO solve it starts from.
"""
import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.das.methods import das_run  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402

TRIPS = {"Amsterdam metro 76 s": ("amsterdam_metro", "amsterdam_rokin_centraal", "Rokin", "Centraal", 76.0),
         "regional 80 s": ("regional_alstom", "regional_808m", "Origin", "Destination", 80.0)}


def ato_run(p):
    """The ATO optimum a DAS method starts from (untimed): Amsterdam metro, 76 s, K = ``points``."""
    trn, trk, a, b, t = TRIPS["Amsterdam metro 76 s"]
    return solve_run(load_track(ROOT / f"tracks/{trk}.yaml"), load_train(ROOT / f"trains/{trn}.yaml"), a, b,
                     Timing(running_time=t), points=p["points"]), p


def method_case(method):
    def run(state):
        ato, p = state
        d = dict(das_run(ato, method, time_limit=p["time_limit"])[0])
        d["das"] = d.pop("status")  # the method's own word ("re-simulated", ...); a failure stays the case's status
        return {**d, **({"status": d["das"]} if d["das"].startswith("failed") else {})}
    harness.register(f"das.{method}", run, params={"points": 1000, "time_limit": 60.0}, setup=ato_run,
                     doc=f"Driver advice by `{method}` from the ATO optimum (Amsterdam metro, 76 s), re-simulated")


for _method in ("round", "phases", "minlp"):
    method_case(_method)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    p.add_argument("--time-limit", type=float, default=60.0)
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    minlp_rows = []
    for name, (trn, trk, a, b, t) in TRIPS.items():
        train, track = load_train(ROOT / f"trains/{trn}.yaml"), load_track(ROOT / f"tracks/{trk}.yaml")
        ato, _, t_ato = harness.timed(lambda: solve_run(track, train, a, b, Timing(running_time=t), points=args.points))
        fine = solve_run(track, train, a, b, Timing(running_time=t), points=4 * args.points)
        s = ato.summary
        print(f"**{name}**, K = {args.points}: ATO {s['traction_energy_kWh']:.4f} kWh ({t_ato:.2f} s, "
              f"regimes {s['regimes']['sequence']}); ATO at K = {4 * args.points}: "
              f"{fine.summary['traction_energy_kWh']:.4f} kWh; marginal dE/dT "
              f"{s['marginal_energy_kWh_per_s']:.4f} kWh/s\n")
        table = harness.Table(["method", "traction kWh", "gap to ATO %", "gap, lateness charged %", "vs ATO 4K %",
                               "arrival error s", "stop error m", "mode changes", "wall s", "status"])
        for method in ("round", "phases", "minlp"):
            d, _, wall = harness.timed(lambda: das_run(ato, method, time_limit=args.time_limit)[0])
            vs_fine = 100 * (d["traction_energy_kWh"] / fine.summary["traction_energy_kWh"] - 1)
            table.add(method, f"{d['traction_energy_kWh']:.4f}", signed(d['gap_to_ato_pct'], 3),
                      signed(d['gap_to_ato_on_time_pct'], 3), signed(vs_fine, 3), signed(d['arrival_error_s'], 3),
                      signed(d['stop_error_m'], 3), d["mode_changes"], f"{wall:.1f}", d["status"])
            if method == "minlp":
                minlp_rows.append((name, d))
        print()
    print(f"MINLP search (MindtPy OA, HiGHS master, cyipopt subproblems, time limit {args.time_limit:.0f} s):\n")
    table = harness.Table(["case", "search s", "OA iterations", "best kWh", "OA master bound kWh", "gap %", "note"])
    for name, d in minlp_rows:
        bound = "-" if d["oa_master_bound_kWh"] is None else f"{d['oa_master_bound_kWh']:.4f}"
        gap = "-" if d["gap_pct"] is None else f"{d['gap_pct']:.2f}"
        table.add(name, f"{d['search_s']:.1f}", d["oa_iterations"], f"{d['traction_energy_kWh']:.4f}", bound, gap,
                  d["bound_note"])


if __name__ == "__main__":
    main()
