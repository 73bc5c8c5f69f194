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
import shlex
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_das import CASES  # noqa: E402  (the two cases of Farooqi 2018 Tables 4.1 and 6.1)
from ecostudy.control.loop import run_loop  # noqa: E402
from ecostudy.control.rspc import Rspc  # noqa: E402
from ecostudy.core.plant import Plant, Truth  # noqa: E402
from ecostudy.heuristics.ecodrive import drive, eco_coasting  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sample", type=float, default=0.38)
    p.add_argument("--horizons", type=int, nargs="*", default=[1, 2, 3, 4])
    p.add_argument("--disturbances", type=float, nargs="*", default=[0.1, 0.05])
    args = p.parse_args()
    print(f"`python bench/bench_rspc.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    cases = {}
    print("| case | strategy | arrival [s] | energy [kWh] |\n|---|---|---|---|")
    for name, (train, track, a, b, arrival) in CASES.items():
        case = prepare(load_track(ROOT / f"tracks/{track}.yaml"), load_train(ROOT / f"trains/{train}.yaml"), a, b, 400)
        cases[name] = (case, arrival)
        for label, trace in (("eco-drive coasting", eco_coasting(case, arrival).trace),
                             ("all-out", drive(case, case.envelope)[1])):
            print(f"| {name} | {label} | {trace.arrival_time:.2f} | {trace.traction_energy / 3.6e6:.3f} |")
    print("\n| case | N | plant | energy [kWh] | arrival [s] | stop error [m] | overspeed [km/h] | solve mean / p95 / "
          "max [ms] | mode changes | no admissible sequence | run wall [s] | modes applied |")
    print("|" + "---|" * 12, flush=True)

    def row(name, n, label, truth):
        case, arrival = cases[name]
        controller = Rspc(case, arrival, args.sample, horizon=n)
        t0 = time.perf_counter()
        result = run_loop(Plant(case.segment, case.train, truth), controller, args.sample, plant_step=args.sample)
        ms = 1e3 * np.array([s for s in controller.solve_seconds if s > 0])
        changes = sum(a != b for a, b in zip(controller.chosen, controller.chosen[1:]))
        modes = ", ".join(f"{m} {k}" for m, k in Counter(controller.chosen).most_common())
        print(f"| {name} | {n} | {label} | {result.traction_work / 3.6e6:.3f} | {result.arrival_time_s:.2f} | "
              f"{result.stop_error_m:+.3f} | {result.max_overspeed_kmh:.2f} | {ms.mean():.1f} / "
              f"{np.percentile(ms, 95):.1f} / {ms.max():.1f} | {changes} | {controller.failures} | "
              f"{time.perf_counter() - t0:.1f} | {modes} |", flush=True)

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
    start = time.perf_counter()
    main()
    print(f"\n{time.perf_counter() - start:.0f} s in all")
