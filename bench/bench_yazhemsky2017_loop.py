"""Yazhemsky 2017 Chs. 9-10 in closed loop, side by side with the published numbers.

    .venv/bin/python bench/bench_yazhemsky2017_loop.py [--points 500] [--delay 0|1|measured] [--power-kw P] [--table1]

``--delay``: the computation delay (control/loop.py); ``--power-kw``: the trips on the commuter
with a constant traction force limit of 1e6 N and a power limit of P kW instead of the traction
loss table (a TTOBench-style train; P = 1e6 kW never binds and is dropped from the SOCP);
``--table1``: Table 1 only; ``--figures 9.7``: those rows of it.

The convex controller (SOCP 6.10 by Clarabel, re-solved every 100 ms from the measured state on
the grid ahead) drives the plant (DOP853 between samples). Table 1: Figs. 9.1, 9.4, 9.2, 9.7
(published from tests/data/yazhemsky2017_closed_loop_published.csv) and Fig. 9.5's follower. Table 2:
the Ch. 10 trends on the representative 5 km track (noise, a 20 % heavier train with and
without the Kalman mass estimator).
"""
import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.control.controllers import Convex, leader_clock  # noqa: E402
from ecostudy.control.estimator import MassEstimator  # noqa: E402
from ecostudy.control.loop import run_loop  # noqa: E402
from ecostudy.core.grid import make_segment  # noqa: E402
from ecostudy.core.physics import Envelope  # noqa: E402
from ecostudy.core.plant import Noise, Plant, Truth  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.convex import ConvexProgram, ConvexWeights, trapezoid_grid  # noqa: E402

TS = 0.1


DELAY = 0


def drive(train, track, weights, latest, points, truth=Truth(), noise=Noise(), estimator=None, lead=None):
    segment = make_segment(load_track(ROOT / "tracks" / f"{track}.yaml"), train, "A", "B")
    controller = Convex(ConvexProgram(segment, train, trapezoid_grid(segment, points), weights), (0.0, latest),
                        estimator=estimator, lead=lead, hold=TS)
    result = run_loop(Plant(segment, train, truth), controller, TS, noise, plant_step=TS, estimator=estimator,
                      delay=DELAY)
    return result, controller


def row(name, result, controller, train, mass=1.0):
    s = 1e3 * np.array([x for x in controller.solve_seconds if x > 0])
    gaps = np.array(controller.gaps)
    f = controller.fallbacks
    return (f"| {name} | {result.arrival_time_s:.2f} | {result.traction_work / (train.mass * mass):.2f} | "
            f"{signed(result.stop_error_m, 3)} | {result.overspeed_max_kmh:.2f} | {gaps.max():.1e} | "
            f"{np.mean(gaps > 1e-6):.0%} | {controller.softened} | {f['shifted_plan']} / {f['reserve']} / "
            f"{f['full_brake']} | {s.mean():.0f} / {np.percentile(s, 95):.0f} / {s.max():.0f}")


@harness.case("yazhemsky2017_loop.convex", params={"track": "yazhemsky2017_advanced_1km", "time_weight": 10.0,
                                              "energy_weight": 1.0, "latest": 200.0, "points": 500})
def convex_trip(p):
    """Yazhemsky 2017's convex controller at 10 Hz on a trip (Fig. 9.2 by default): arrival, energy, stop, solve ms."""
    train = load_train(ROOT / "trains/yazhemsky2017_commuter.yaml")
    result, controller = drive(train, p["track"], ConvexWeights(time=p["time_weight"], energy=p["energy_weight"]),
                               p["latest"], p["points"])
    s = 1e3 * np.array([x for x in controller.solve_seconds if x > 0])
    return {"arrival_s": result.arrival_time_s, "energy_J_per_kg": result.traction_work / train.mass,
            "stop_error_m": result.stop_error_m, "solve_mean_ms": s.mean(), "solve_max_ms": s.max()}


def power_limited(train, power_kw):
    """The commuter with F <= 1e6 N and F v <= ``power_kw`` instead of its traction loss table."""
    return dataclasses.replace(train, traction=Envelope("force_power", max_force=1e6, max_power=power_kw * 1e3))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=500)
    p.add_argument("--delay", default="0")
    p.add_argument("--power-kw", type=float, default=None)
    p.add_argument("--table1", action="store_true")
    p.add_argument("--figures", nargs="*", default=None, help="Table 1 rows of these figures only (e.g. 9.7)")
    args = p.parse_args()
    global DELAY
    DELAY = args.delay if args.delay == "measured" else int(args.delay)
    print(harness.command(__file__) + "\n")
    train = load_train(ROOT / "trains/yazhemsky2017_commuter.yaml")
    if args.power_kw is not None:
        train = power_limited(train, args.power_kw)
    published = pd.read_csv(ROOT / "tests/data/yazhemsky2017_closed_loop_published.csv", dtype={"figure": str})
    head = ("| trip | arrival [s] | energy [J/kg] | stop error [m] | overspeed [km/h] | max abs(rho s - 1) | "
            "solves with gap > 1e-6 | windows dropped | fallbacks shifted / reserve / full | solve mean / p95 / max [ms] | "
            "published: arrival, energy, stop |")
    print(head + "\n|" + "---|" * 11)
    runs = {}
    for c in published.to_dict("records"):
        if args.figures and c["figure"] not in args.figures:
            continue
        result, controller = drive(train, c["track"], ConvexWeights(time=c["time_weight"], energy=c["energy_weight"]),
                                   c["latest_s"], args.points)
        runs[c["figure"]] = result
        print(row(f"Fig. {c['figure']} ({c['time_weight']:g}/{c['energy_weight']:g}, T_max {c['latest_s']:g} s)",
                  result, controller, train)
              + f" | {c['published_time_s']}, {c['published_energy_J_per_kg']}, {signed(c['published_stop_m'] - 1000, 2)} |")
    if args.table1:
        return
    leader = runs["9.4"]
    follower, controller = drive(train, "yazhemsky2017_advanced_1km", ConvexWeights(time=10.0, energy=1.0), 300.0,
                                 args.points, lead=leader_clock(leader.states, 100.0))
    x_lead = np.array([s.position for s in leader.states])
    t_lead = np.array([s.time for s in leader.states])
    gaps = [np.interp(s.time, t_lead, x_lead) - s.position for s in follower.states
            if s.position > 0.0 and s.time <= t_lead[-1]]
    print(row("Fig. 9.5 follower (10/1), 100 m behind 9.4", follower, controller, train)
          + f" | 101.53, 199.90, -0.13 (smallest gap here {min(gaps):.2f} m) |")
    print("\n| Ch. 10 trip (5 km representative, 1/0.1, T_max 360 s, K = 300) | arrival [s] | energy [J/kg] | "
          "stop error [m] | overspeed [km/h] | max abs(rho s - 1) | solves with gap > 1e-6 | windows dropped | "
          "fallbacks shifted / reserve / full | solve mean / p95 / max [ms] | mass estimate (1 % from the truth after) |")
    print("|" + "---|" * 11)
    noise = Noise(acceleration=0.05, position=0.01, speed=0.01, seed=3, period=1.0, accelerometer=0.01)
    cases = [("nominal", Truth(), Noise(), False), ("noise", Truth(), noise, False),
             ("20 % heavier, no estimator", Truth(mass=1.2), Noise(), False),
             ("20 % heavier, estimator", Truth(mass=1.2), Noise(), True),
             ("20 % heavier, noise, estimator", Truth(mass=1.2), noise, True)]
    for name, truth, n, with_estimator in cases:
        estimator = MassEstimator() if with_estimator else None
        result, controller = drive(train, "yazhemsky2017_5km_representative", ConvexWeights(time=1.0, energy=0.1), 360.0,
                                   300, truth, n, estimator)
        note = ""
        if estimator is not None:
            off = [x for x, m in estimator.history if x is not None and abs(m - truth.mass) > 0.01 * truth.mass]
            note = f"{estimator.estimate:.4f} ({max(off, default=0.0):.0f} m)"
        print(row(name, result, controller, train, truth.mass) + f" | {note} |")


if __name__ == "__main__":
    main()
