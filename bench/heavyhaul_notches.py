"""Heavy haul: what the locomotives' notches do to the controller's requests, step by step (the plant's
``notches`` effect; Zhang & Zhuan's Fig. 2 plots the locomotives' throttle notches).

    python bench/heavyhaul_notches.py heavyhaul_brake_penalty_rolling --kb 1 60

Runs the study's cases with ``notches: true`` (in two processes), every plant step recorded: per K_b
the run's E, traction, wagons' braking and stretch braking, then what the rounding did to the
locomotives: in how many steps some locomotive's notch differs from its request by more than 1 %
of a notch, the mean |rounding| in notches, the traction and dynamic braking the rounding added and
removed (each locomotive's (applied - requested) effort times its speed, both at the step's start,
times the step: an estimate, the plant applies the notch's share of the envelope as the speed
changes), and the steps in which a request for traction (dynamic braking) below half a notch went
to idle (off).
"""
import argparse
import sys
import warnings
from multiprocessing import Pool
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ecostudy.core.errors import EcostudyWarning  # noqa: E402
from ecostudy.core.units import KWH  # noqa: E402
from ecostudy.heavyhaul.plant import CascadePlant  # noqa: E402
from ecostudy.studies import heavyhaul as study  # noqa: E402


class Recording(CascadePlant):
    """The real plant, keeping (start state, request, step) of every step it takes."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.taken = []

    def step(self, state, requested, dt):
        result = super().step(state, requested, dt)
        self.taken.append((state, np.asarray(requested, float), dt, result))
        return result


def rounding(plant):
    """What the notches did to the locomotives' requests over the recorded steps (the module's list)."""
    n_t, n_d = plant.notches.traction, plant.notches.dynamic_brake
    off, error, added, removed, idle, released = 0, [], np.zeros(2), np.zeros(2), 0, 0
    for state, requested, dt, step in plant.taken:
        loco = plant.loco
        dynamic, upper = (e[loco] for e in plant.motor_envelopes(state.speeds))
        asked = np.clip(requested[loco], -dynamic, upper)
        level = step.levels[loco]
        applied = np.where(level >= 0, level * upper, level * dynamic)
        notch = np.where(asked >= 0, upper / n_t, dynamic / n_d)
        miss = (applied - asked) / notch
        off += int(np.any(np.abs(miss) > 0.01))
        error.extend(np.abs(miss))
        work = (applied - asked) * np.maximum(state.speeds[loco], 0.0) * dt
        pulling = asked > 0
        added += [work[pulling & (work > 0)].sum(), -work[~pulling & (work < 0)].sum()]
        removed += [-work[pulling & (work < 0)].sum(), work[~pulling & (work > 0)].sum()]
        idle += int(np.any(pulling & (level == 0)))
        released += int(np.any((asked < 0) & (level == 0)))
    return len(plant.taken), off, float(np.mean(error)), added / KWH, removed / KWH, idle, released


def one(job):
    path, kb = job
    warnings.simplefilter("ignore", EcostudyWarning)
    study.CascadePlant = Recording
    _, _, _, cases = study.expand(path)
    case = {**next(c for c in cases if c["labels"]["K_b"] == kb), "notches": True}
    consist, controller, record, reference, plant = study.drive(case)
    s = study.summarise(consist, controller, record, reference, plant.segment.distance, controller.locos)
    return kb, s, rounding(plant)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("study")
    parser.add_argument("--kb", type=float, nargs="+", default=[1.0, 60.0])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    path = ROOT / "studies" / f"{args.study}.yaml"
    with Pool(min(args.workers, len(args.kb))) as pool:
        results = pool.map(one, [(path, kb) for kb in args.kb])
    print("| K_b | E [kWh] | traction | wagons | stretch | steps | off a notch | mean |rounding| [notches] | "
          "traction added / removed [kWh] | dynamic added / removed [kWh] | traction -> idle | dynamic -> off |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for kb, s, (steps, off, mean, added, removed, idle, released) in results:
        print(f"| {kb:g} | {s['energy_total_kWh']:.0f} | {s['traction_kWh']:.0f} | {s['wagon_brake_kWh']:.0f} | "
              f"{s['stretch_braking_kWh']:.1f} | {steps} | {off} | {mean:.3f} | {added[0]:.1f} / {removed[0]:.1f} | "
              f"{added[1]:.1f} / {removed[1]:.1f} | {idle} | {released} |")
