"""Closed-loop groundwork: open-loop replay against re-planning (with and without the mass
estimator) on the model train and on a 10 % heavier one.

    .venv/bin/python bench/bench_closed_loop.py [--points 200] [--sample 1.0] [--plant-step 0.05]

Amsterdam metro, 76 s. Prints one markdown row per (true mass, controller): stop error, arrival,
traction work at the wheel, worst overspeed, solve time per cycle (mean, p95, max), re-plans that
found no plan (braked instead) and the final mass estimate.
"""
import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.control.controllers import OpenLoop, Replanning  # noqa: E402
from ecostudy.control.estimator import MassEstimator  # noqa: E402
from ecostudy.control.loop import run_loop  # noqa: E402
from ecostudy.core.plant import Plant, Truth  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=200)
    p.add_argument("--sample", type=float, default=1.0)
    p.add_argument("--plant-step", type=float, default=0.05)
    args = p.parse_args()
    print(f"`python bench/bench_closed_loop.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    track = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    train = load_train(ROOT / "trains/amsterdam_metro.yaml")
    plan = solve_run(track, train, "Rokin", "Centraal", Timing(running_time=76.0), points=args.points)
    print(f"open-loop plan: {plan.summary['traction_energy_kWh']:.3f} kWh, 76 s, K = {args.points}, "
          f"sample {args.sample} s, plant step {args.plant_step} s\n")
    print("| true mass | controller | stop error m | arrival s | traction kWh | overspeed km/h | solve mean s | "
          "p95 s | max s | no plan (braked) | mass estimate | wall s |\n|---|---|---|---|---|---|---|---|---|---|---|---|")
    for scale in (1.0, 1.1):
        plant = Plant(plan.segment, train, Truth(mass=scale))
        for name in ("open loop, by position", "open loop, on its clock", "re-planning", "re-planning + mass estimator"):
            estimator = MassEstimator() if "estimator" in name else None
            if name.startswith("open"):
                controller = OpenLoop(plan, by="position" if "position" in name else "time")
            else:
                controller = Replanning(prepare(track, train, "Rokin", "Centraal", args.points), 76.0, estimator=estimator)
            t0 = time.perf_counter()
            r = run_loop(plant, controller, args.sample, plant_step=args.plant_step, estimator=estimator)
            wall = time.perf_counter() - t0
            s = np.array(r.solve_seconds)
            estimate = f"{estimator.estimate:.4f}" if estimator else "-"
            print(f"| {scale:.1f} | {name} | {r.stop_error_m:+.2f} | {r.arrival_time_s:.2f} | "
                  f"{r.traction_work / 3.6e6:.3f} | {r.max_overspeed_kmh:.2f} | {s.mean():.3f} | "
                  f"{np.percentile(s, 95):.3f} | {s.max():.3f} | {getattr(controller, 'failures', '-')} | "
                  f"{estimate} | {wall:.1f} |", flush=True)


if __name__ == "__main__":
    main()
