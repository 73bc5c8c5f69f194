"""Closed-loop groundwork: open-loop replay against re-planning (with and without the mass
estimator) on the model train and on a 10 % heavier one.

    .venv/bin/python bench/bench_closed_loop.py [--points 200] [--sample 1.0] [--plant-step 0.05]

Amsterdam metro, 76 s. Prints one markdown row per (true mass, controller): stop error, arrival,
traction work at the wheel, worst overspeed, solve time per cycle (mean, p95, max), re-plans that
found no plan (braked instead) and the final mass estimate.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.control.controllers import OpenLoop, Replanning  # noqa: E402
from ecostudy.control.estimator import MassEstimator  # noqa: E402
from ecostudy.control.loop import run_loop  # noqa: E402
from ecostudy.core.plant import Plant, Truth  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402


def setup(p):
    track = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    train = load_train(ROOT / "trains/amsterdam_metro.yaml")
    return track, train, solve_run(track, train, "Rokin", "Centraal", Timing(running_time=76.0), points=p["points"]), p


def drive(plant, controller, p, estimator=None):
    """The loop run and its row's numbers (solve times per cycle, stop, arrival, energy)."""
    r = run_loop(plant, controller, p["sample"], plant_step=p["plant_step"], estimator=estimator)
    s = np.array(r.solve_seconds)
    return {"stop_error_m": r.stop_error_m, "arrival_s": r.arrival_time_s, "traction_kWh": r.traction_work / 3.6e6,
            "overspeed_kmh": r.overspeed_max_kmh, "solve_mean_s": s.mean(), "solve_p95_s": np.percentile(s, 95),
            "solve_max_s": s.max(), "failures": getattr(controller, "failures", "-"),
            "mass_estimate": f"{estimator.estimate:.4f}" if estimator else "-"}


@harness.case("closed_loop.replanning", setup=setup,
              params={"points": 200, "sample": 1.0, "plant_step": 0.05, "mass": 1.1, "estimator": True})
def replanning(state):
    """Re-planning (with the mass estimator) driving a train ``mass`` times the model's, Rokin to Centraal in 76 s."""
    track, train, plan, p = state
    estimator = MassEstimator() if p["estimator"] else None
    controller = Replanning(prepare(track, train, "Rokin", "Centraal", p["points"]), 76.0, estimator=estimator)
    return drive(Plant(plan.segment, train, Truth(mass=p["mass"])), controller, p, estimator)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=200)
    p.add_argument("--sample", type=float, default=1.0)
    p.add_argument("--plant-step", type=float, default=0.05)
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    params = {"points": args.points, "sample": args.sample, "plant_step": args.plant_step}
    track, train, plan, _ = setup(params)
    print(f"open-loop plan: {plan.summary['traction_energy_kWh']:.3f} kWh, 76 s, K = {args.points}, "
          f"sample {args.sample} s, plant step {args.plant_step} s\n")
    table = harness.Table(["true mass", "controller", "stop error m", "arrival s", "traction kWh", "overspeed km/h",
                           "solve mean s", "p95 s", "max s", "no plan (braked)", "mass estimate", "wall s"])
    for scale in (1.0, 1.1):
        plant = Plant(plan.segment, train, Truth(mass=scale))
        for name in ("open loop, by position", "open loop, on its clock", "re-planning", "re-planning + mass estimator"):
            estimator = MassEstimator() if "estimator" in name else None
            if name.startswith("open"):
                controller = OpenLoop(plan, by="position" if "position" in name else "time")
            else:
                controller = Replanning(prepare(track, train, "Rokin", "Centraal", args.points), 76.0, estimator=estimator)
            r = harness.sample(lambda c: drive(plant, c, params, estimator), controller)
            table.add(f"{scale:.1f}", name, signed(r['stop_error_m'], 2), f"{r['arrival_s']:.2f}", f"{r['traction_kWh']:.3f}",
                      f"{r['overspeed_kmh']:.2f}", f"{r['solve_mean_s']:.3f}", f"{r['solve_p95_s']:.3f}",
                      f"{r['solve_max_s']:.3f}", r["failures"], r["mass_estimate"], f"{r['wall_s']:.1f}")


if __name__ == "__main__":
    main()
