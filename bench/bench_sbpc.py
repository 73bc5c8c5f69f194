"""SBPC (Farooqi 2018 Ch. 4) on the Amsterdam case: T_s = 0.38 s, k_f = 200 (76 s).

    .venv/bin/python bench/bench_sbpc.py [--sample 0.38] [--blocks 45 20 1] [--disturbances 0.1 0.05 0.02]
        [--sppc] [--transcription condensed]
    .venv/bin/python bench/bench_sbpc.py --draws 20 [--workers 2] [--only sbpc_multi ...] [--study FILE]

With ``--draws N``: the stop over N random draws (``studies/metro_terminal.yaml``, its draws set
to N: mass, resistance, traction and braking uniform within +-10 %, DAS levels, Yazhemsky 2017
Ch. 10 noise, one sample of computation delay), per controller of the study: the stop error (max
|e|, median), the arrival against the timetable (median, max), the energy per kg against the same
controller on the model train without noise (mean ratio, over the runs that arrived), the statuses and the wall time of a
run; per run (stderr) the lateness split in two: the plan part (the earliest stand on the mark
from the true state where the terminal approach's first handle acts, coasting then braking in
full on the draw's own brake, against the timetable) and the approach part (the run's stand
against that earliest one). The time SBPC nominal L = 1 takes for the 200 samples: ``--blocks 1
--disturbances`` (run wall, and the process's CPU seconds: on a busy machine the better measure).

Table 1 (Table 4.1's trend): the nominal SBPC for each L on the model train: energy at the wheel,
arrival, stop error, solve time per step (mean, max), Ipopt iterations per step, samples where
the nominal problem had no solution and the two-step relaxation stood in. Table 2 (§4.4, Theorem
4.3.1 in practice): the two-step and multi-objective variants (L = 20) driving a train whose
mass is d heavier and whose resistance, traction and braking are d weaker, with the handle
quantised to the DAS levels {-1, 0, 0.5, 0.75, 1}: the terminal error against d. With ``--sppc``
only SPPC (Farooqi 2018 Ch. 5, ``control/sppc.py``; DAS modes by construction): nominal on the model
train, then the two-step variant on the d-disturbed trains.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.control.controllers import Quantised  # noqa: E402
from ecostudy.control.loop import run_loop  # noqa: E402
from ecostudy.control.sbpc import TRANSCRIPTIONS, VARIANTS, Sbpc  # noqa: E402
from ecostudy.control.sppc import Sppc  # noqa: E402
from ecostudy.core.plant import Plant, Truth  # noqa: E402
from ecostudy.core.types import State, Timing  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402
from ecostudy.ocp.solver import configure  # noqa: E402
from ecostudy.studies.cases import case_key  # noqa: E402
from ecostudy.studies.closedloop import case_delay, expand, run_loop_case  # noqa: E402
from ecostudy.studies.workers import worker_pool  # noqa: E402

STUDY = ROOT / "studies/metro_terminal.yaml"


def nominal_case(case):
    """``case`` on the model train without noise (the energy reference of its controller)."""
    quiet = {**case, "truth": dict.fromkeys(case["truth"], 1.0),
             "noise": {**dict.fromkeys(case["noise"], 0.0), "period_s": case["noise"]["period_s"], "seed": 0},
             "labels": {**case["labels"], "draw": "model"}}
    quiet["key"] = case_key({k: v for k, v in quiet.items() if k != "key"})
    return quiet


def earliest_stop(plant, state, distance, dt=0.02):
    """The earliest stand at ``distance`` from ``state`` with the DAS levels 0 and -1 on ``plant``
    (the draw's train, no noise): coast, then brake in full on the train's own brake; the switch
    found by bisection. The clock at the stand [s] (``state``'s clock if even full braking overruns)."""
    def stop(coast):
        s = state
        while s.time < state.time + coast - 1e-9:
            s = plant.step(s, 0.0, min(dt, state.time + coast - s.time)).state
        while True:
            step = plant.step(s, -1.0, dt)
            if step.stood is not None or step.state.speed <= 0.0:
                return step.state.position, step.stood if step.stood is not None else step.state.time
            s = step.state
    lo, hi = 0.0, 60.0
    if stop(0.0)[0] > distance:
        return stop(0.0)[1]
    for _ in range(30):
        lo, hi = (lo, 0.5 * (lo + hi)) if stop(0.5 * (lo + hi))[0] > distance else (0.5 * (lo + hi), hi)
    return stop(lo)[1]


def lateness_parts(case, summary, arrival):
    """(plan part, approach part) [s] of a run's lateness: the earliest stand from the true state
    where the terminal approach's first handle acts (:func:`earliest_stop`) against the timetable,
    and the run's stand against that earliest one. (nan, nan) without an approach."""
    steps = summary.get("steps") or {}
    first = next((i for i, s in enumerate(steps.get("status", [])) if s and s.startswith("terminal_")), None)
    if first is None:
        return float("nan"), float("nan")
    delay = case_delay(case)
    k = min(first + (delay if isinstance(delay, int) else 1), len(steps["time_s"]) - 1)
    track, train = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"), load_train(ROOT / "trains/amsterdam_metro.yaml")
    segment = prepare(track, train, "Rokin", "Centraal", 200).segment
    plant = Plant(segment, train, Truth(**case["truth"]))
    earliest = earliest_stop(plant, State(steps["position_m"][k], steps["speed_mps"][k], steps["time_s"][k]),
                             segment.distance)
    return earliest - arrival, summary["arrival_s"] - earliest


def timed(case):
    """``run_loop_case`` with the run's wall time."""
    row, _, wall = harness.timed(lambda: run_loop_case(case))
    if row["summary"]:
        row["summary"]["parts"] = lateness_parts(case, row["summary"], case["window"][1])
    return case, row, wall


def setup(p):
    """The Amsterdam case (K = 200) and the ATO optimum's speeds SBPC starts from (untimed)."""
    track = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    train = load_train(ROOT / "trains/amsterdam_metro.yaml")
    ato = solve_run(track, train, "Rokin", "Centraal", Timing(running_time=76.0), points=200)
    case = prepare(track, train, "Rokin", "Centraal", 200)
    return track, train, ato, case, np.interp(case.nodes, ato.trajectory.nodes, ato.trajectory.v), p


def loop_report(case, train, controller, driven, truth, sample):
    """Drive the plant with ``driven`` (``controller`` or its quantised handle): energy, arrival, stop, solves."""
    result = run_loop(Plant(case.segment, train, truth), driven, sample, plant_step=sample)
    s = np.array([x for x in controller.solve_seconds if x > 0])
    return {"energy_kWh": result.traction_work / 3.6e6, "arrival_s": result.arrival_time_s,
            "stop_error_m": result.stop_error_m, "overspeed_kmh": result.overspeed_max_kmh, "solve_mean_s": s.mean(),
            "solve_max_s": s.max(), "iterations": float(np.mean(controller.iterations)), "softened": controller.softened}


@harness.case("sbpc.nominal", setup=setup, params={"block": 20, "sample": 0.38, "transcription": "simultaneous"})
def sbpc_nominal(state):
    """Nominal SBPC (Farooqi 2018 Ch. 4) with blocks of L samples driving the model train, Rokin to Centraal in 76 s."""
    _, train, _, case, speeds, p = state
    controller = Sbpc(case, 76.0, p["sample"], p["block"], speeds, "nominal", transcription=p["transcription"])
    return loop_report(case, train, controller, controller, Truth(), p["sample"])


def draws_table(study, draws, workers, only, skip=0, model=True):
    """Run each controller of ``study`` over draws ``skip`` .. ``draws`` - 1 and (``model``) on the model train; a row each."""
    _, _, cases = expand(study)
    chosen = [c for c in cases if skip <= c["labels"]["draw"] < draws and (not only or c["scenario"] in only)]
    print("| controller | draws | stop error max abs / median [m] | within 1 m | arrival - 76 s median / max [s] | "
          "overspeed max [km/h] | energy / model train, mean (min-max) | statuses | run wall mean [s] |\n|"
          + "---|" * 9, flush=True)
    with worker_pool(workers) as pool:
        for name in only or dict.fromkeys(c["scenario"] for c in chosen):
            mine = [c for c in chosen if c["scenario"] == name]
            runs = []
            for case, row, wall in pool.map(timed, [nominal_case(mine[0])] * model + mine):
                runs.append((row, wall))
                s = row["summary"] or {}
                print(f"  {name} draw {case['labels']['draw']}: {row['status']} stop "
                      f"{signed(s.get('stop_error_m', float('nan')), 3)} m, arrival {s.get('arrival_s', float('nan')):.2f} s, "
                      f"{wall:.0f} s wall, overspeed {s.get('overspeed_max_kmh', float('nan')):.2f} km/h, "
                      f"{s.get('energy_J_per_kg', float('nan')):.1f} J/kg, lateness: plan part "
                      f"{signed(s.get('parts', (np.nan,) * 2)[0], 2)} s, approach part {signed(s.get('parts', (np.nan,) * 2)[1], 2)} s",
                      file=sys.stderr, flush=True)
            print(draws_row(name, runs[0][0] if model else None, runs[model:], mine[0]["window"][1]), flush=True)


def draws_row(name, model, runs, arrival):
    """One table row: ``model`` the run on the model train (None: no energy ratio), ``runs`` [(row, wall)] the draws."""
    s = [r["summary"] for r, _ in runs if r["summary"]]
    e = np.array([x["stop_error_m"] for x in s])
    late = np.array([x["arrival_s"] for x in s], float) - arrival
    # the energy of the runs that arrived, as aggregate.csv's (a run short of its stop made no trip)
    ratio = (np.array([x["energy_J_per_kg"] for x in s]) / (model["summary"]["energy_J_per_kg"] if model else np.nan))[
        ~np.isnan(late)]
    statuses = {k: sum(r["status"] == k for r, _ in runs) for k in ("ok", "flagged", "failed")}
    return (f"| {name} | {len(s)} of {len(runs)} | {np.max(np.abs(e)):.3f} / {signed(np.median(e), 3)} | "
            f"{int(np.sum(np.abs(e) <= 1.0))} | {signed(np.median(late), 2)} / {signed(np.max(late), 2)} | "
            f"{max(x['overspeed_max_kmh'] for x in s):.2f} | {ratio.mean():.3f} ({ratio.min():.3f}-{ratio.max():.3f}) | "
            f"{' '.join(f'{k} {n}' for k, n in statuses.items() if n)} | {np.mean([w for _, w in runs]):.0f} |")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sample", type=float, default=0.38)
    p.add_argument("--blocks", type=int, nargs="*", default=[45, 20, 1])
    p.add_argument("--disturbances", type=float, nargs="*", default=[0.1, 0.05, 0.02])
    p.add_argument("--sppc", action="store_true", help="SPPC rows instead of SBPC's")
    p.add_argument("--brake-reserve", type=float, help="share of the brake the plans hold back (default: SBPC 0, "
                   "SPPC 0.1, the controllers' defaults)")
    p.add_argument("--variants", nargs="*", default=["two_step", "multi"], help="SBPC's relaxed variants to run")
    p.add_argument("--block-variant", default="nominal", choices=VARIANTS,
                   help="the variant of the rows for each L on the model train")
    p.add_argument("--transcription", default="simultaneous", choices=TRANSCRIPTIONS,
                   help="SBPC's FHOCP with the states as variables (Ipopt) or condensed to the block handles (SLSQP)")
    p.add_argument("--draws", type=int, help="the stop over this many random draws of --study (see above)")
    p.add_argument("--study", default=STUDY, help="the closed-loop study of --draws")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--only", nargs="*", help="with --draws: only these controllers of the study")
    p.add_argument("--skip", type=int, default=0, help="with --draws: leave out the first SKIP draws (run them apart)")
    p.add_argument("--no-model", action="store_true", help="with --draws: no run on the model train (no energy ratio)")
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    if args.draws:
        configure()
        draws_table(args.study, args.draws, args.workers, args.only, args.skip, not args.no_model)
        return
    track, train, ato, case, speeds, _ = setup({})
    print(f"ATO optimum (space-domain NLP, K = 200, 76 s): {ato.summary['traction_energy_kWh']:.3f} kWh\n")
    table = harness.Table(["variant", "L", "plant", "energy [kWh]", "arrival [s]", "stop error [m]", "overspeed [km/h]",
                           "solve mean / max [s]", "iterations per step", "nominal infeasible", "run wall [s]",
                           "run CPU [s]"])

    def drive(name, block, label, controller, driven, truth):
        """Run the loop and print one table row."""
        r = harness.sample(lambda _: loop_report(case, train, controller, driven, truth, args.sample), None)
        table.add(name, block, label, f"{r['energy_kWh']:.3f}", f"{r['arrival_s']:.2f}", signed(r['stop_error_m'], 3),
                  f"{r['overspeed_kmh']:.2f}", f"{r['solve_mean_s']:.2f} / {r['solve_max_s']:.2f}",
                  f"{r['iterations']:.1f}", r["softened"], f"{r['wall_s']:.0f}", f"{r['cpu_s']:.1f}")

    def run(variant, block, truth, quantised, label):
        controller = Sbpc(case, 76.0, args.sample, block, speeds, variant, brake_reserve=args.brake_reserve or 0.0,
                          transcription=args.transcription)
        drive(variant, block, label, controller, Quantised(controller, train.das_levels) if quantised else controller, truth)

    def run_sppc(variant, truth, label):
        controller = Sppc(solve_run(track, train, "Rokin", "Centraal", Timing(running_time=76.0), points=300), 76.0,
                          variant=variant, **({} if args.brake_reserve is None else {"brake_reserve": args.brake_reserve}))
        drive(f"SPPC {variant}", "-", label, controller, controller, truth)

    if args.sppc:
        run_sppc("nominal", Truth(), "model")
        for d in args.disturbances:
            run_sppc("two_step", Truth(1 + d, 1 - d, 1 - d, 1 - d), f"d = {d:g}")
        return
    for d in args.disturbances:
        for variant in args.variants:
            run(variant, 20, Truth(1 + d, 1 - d, 1 - d, 1 - d), True, f"d = {d:g}, DAS levels")
    for block in args.blocks:
        run(args.block_variant, block, Truth(), False, "model")


if __name__ == "__main__":
    main()
