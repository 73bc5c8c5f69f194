"""Where a heavy-haul run's energy goes, phase by phase and kilometre by kilometre: the hill start's
hold, the release of the wagons' brakes after it, the rest of the run (docs/heavyhaul.md, "A line
nobody here wrote", the hill start with air brakes).

    PYTHONPATH=$PWD python bench/heavyhaul_hold_energy.py STUDY.yaml [--full-hold | --hold-scale X] [--json OUT]

runs the study's first case (one run, as ``ecostudy heavyhaul`` does: :func:`ecostudy.studies.heavyhaul.drive`)
and prints traction, dynamic and wagon brake works and the plant's losses (running, curve, grade,
coupler damping, draft gear) per phase and per km of the head's position. ``--full-hold`` holds the
standing train on every wagon's full brake instead of :meth:`CascadePlant.holding_brakes` (what the
hold applied before the hold was the brake that holds the grade), on the same code.
"""
import argparse
import json

import numpy as np

from ecostudy.core.units import KN, KWH
from ecostudy.heavyhaul import plant as plant_module
from ecostudy.studies.heavyhaul import _run, expand

WORKS = ("traction", "dynamic_brake", "wagon_brake")
LOSSES = plant_module.LOSSES
RELEASED = 1 * KN  # [N]: the wagons' brakes summed below this are released


def recorder(rows):
    """The plant's step and hold, each appending its works and losses to ``rows``."""
    step, hold = plant_module.CascadePlant.step, plant_module.CascadePlant.hold

    def note(plant, before, out, held):
        s = out.state
        rows.append({"t0": before.time, "t1": s.time, "held": held,
                     "head": float(s.positions[0] + 0.5 * plant.consist.length[0]),
                     "speed": float(np.dot(plant.consist.mass, s.speeds) / plant.consist.mass.sum()),
                     "brakes_kN": 0.0 if s.brakes is None else float(-np.sum(s.brakes)) / KN,
                     **dict(zip(WORKS, (out.traction_work, out.dynamic_brake_work, out.wagon_brake_work))),
                     **dict(zip(LOSSES, out.losses))})
        return out

    def stepped(self, state, requested, dt):
        return note(self, state, step(self, state, requested, dt), False)

    def held(self, state, dt, *args):
        return note(self, state, hold(self, state, dt, *args), True)

    return stepped, held


def phases(rows):
    """Each row's phase: 'hold', 'release' (after the last hold until the wagons' brakes are released), 'rest'."""
    last = max([i for i, r in enumerate(rows) if r["held"]], default=-1)
    out, releasing = [], last >= 0
    for i, r in enumerate(rows):
        if i <= last:
            out.append("hold")
            continue
        out.append("release" if releasing else "rest")
        releasing = releasing and r["brakes_kN"] > RELEASED / KN
    return out


def totals(rows, keys):
    return {k: sum(r[k] for r in rows) / KWH for k in (*WORKS, *LOSSES)} | {"steps": len(rows), "from_s": rows[0]["t0"] if rows else None,
                                                                             "to_s": rows[-1]["t1"] if rows else None}


def by_km(rows, length):
    """Per piece of ``length`` [m] of the head's travel: the works and losses in it [kWh] (each step's
    spread evenly over the distance it ran; the hold runs none) and when the head reached its end [s]."""
    heads = np.array([0.0] + [r["head"] for r in rows])
    times = np.array([rows[0]["t0"]] + [r["t1"] for r in rows])
    reached = np.maximum.accumulate(heads)  # the head's farthest: a step that creeps back adds nothing
    out = {}
    for key in (*WORKS, *LOSSES):
        total = np.concatenate([[0.0], np.cumsum([r[key] for r in rows])]) / KWH
        marks = np.arange(0.0, reached[-1] + length, length)
        at = np.interp(marks, reached, total)
        for lo, value in zip(marks[1:], np.diff(at)):
            out.setdefault(f"{lo / 1e3:g}", {})[key] = float(value)
    for lo in out:
        out[lo]["at_s"] = float(np.interp(float(lo) * 1e3, reached, times))
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("study")
    parser.add_argument("--full-hold", action="store_true")
    parser.add_argument("--hold-scale", type=float, help="hold on this many times the brake that holds the grade "
                        "(at most every wagon's full brake)")
    parser.add_argument("--km", type=float, default=1.0)
    parser.add_argument("--json")
    a = parser.parse_args()
    rows = []
    stepped, held = recorder(rows)
    plant_module.CascadePlant.step, plant_module.CascadePlant.hold = stepped, held
    if a.full_hold:
        plant_module.CascadePlant.holding_brakes = lambda self, positions, creep: np.where(
            self.loco, 0.0, self.envelopes(np.zeros(self.n))[0])
    if a.hold_scale:
        holding = plant_module.CascadePlant.holding_brakes
        plant_module.CascadePlant.holding_brakes = lambda self, positions, creep: np.maximum(
            a.hold_scale * holding(self, positions, creep), np.where(self.loco, 0.0, self.envelopes(np.zeros(self.n))[0]))
    case = expand(a.study)[3][0]
    status, why, summary = _run(case)
    labels = phases(rows)
    out = {"case": case["scenario"], "status": status, "why": why,
           "summary": {k: summary[k] for k in ("energy_total_kWh", "traction_kWh", "dynamic_brake_kWh", "wagon_brake_kWh",
                                               "arrival_late_s", "stop_error_m", "tracking_mean_mps", "force_max_kN",
                                               "held_s") if k in summary},
           "phases": {p: totals([r for r, q in zip(rows, labels) if q == p], None) for p in ("hold", "release", "rest")},
           "km": {}}
    out["km"] = by_km(rows, a.km * 1e3)
    out["rows"] = rows
    print(json.dumps({k: out[k] for k in ("case", "status", "why", "summary")}, indent=1))
    head = f"{'phase':>8} {'steps':>5} {'from-to [s]':>13} " + " ".join(f"{k[:9]:>9}" for k in (*WORKS, *LOSSES))
    print(head)
    for p, t in out["phases"].items():
        if t["steps"]:
            print(f"{p:>8} {t['steps']:5d} {t['from_s']:6.0f}-{t['to_s']:<6.0f} " + " ".join(f"{t[k]:9.1f}" for k in (*WORKS, *LOSSES)))
    print(f"{'to km':>8} {'at [s]':>7} " + " ".join(f"{k[:9]:>9}" for k in (*WORKS, *LOSSES)))
    for km, t in out["km"].items():
        print(f"{km:>8} {t['at_s']:7.1f} " + " ".join(f"{t[k]:9.1f}" for k in (*WORKS, *LOSSES)))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
