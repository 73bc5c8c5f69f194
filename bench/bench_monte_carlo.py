"""Where the time of a closed-loop Monte Carlo study goes: a few draws of each controller, run
one after the other in this process through ``bench/harness.py`` (case ``monte_carlo.trip``),
timed in CPU seconds (this process and its waited-for children: on a busy machine less misleading
than the wall clock) and wall seconds, and the whole study projected.

    .venv/bin/python bench/bench_monte_carlo.py studies/metro_monte_carlo.yaml [--draws 0 1] [--only NAME ...] [--cores 2]

Per controller: samples per run, CPU and wall seconds per run, the mean solve time per sample
[ms], the stop error and energy of each draw (to compare a cheaper setting's results with the
shipped one's), and the projected CPU time of all its runs. The projection of the whole study
is the sum over controllers of (draws x CPU per run) over ``--cores`` (the study's workers run
one case each; the cases are many, so they share the cores evenly).
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.ocp.solver import configure  # noqa: E402
from ecostudy.studies.closedloop import _trip, expand  # noqa: E402


def setup(p):
    configure()
    return expand(Path(p["study"]))[2][p["case"]]


@harness.case("monte_carlo.trip", setup=setup, params={"study": str(ROOT / "studies/metro_monte_carlo.yaml"), "case": 0})
def trip(case):
    """One closed-loop trip of a Monte Carlo study (a controller, a draw): samples, solve time, stop error, energy."""
    status, error, s = _trip(case)
    return {"status": str(status), "samples": s["samples"], "solve_mean_ms": s["solve_mean_ms"],
            "stop_error_m": s["stop_error_m"], "energy_J_per_kg": s["energy_J_per_kg"]}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study", type=Path)
    p.add_argument("--draws", type=int, nargs="*", default=[0, 1])
    p.add_argument("--only", nargs="*", default=None)
    p.add_argument("--cores", type=int, default=2)
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    configure()
    study, _, cases = expand(args.study)
    table = harness.Table(["controller", "draw", "status", "samples", "CPU s", "wall s", "solve mean ms", "stop error m",
                           "energy J/kg"])
    total = 0.0
    for spec in study.controllers:
        if args.only and spec.name not in args.only:
            continue
        cpu = []
        for case in cases:
            if case["labels"]["controller"] != spec.name or case["labels"]["draw"] not in args.draws:
                continue
            r = harness.sample(trip, case)
            cpu.append(r["cpu_s"])
            table.add(spec.name, case["labels"]["draw"], r["status"], r["samples"], f"{r['cpu_s']:.1f}",
                      f"{r['wall_s']:.1f}", f"{r['solve_mean_ms']:.1f}", signed(r['stop_error_m'], 3),
                      f"{r['energy_J_per_kg']:.1f}")
        projected = study.draws * float(np.mean(cpu))
        total += projected
        table.add(spec.name, f"all {study.draws}", "projected", "", f"{projected / 60:.1f} CPU min", "", "", "", "")
    print(f"\nprojected: {total / 60:.1f} CPU min, {total / 60 / args.cores:.1f} min on {args.cores} cores")


if __name__ == "__main__":
    main()
