"""Where the time of a closed-loop Monte Carlo study goes: a few draws of each controller, run
one after the other in this process, timed in CPU seconds (``time.process_time``: on a busy
machine less misleading than the wall clock) and wall seconds, and the whole study projected.

    .venv/bin/python bench/bench_monte_carlo.py studies/metro_monte_carlo.yaml [--draws 0 1] [--only NAME ...] [--cores 2]

Per controller: samples per run, CPU and wall seconds per run, the mean solve time per sample
[ms], the stop error and energy of each draw (to compare a cheaper setting's results with the
shipped one's), and the projected CPU time of all its runs. The projection of the whole study
is the sum over controllers of (draws x CPU per run) over ``--cores`` (the study's workers run
one case each; the cases are many, so they share the cores evenly).
"""
import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.ocp.solver import configure  # noqa: E402
from ecostudy.studies.closedloop import _trip, expand  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study", type=Path)
    p.add_argument("--draws", type=int, nargs="*", default=[0, 1])
    p.add_argument("--only", nargs="*", default=None)
    p.add_argument("--cores", type=int, default=2)
    args = p.parse_args()
    print(f"`python bench/bench_monte_carlo.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    configure()
    study, _, cases = expand(args.study)
    print("| controller | draw | status | samples | CPU s | wall s | solve mean ms | stop error m | energy J/kg |\n"
          "|---|---|---|---|---|---|---|---|---|")
    total = 0.0
    for spec in study.controllers:
        if args.only and spec.name not in args.only:
            continue
        cpu = []
        for case in cases:
            if case["labels"]["controller"] != spec.name or case["labels"]["draw"] not in args.draws:
                continue
            c0, w0 = time.process_time(), time.perf_counter()
            status, error, s = _trip(case)
            cpu.append(time.process_time() - c0)
            print(f"| {spec.name} | {case['labels']['draw']} | {status} | {s['samples']} | {cpu[-1]:.1f} | "
                  f"{time.perf_counter() - w0:.1f} | {s['solve_mean_ms']:.1f} | {s['stop_error_m']:+.3f} | "
                  f"{s['energy_J_per_kg']:.1f} |", flush=True)
        projected = study.draws * float(np.mean(cpu))
        total += projected
        print(f"| {spec.name} | all {study.draws} | projected | | {projected / 60:.1f} CPU min | | | | |", flush=True)
    print(f"\nprojected: {total / 60:.1f} CPU min, {total / 60 / args.cores:.1f} min on {args.cores} cores")


if __name__ == "__main__":
    main()
