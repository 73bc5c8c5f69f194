"""Coverage of the calibration's 95 % intervals over generated logs, the identifiability report on a
flat track, and the energy difference `validate` reports against an independent computation.

    .venv/bin/python bench/bench_calibration.py --logs 200            # coverage (a few minutes)
    .venv/bin/python bench/bench_calibration.py --logs 0 --validate   # identifiability and the validate check
    .venv/bin/python bench/bench_calibration.py --example out/logs    # two example logs for docs/calibration.md
    .venv/bin/python bench/bench_calibration.py --logs 0 --held 30    # both intervals where a parameter is held
    .venv/bin/python bench/bench_calibration.py --logs 0 --steep 5    # validate down 40 and 60 per mille
    .venv/bin/python bench/bench_calibration.py --logs 0 --scale 30   # a speed scale off against the mass interval
    .venv/bin/python bench/bench_calibration.py --logs 0 --held-check 40  # held parameters against the logs

Each log: the regional train of Farooqi 2018 §6.3 with true parameters drawn around
the train file (mass +-5 %, Davis A, B, C +-15 %, traction efficiency +-3 %), driven by the plant
over four runs of tracks/calibration_line.yaml (there and back), sampled at 10 Hz with speed noise 0.05 m/s and 1 %
power noise; one calibration per log from the train file's values. Prints one table.
"""
import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.calibration.fit import DEFAULT_FIT, Problem, identify, priors  # noqa: E402
from ecostudy.calibration.generate import (  # noqa: E402
    LogNoise, follow_work, generate_log, level_track, steady_log, steep_track, true_train)
from ecostudy.calibration.validate import validate_log  # noqa: E402
from ecostudy.calibration.estimate import HELD_EXCLUDED, MIN_BOOTSTRAP_LOGS, calibrate_logs, held_against_logs  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.io.logfile import parse_log, write_log  # noqa: E402
from ecostudy.io.logscale import SCALE_ERRORS, SCALE_MASS_BIAS, measured_scale, speed_scale  # noqa: E402

TRAIN, TRACK = ROOT / "trains" / "regional_alstom.yaml", ROOT / "tracks" / "calibration_line.yaml"
STOPS = ["West", "Middle", "East", "Middle", "West"]


def drawn_truth(train, seed):
    rng = np.random.default_rng(10_000 + seed)
    return true_train(train, mass=rng.uniform(0.95, 1.05), davis=tuple(rng.uniform(0.85, 1.15, 3)),
                      efficiency=rng.uniform(0.97, 1.03))


def as_log(frame, name):
    """A generated table as a parsed log (through the file format's text)."""
    text = "---\ntrack: calibration_line.yaml\ntrain: regional_alstom.yaml\n---\n" + frame.to_csv(
        index=False, float_format="%.6f")
    return parse_log(text, f"{name}.csv", name)


def drawn_log(seed):
    """(track, file train, true train, the generated log) of one seed (untimed)."""
    track, train = load_track(TRACK), load_train(TRAIN)
    truth = drawn_truth(train, seed)
    frame, _ = generate_log(track, truth, STOPS, truth, seed=seed)
    return track, train, truth, as_log(frame, f"log{seed}")


@harness.case("calibration.log", params={"seed": 0}, setup=lambda p: drawn_log(p["seed"]))
def calibrate_one(state):
    """One calibration of a generated log (four runs, 10 Hz, noisy) from the train file's values."""
    track, train, _, log = state
    result = calibrate_logs([log], track, train, DEFAULT_FIT)
    return {"status": str(result.status), "drift": result.quality["structure_ratio"],
            "identifiable": int(result.table["identifiable"].sum())}


def one_log(seed):
    """(true parameters, the calibration's table as records, its status, innovation drift, fit seconds)."""
    track, train, truth, log = drawn_log(seed)
    result, _, seconds = harness.timed(lambda: calibrate_logs([log], track, train, DEFAULT_FIT))
    return priors(truth), result.table.to_dict("records"), result.status, result.quality["structure_ratio"], seconds


def coverage(count, workers):
    hits, widths, held, times = {n: [] for n in DEFAULT_FIT}, {n: [] for n in DEFAULT_FIT}, [], []
    drift, flagged = [], 0
    with ProcessPoolExecutor(workers) as pool:
        for true, rows, status, structure, seconds in pool.map(one_log, range(count)):
            times.append(seconds)
            drift.append(structure)
            flagged += status != "ok"
            for row in rows:
                if row["name"] not in hits:
                    continue
                if not row["identifiable"]:
                    held.append(row["name"])
                    continue
                hits[row["name"]].append(row["low"] <= true[row["name"]] <= row["high"])
                widths[row["name"]].append(100 * 0.5 * (row["high"] - row["low"]) / true[row["name"]])
    print(f"{count} logs, one calibration each (fit {np.median(times):.2f} s median, busy machine)")
    print(f"{'parameter':12s} {'fitted':>6s} {'coverage %':>10s} {'median half-width %':>20s}")
    for n in DEFAULT_FIT:
        h = np.array(hits[n])
        print(f"{n:12s} {len(h):6d} {100 * h.mean() if len(h) else float('nan'):10.1f} "
              f"{np.median(widths[n]) if widths[n] else float('nan'):20.3f}")
    print(f"held at the prior (not identifiable): {len(held)} ({', '.join(sorted(set(held))) or 'none'}); "
          f"flagged {flagged} of {count}; residual drift median {np.median(drift):.2f}, max {np.max(drift):.2f}")


def identifiability(track, train):
    flat = level_track(track)
    truth = drawn_truth(train, 0)
    frame, _ = generate_log(flat, truth, STOPS, truth, seed=0)
    result = calibrate_logs([as_log(frame, "flat")], flat, train, ("mass", "rotating_mass_factor", "davis_a"))
    print("flat track, fitting mass, rotating_mass_factor, davis_a:", result.status, "-", result.reason)


def write_examples(folder, track, train):
    """Two logs of the regional train 5 % heavier, with 10 % more running resistance and a traction
    efficiency 3 % lower than its train file says (there and back, two runs each)."""
    folder.mkdir(parents=True, exist_ok=True)
    truth = true_train(train, mass=1.05, davis=(1.1, 1.1, 1.1), efficiency=0.97)
    inside = folder.resolve().parent.parent == ROOT  # out/logs: name the files relative to the log
    header = {"track": str(Path("../../tracks") / TRACK.name) if inside else str(TRACK),
              "train": str(Path("../../trains") / TRAIN.name) if inside else str(TRAIN),
              "source": "generated by bench/bench_calibration.py --example: the plant with known parameters, "
                        "speed noise 0.05 m/s, power noise 1 %, 10 Hz"}
    for name, stops, seed in (("there", STOPS[:3], 1), ("back", STOPS[2:], 2)):
        frame, _ = generate_log(track, truth, stops, truth, seed=seed)
        write_log(folder / f"{name}.csv", header, frame)
        print(f"wrote {folder / name}.csv ({len(frame)} rows)")


def validate_check(count, track, train):
    """validate on logs of the train 5 % heavier with 5 % more resistance (and 5 % lower traction
    efficiency) than its file, against the pointwise computation on the noise-free record."""
    truth = true_train(train, mass=1.05, davis=(1.05, 1.05, 1.05), efficiency=0.95)
    gaps = []
    print("log run  validate %  independent %  gap (points)")
    for seed in range(count):
        frame, clean = generate_log(track, truth, STOPS[:3], truth, seed=100 + seed)
        table = validate_log(as_log(frame, f"v{seed}"), track, train)
        for row, (model, true) in zip(table.itertuples(), follow_work(clean, track, truth, train)):
            independent = 100 * (model - true) / true
            gaps.append(row.traction_difference_pct - independent)
            print(f"{seed:3d} {row.run:3d} {row.traction_difference_pct:11.3f} {independent:14.3f} {signed(gaps[-1], 3):>12}")
    print(f"validate against the independent computation: largest gap {np.max(np.abs(gaps)):.3f} percentage points "
          f"over {len(gaps)} runs (mean {signed(np.mean(gaps), 3)})")


def steep_check(count, train):
    """validate down 40 and 60 per mille (:func:`steep_track`, Top to Bottom, log seeds 1 to ``count``):
    logs of the train file's own train, replayed on it and on the train 5 % heavier."""
    heavier = true_train(train, mass=1.05)
    print("permille seed run  model    stop error m  tolerance m  time %  energy %  status")
    for permille in (40, 60):
        track = steep_track(permille)
        for seed in range(1, count + 1):
            frame, _ = generate_log(track, train, ["Top", "Mid", "Bottom"], train, seed=seed)
            log = as_log(frame, f"steep{permille}_{seed}")
            for name, model in (("same", train), ("heavier", heavier)):
                for row in validate_log(log, track, model).itertuples():
                    print(f"{permille:8d} {seed:4d} {row.run:3d}  {name:8s} {row.model_stop_error_m:12.1f} "
                          f"{row.stop_tolerance_m:12.1f} {row.time_difference_pct:7.2f} "
                          f"{row.traction_difference_pct:9.2f}  {row.status}")


def held_coverage(sets, track, train, draws=200, size=MIN_BOOTSTRAP_LOGS):
    """Both intervals where a parameter is held: sets of ``size`` level constant-speed logs (25 m/s
    for 400 s, log seeds size k + 1 to size k + size; the fewest a bootstrap over logs gives an
    interval from) of the train with A 30 % higher, B half and C 10 % higher than its file,
    calibrated for mass, A, B, C with ``draws`` bootstrap draws; how often each interval holds the
    truth of the parameters reported identifiable."""
    truth = true_train(train, davis=(1.3, 0.5, 1.1))
    true = priors(truth)
    level, hits, held = level_track(track), {}, 0
    for k in range(sets):
        logs = [as_log(steady_log(truth, seed), f"steady{seed}") for seed in range(size * k + 1, size * k + size + 1)]
        result = calibrate_logs(logs, level, train, ("mass", "davis_a", "davis_b", "davis_c"), draws)
        held += not result.table["identifiable"].all()
        for row in result.table[result.table["identifiable"]].itertuples():
            h = hits.setdefault(row.name, [0, 0, 0])
            h[0] += row.low <= true[row.name] <= row.high
            h[1] += row.boot_low <= true[row.name] <= row.boot_high
            h[2] += 1
    print(f"{sets} sets of {size} level constant-speed logs, {draws} bootstrap draws; a parameter held in {held}")
    print("parameter  identified  95 % interval holds truth  bootstrap interval holds truth")
    for name, (gauss, boot, count) in hits.items():
        print(f"{name:10s} {count:10d} {gauss:25d} {boot:31d}")


def example_logs(track, truth, scale=1.0, noise=LogNoise()):
    """The worked example's two logs (there and back, seeds 1 and 2) of ``truth``, speeds times ``scale``."""
    return [as_log(frame.assign(speed_mps=frame["speed_mps"] * scale), name) for name, frame in
            (("there", generate_log(track, truth, STOPS[:3], truth, seed=1, noise=noise)[0]),
             ("back", generate_log(track, truth, STOPS[2:], truth, seed=2, noise=noise)[0]))]


def scale_check(seeds, track, train):
    """A speed sensor off in scale against the fitted mass's interval: the worked example's logs with
    their speeds times 0.998 to 1.005 (the mass's bias, its ratio to the mismatch, its offset in
    half-widths, the status's scale reason); then one log per seed 1 to ``seeds`` as generated (0.05
    and 0.3 m/s speed noise): the largest implied bias, 2 |s - 1|, over the mass's half-width."""
    truth = true_train(train, mass=1.05, davis=(1.1, 1.1, 1.1), efficiency=0.97)
    print("speeds x  measured  mass off %  off / mismatch  half-width %  half-widths off  scale flagged")
    for k in (0.998, 1.0, 1.001, 1.002, 1.005):
        logs = example_logs(track, truth, k)
        result = calibrate_logs(logs, track, train, DEFAULT_FIT, draws=0)
        mass = result.table.set_index("name").loc["mass"]
        off = mass.estimate / truth.static_mass - 1.0
        print(f"{k:8.3f}  {speed_scale(logs[0]):8.5f}  {100 * off:+10.3f}  "
              f"{off / (1.0 - k) if k != 1.0 else float('nan'):14.2f}  {100 * (mass.high - mass.estimate) / mass.estimate:12.3f}"
              f"  {(mass.estimate - truth.static_mass) / (mass.high - mass.estimate):15.1f}  "
              f"{'times the travel of its positions' in result.reason}")
    for sigma in (0.05, 0.3):
        worst, judged, flagged = 0.0, 0.0, 0
        for seed in range(1, seeds + 1):
            frame, _ = generate_log(track, truth, STOPS[:3], truth, seed=seed, noise=LogNoise(speed=sigma))
            log = as_log(frame, f"s{seed}")
            result = calibrate_logs([log], track, train, DEFAULT_FIT, draws=0)
            mass = result.table.set_index("name").loc["mass"]
            (ratio, error), half = measured_scale(log), (mass.high - mass.estimate) / mass.estimate
            worst = max(worst, SCALE_MASS_BIAS * abs(ratio - 1.0) / half)
            judged = max(judged, SCALE_MASS_BIAS * max(abs(ratio - 1.0) - SCALE_ERRORS * error, 0.0) / half)
            flagged += "times the travel of its positions" in result.reason
        print(f"{seeds} logs as generated, speed noise {sigma:g} m/s: implied mass bias at most {worst:.2f} half-widths, "
              f"{judged:.2f} less {SCALE_ERRORS:g} standard errors of the scale; scale flagged in {flagged}")


def held_check(count, track, train):
    """Parameters held at the train file's value (not asked for) against the logs: the worked example's
    logs of the train with its rotating-mass allowance 1.25 times the file's (the status, which
    intervals miss the truth); then ``count`` coverage logs (:func:`drawn_log`; the allowance and the
    regeneration efficiency the file's): how far each held value lies from what the logs give, in
    half-widths of its 95 % interval, and what the check costs against the whole calibration."""
    truth = true_train(train, mass=1.05, davis=(1.1, 1.1, 1.1), efficiency=0.97, rotating=1.25)
    result = calibrate_logs(example_logs(track, truth), track, train, DEFAULT_FIT, draws=0)
    true = priors(truth)
    missed = [r.name for r in result.table.itertuples() if not r.low <= true[r.name] <= r.high]
    print(f"allowance 1.25 times the file's: intervals missing the truth: {', '.join(missed) or 'none'}; "
          f"{result.status}: {result.reason}")
    apart, check, whole = {}, [], []
    for seed in range(count):
        track_, train_, _, log = drawn_log(seed)
        result, _, seconds = harness.timed(lambda: calibrate_logs([log], track_, train_, DEFAULT_FIT, draws=0))
        whole.append(seconds)
        problem = Problem.from_logs([log], track_, train_)
        free, p, *_ = identify(problem, list(DEFAULT_FIT))
        _, _, seconds = harness.timed(lambda: held_against_logs(problem, DEFAULT_FIT, free, p))
        check.append(seconds)
        for name, fit in result.quality["held_fitted"].items():
            apart.setdefault(name, []).append(abs(fit["fitted"] - fit["held"]) / fit["half_width"])
    for name, values in apart.items():
        values = np.array(values)
        print(f"{name}: checked in {values.size} of {count} logs; held value from the logs' at most {values.max():.2f} "
              f"half-widths, beyond 1 in {int((values > 1).sum())}, beyond {HELD_EXCLUDED:g} in "
              f"{int((values > HELD_EXCLUDED).sum())}")
    print(f"the check {np.median(check):.2f} s of a calibration's {np.median(whole):.2f} s (wall, medians, draws 0)")


def noisy_coverage(pairs, track, train):
    """Noisy 1 Hz logs with parameters held: ``pairs`` pairs of logs there and back (seeds 2k + 1, 2k + 2),
    speed noise 0.2 m/s and 3 % power noise, of the train 5 % heavier, with 10 % more running resistance
    and a traction efficiency 3 % lower than its file, calibrated with the default fit against the file:
    how often each parameter is identified and its 95 % interval holds the truth, the mean standardised
    error of each parameter identified, and how often the calibration is flagged."""
    truth = true_train(train, mass=1.05, davis=(1.1, 1.1, 1.1), efficiency=0.97)
    true, noise = priors(truth), LogNoise(speed=0.2, power=0.03, rate=1.0)
    hits, flagged = {}, 0
    for k in range(pairs):
        logs = [as_log(generate_log(track, truth, stops, truth, seed=2 * k + i + 1, noise=noise)[0], f"noisy{2 * k + i + 1}")
                for i, stops in enumerate((STOPS[:3], STOPS[2:]))]
        result = calibrate_logs(logs, track, train, DEFAULT_FIT, draws=0)
        flagged += result.status != "ok"
        for row in result.table[result.table["identifiable"]].itertuples():
            h = hits.setdefault(row.name, [0, 0, []])
            h[0] += 1
            h[1] += row.low <= true[row.name] <= row.high
            h[2].append((row.estimate - true[row.name]) / row.std)
    print(f"{pairs} pairs of 1 Hz logs, speed noise 0.2 m/s, power noise 3 %; calibration flagged in {flagged}")
    print("parameter  identified  95 % interval holds truth  mean standardised error")
    for name in DEFAULT_FIT:
        count, holds, z = hits.get(name, [0, 0, []])
        print(f"{name:10s} {count:10d} {holds:25d} {np.mean(z) if z else np.nan:24.2f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", type=int, default=200)
    parser.add_argument("--validate", action="store_true", help="also the validate check")
    parser.add_argument("--validate-logs", type=int, default=10, help="logs of the validate check")
    parser.add_argument("--workers", type=int, default=1, help="processes for the coverage logs")
    parser.add_argument("--example", type=Path, help="write example logs into this folder and stop")
    parser.add_argument("--held", type=int, default=0, help="sets of five logs of the held-parameter coverage (e.g. 30)")
    parser.add_argument("--steep", type=int, default=0, help="log seeds of the validate check down steep grades")
    parser.add_argument("--scale", type=int, default=0, help="log seeds of the speed-scale check (e.g. 10)")
    parser.add_argument("--held-check", type=int, default=0, help="coverage logs of the held-parameter check (e.g. 40)")
    parser.add_argument("--noisy", type=int, default=0, help="pairs of noisy 1 Hz logs of the held-parameter coverage (e.g. 12)")
    args = parser.parse_args()
    track, train = load_track(TRACK), load_train(TRAIN)
    if args.example:
        return write_examples(args.example, track, train)
    print(harness.command(__file__))
    if args.logs:
        _, _, wall = harness.timed(lambda: coverage(args.logs, args.workers))
        print(f"coverage wall time {wall:.0f} s with {args.workers} worker(s)")
    if args.held:
        _, cpu, wall = harness.timed(lambda: held_coverage(args.held, track, train))
        print(f"held-parameter coverage: {wall:.0f} s wall, {cpu:.0f} s CPU")
    if args.steep:
        _, cpu, wall = harness.timed(lambda: steep_check(args.steep, train))
        print(f"steep-grade check: {wall:.0f} s wall, {cpu:.0f} s CPU")
    if args.scale:
        _, cpu, wall = harness.timed(lambda: scale_check(args.scale, track, train))
        print(f"speed-scale check: {wall:.0f} s wall, {cpu:.0f} s CPU")
    if args.held_check:
        _, cpu, wall = harness.timed(lambda: held_check(args.held_check, track, train))
        print(f"held-parameter check: {wall:.0f} s wall, {cpu:.0f} s CPU")
    if args.noisy:
        _, cpu, wall = harness.timed(lambda: noisy_coverage(args.noisy, track, train))
        print(f"noisy-log coverage: {wall:.0f} s wall, {cpu:.0f} s CPU")
    identifiability(track, train)
    if args.validate:
        validate_check(args.validate_logs, track, train)


if __name__ == "__main__":
    main()
