"""RSPC (Farooqi 2018 Ch. 6, ``control/rspc.py``) on the Amsterdam metro case (76 s) and the regional
case of Farooqi 2018 §6.3 (808 m, 80 s), at T_s = 0.38 s, plant stepped at the sample.

    .venv/bin/python bench/bench_rspc.py [--horizons 1 2 3 4] [--disturbances 0.1 0.05]
    .venv/bin/python bench/bench_rspc.py --step-costs [--horizons 1 2 3 4 5 6] [--loop-study STUDY]
        [--states 12] [--repeat 3] [--run-horizons 1 2 3 4 5 6]

Table 1: the references of Table 6.1 on each case, scored by the independent simulator: the
industrial eco-drive coasting strategy at the timetable and the all-out run. Table 2: RSPC with
the default settings (N = 3, D = 25 m, gamma_S = 0.995) on the model train and on the trains d
heavier with resistance, traction and braking d weaker (and d lighter with them d stronger), then
N swept on the model train: energy at the wheel, arrival, stop error, overspeed, solve time per
sample (the enumeration of 6^N sequences), mode changes, samples without an admissible sequence.

``--step-costs``: what one step of the enumeration costs at each horizon N, on the RSPC controller
of a closed-loop study (``studies/metro_monte_carlo.yaml``: the Amsterdam case at K = 100, T_s =
0.38 s, built as the study builds it), in this one process: the states of its N = 3 run on draw 0's
true train (without noise) up to the stopping curve (after it no sequence is enumerated),
``--states`` of them evenly spaced; every N's ``best`` timed on each of them in turn, ``--repeat``
rounds (so a load change slows every N alike): the median CPU ms a step (``time.process_time``) and
its ratio to N = 3's, beside the sequences m^N of m modes (``estimate.rspc_scale``'s count), the
candidates the enumeration predicted to the horizon's last step and its model evaluations
(``Rspc._accel`` calls) after the pruning, medians over the states. ``--run-horizons``: then each
of those N's whole run of draw 0 (``closedloop.run_loop_case``, set-up, noise and deviations as the
study has them): CPU a sample against ``estimate.check_closed_loop``'s estimate of the run
(docs/guards.md, "RSPC's horizon").
"""
import argparse
import sys
import time
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
from ecostudy.ocp.phases import sequences  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402
from ecostudy.studies.closedloop import _inputs, build_controller, controller_spec, expand, run_loop_case  # noqa: E402
from ecostudy.studies.estimate import check_closed_loop, rspc_scale  # noqa: E402


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


class Counted(Rspc):
    """An RSPC controller that counts its model evaluations in ``best`` and those of the last step
    (the candidates predicted to the horizon's end)."""

    def best(self, position, speed, clock):
        starts, lengths, _ = self.steps(position, speed)
        self.last_mid = starts[-1] + 0.5 * lengths[-1] if starts else None
        self.evaluations = self.candidates = 0
        return super().best(position, speed, clock)

    def _accel(self, x_mid, v, control):
        self.evaluations += 1
        self.candidates += x_mid == self.last_mid
        return super()._accel(x_mid, v, control)


def with_horizon(case, horizon):
    """A closed-loop study's case with its RSPC controller's horizon N set."""
    spec = case["controller"]
    return {**case, "controller": {**spec, "rspc": {**spec.get("rspc", {}), "horizon": horizon}}}


def rspc_planner(case, horizon):
    """(the RSPC controller of a closed-loop study's case with the horizon N set, built as the study
    builds it; its segment and model train)."""
    case = with_horizon(case, horizon)
    track, train, segment = _inputs(case)
    return build_controller(case, track, segment, train, None)[1], (segment, train)


def step_costs(case, horizons, count, repeat):
    """The CPU of one enumerating step at each horizon (module docstring, ``--step-costs``)."""
    planner, (segment, train) = rspc_planner(case, 3)
    ts = case["sample_time"]
    run = run_loop(Plant(segment, train, Truth(**case["truth"])), planner, ts, plant_step=ts)
    states = []
    for s in run.states:
        if planner.must_brake(s.position, s.speed):
            break
        states.append(s)
    chosen = [states[i] for i in np.linspace(0, len(states) - 1, count).round().astype(int)]
    print(f"{case['study']}, {case['labels']['controller']}: {len(states)} samples of {ts:g} s enumerate before the "
          f"stopping curve (of {len(run.states)}); {len(chosen)} of them timed, {repeat} rounds\n")
    planners = {n: rspc_planner(case, n)[0] for n in horizons}
    cpu = {n: [] for n in horizons}
    for _ in range(repeat):
        for s in chosen:
            for n in horizons:
                t0 = time.process_time()
                planners[n].best(s.position, s.speed, s.time)
                cpu[n].append(time.process_time() - t0)
    counts = {}
    for n in horizons:
        counted = planners[n]
        counted.__class__ = Counted
        made = [(counted.best(s.position, s.speed, s.time), counted.candidates, counted.evaluations)[1:] for s in chosen]
        counts[n] = np.median(np.array(made), axis=0)
    base = np.median(cpu[3]) if 3 in cpu else np.nan
    table = harness.Table(["N", "sequences m^N", "estimate's scale", "candidates at the last step (median)",
                           "model evaluations (median)", "CPU ms a step: median (min - max)", "mean",
                           "median's ratio to N = 3"])
    modes = len(planners[horizons[0]].modes)
    for n in horizons:
        ms = 1e3 * np.array(cpu[n])
        table.add(n, f"{sequences(modes, n):,}", f"{rspc_scale(n, modes):.3g}", f"{counts[n][0]:,.0f}",
                  f"{counts[n][1]:,.0f}", f"{np.median(ms):.2f} ({ms.min():.2f} - {ms.max():.2f})", f"{ms.mean():.2f}",
                  f"{np.median(cpu[n]) / base:.3g}")


def whole_runs(case, horizons):
    """Each horizon's whole run of the case (``closedloop.run_loop_case``, set-up included): CPU a
    sample against ``estimate.check_closed_loop``'s estimate of the same run."""
    print()
    table = harness.Table(["N", "status", "samples", "CPU s", "CPU ms a sample", "estimate s", "estimate / CPU"])
    for n in horizons:
        c = with_horizon(case, n)
        estimate = check_closed_loop([c], case["study"])[0]
        r = harness.sample(run_loop_case, c)
        samples = r["summary"]["samples"]
        table.add(n, r["status"], samples, f"{r['cpu_s']:.1f}", f"{1e3 * r['cpu_s'] / samples:.1f}", f"{estimate:.1f}",
                  f"{estimate / r['cpu_s']:.2f}")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sample", type=float, default=0.38)
    p.add_argument("--horizons", type=int, nargs="*", default=[1, 2, 3, 4])
    p.add_argument("--disturbances", type=float, nargs="*", default=[0.1, 0.05])
    p.add_argument("--step-costs", action="store_true", help="time one enumerating step at each of --horizons")
    p.add_argument("--loop-study", type=Path, default=ROOT / "studies/metro_monte_carlo.yaml")
    p.add_argument("--states", type=int, default=12)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--run-horizons", type=int, nargs="*", default=[],
                   help="with --step-costs: the horizons whose whole run of draw 0 is timed too")
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    if args.step_costs:
        case = next(c for c in expand(args.loop_study)[2]
                    if controller_spec(c)["kind"] == "rspc" and c["labels"]["draw"] == 0)
        step_costs(case, args.horizons, args.states, args.repeat)
        return whole_runs(case, args.run_horizons) if args.run_horizons else None
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
