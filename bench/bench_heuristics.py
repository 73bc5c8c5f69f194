"""Heuristics against the optimum on the shipped cases: eco-drive coasting and MARECO-style.

    .venv/bin/python bench/bench_heuristics.py [--points 1000]

For each case and running time: the ATO optimum (traction energy), eco-drive coasting and the
MARECO-style heuristic (ecostudy/mareco.py), each re-simulated; gap to the optimum, arrival
error and wall time of the heuristic (the optimum's solve excluded).
"""
import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.heuristics import ecodrive  # noqa: E402
from ecostudy.core.errors import InfeasibleError  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402

TRIPS = [("amsterdam_metro", "amsterdam_rokin_centraal", "Rokin", "Centraal", (76.0, 80.0, 85.0, 90.0)),
         ("regional_alstom", "regional_808m", "Origin", "Destination", (80.0, 90.0)),
         ("yazhemsky2017_commuter", "yazhemsky2017_flat_1km", "A", "B", (77.99, 95.0)),
         ("yazhemsky2017_commuter", "yazhemsky2017_advanced_1km", "A", "B", (84.92, 100.87))]


def metro(p):
    trn, trk, a, b, _ = TRIPS[0]
    return prepare(load_track(ROOT / f"tracks/{trk}.yaml"), load_train(ROOT / f"trains/{trn}.yaml"), a, b, p["points"]), p


def heuristic_case(heuristic):
    def run(state):
        case, p = state
        row = heuristic(case, p["time"]).row(case.train, case.segment.distance)
        return {"energy_kWh": row["traction_energy_kWh"], "arrival_error_s": row["running_time_s"] - p["time"]}
    harness.register(f"heuristics.{heuristic.__name__}", run, params={"points": 1000, "time": 80.0}, setup=metro,
                     doc=f"The {heuristic.__name__} heuristic on the Amsterdam metro (Rokin to Centraal) in `time` s")


for _heuristic in (ecodrive.eco_coasting, ecodrive.mareco):
    heuristic_case(_heuristic)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    table = harness.Table(["case", "time (s)", "optimum (kWh)", "strategy", "energy (kWh)", "gap (%)",
                           "arrival error (s)", "wall (s)"])
    for trn, trk, a, b, times in TRIPS:
        train, track = load_train(ROOT / f"trains/{trn}.yaml"), load_track(ROOT / f"tracks/{trk}.yaml")
        case = prepare(track, train, a, b, args.points)
        for t in times:
            opt = solve_run(track, train, a, b, Timing(running_time=t), points=args.points).summary
            e_opt = opt["traction_energy_kWh"]
            for heuristic in (ecodrive.eco_coasting, ecodrive.mareco):
                try:
                    row, _, wall = harness.timed(lambda: heuristic(case, t).row(train, case.segment.distance))
                except InfeasibleError as exc:
                    table.add(trk, f"{t:.2f}", f"{e_opt:.4f}", heuristic.__name__, exc, "", "", "")
                    continue
                table.add(trk, f"{t:.2f}", f"{e_opt:.4f}", row["strategy"], f"{row['traction_energy_kWh']:.4f}",
                          signed(100 * (row['traction_energy_kWh'] / e_opt - 1), 2), signed(row['running_time_s'] - t, 3),
                          f"{wall:.2f}")


if __name__ == "__main__":
    main()
