"""RSPC (Farooqi 2018 Ch. 6, ``control/rspc.py``) on the Amsterdam metro case (76 s) and the regional
case of Farooqi 2018 §6.3 (808 m, 80 s), at T_s = 0.38 s, plant stepped at the sample.

    .venv/bin/python bench/bench_rspc.py [--horizons 1 2 3 4] [--disturbances 0.1 0.05]

Table 1: the references of Table 6.1 on each case, scored by the independent simulator: the
industrial eco-drive coasting strategy at the timetable and the all-out run. Table 2: RSPC with
the default settings (N = 3, D = 25 m, gamma_S = 0.995) on the model train and on the trains d
heavier with resistance, traction and braking d weaker (and d lighter with them d stronger), then
N swept on the model train: energy at the wheel, arrival, stop error, overspeed, solve time per
sample (the enumeration of 6^N sequences), mode changes, samples without an admissible sequence.
"""
import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from bench.bench_das import TRIPS  # noqa: E402  (the two cases of Farooqi 2018 Tables 4.1 and 6.1)
from ecostudy.control.loop import run_loop  # noqa: E402
from ecostudy.control.rspc import Rspc  # noqa: E402
from ecostudy.core.plant import Plant, Truth  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.heuristics.ecodrive import drive, eco_coasting  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402


def prepared(name):
    train, track, a, b, arrival = TRIPS[name]
    return prepare(load_track(ROOT / f"tracks/{track}.yaml"), load_train(ROOT / f"trains/{train}.yaml"), a, b, 400), arrival


def drive_rspc(case, arrival, sample, n, truth):
    """RSPC with horizon ``n`` driving the plant: energy, arrival, stop, solve times, mode changes."""
    controller = Rspc(case, arrival, sample, horizon=n)
    result = run_loop(Plant(case.segment, case.train, truth), controller, sample, plant_step=sample)
    ms = 1e3 * np.array([s for s in controller.solve_seconds if s > 0])
    return {"energy_kWh": result.traction_work / 3.6e6, "arrival_s": result.arrival_time_s,
            "stop_error_m": result.stop_error_m, "overspeed_kmh": result.overspeed_max_kmh, "solve_mean_ms": ms.mean(),
            "solve_p95_ms": np.percentile(ms, 95), "solve_max_ms": ms.max(),
            "mode_changes": sum(a != b for a, b in zip(controller.chosen, controller.chosen[1:])),
            "failures": controller.failures,
            "modes": ", ".join(f"{m} {k}" for m, k in Counter(controller.chosen).most_common())}


@harness.case("rspc.model", params={"trip": "Amsterdam metro 76 s", "sample": 0.38, "horizon": 3},
              setup=lambda p: (*prepared(p["trip"]), p))
def rspc_model(state):
    """RSPC (Farooqi 2018 Ch. 6) with horizon N driving the model train."""
    case, arrival, p = state
    return drive_rspc(case, arrival, p["sample"], p["horizon"], Truth())


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sample", type=float, default=0.38)
    p.add_argument("--horizons", type=int, nargs="*", default=[1, 2, 3, 4])
    p.add_argument("--disturbances", type=float, nargs="*", default=[0.1, 0.05])
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    cases = {}
    table = harness.Table(["case", "strategy", "arrival [s]", "energy [kWh]"])
    for name in TRIPS:
        case, arrival = cases[name] = prepared(name)
        for label, trace in (("eco-drive coasting", eco_coasting(case, arrival).trace),
                             ("all-out", drive(case, case.envelope)[1])):
            table.add(name, label, f"{trace.arrival_time:.2f}", f"{trace.traction_energy / 3.6e6:.3f}")
    print()
    table = harness.Table(["case", "N", "plant", "energy [kWh]", "arrival [s]", "stop error [m]", "overspeed [km/h]",
                           "solve mean / p95 / max [ms]", "mode changes", "no admissible sequence", "run wall [s]",
                           "modes applied"])

    def row(name, n, label, truth):
        r = harness.sample(lambda c: drive_rspc(*c, args.sample, n, truth), cases[name])
        table.add(name, n, label, f"{r['energy_kWh']:.3f}", f"{r['arrival_s']:.2f}", signed(r['stop_error_m'], 3),
                  f"{r['overspeed_kmh']:.2f}", f"{r['solve_mean_ms']:.1f} / {r['solve_p95_ms']:.1f} / {r['solve_max_ms']:.1f}",
                  r["mode_changes"], r["failures"], f"{r['wall_s']:.1f}", r["modes"])

    for name in cases:
        row(name, 3, "model", Truth())
        for d in args.disturbances:
            row(name, 3, f"d = +{d:g}", Truth(1 + d, 1 - d, 1 - d, 1 - d))
            row(name, 3, f"d = -{d:g}", Truth(1 - d, 1 + d, 1 + d, 1 + d))
    for n in args.horizons:
        if n != 3:
            for name in cases:
                row(name, n, "model", Truth())


if __name__ == "__main__":
    _, _, seconds = harness.timed(main)
    print(f"\n{seconds:.0f} s in all")
