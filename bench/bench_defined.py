"""The space NLP written with its named expressions as AMPL defined variables, measured against
ecostudy as it ships (every named expression written inline, the end speeds fixed).

    pip install -e '.[bench]'    # CasADi, which bench/bench_lean.py (the cases' set-up) imports
    PYTHONPATH=$PWD .venv/bin/python bench/bench_defined.py [--points 1000 5000] [--repeat 3] [--case long metro]

Three variants of one model (``ocp.problem.build``, the cases of ``bench/bench_lean.py``), alternated
in one process, each build + NL write + Ipopt (``ocp.session.Session``) from the same start:

- ``shipped``: as ecostudy solves it (standstill at both ends by fixing the end speeds, written inline);
- ``bounds``: the end speeds held by equal bounds instead (Ipopt takes such a variable out of its
  problem, ``fixed_variable_treatment make_parameter``), still written inline;
- ``defined``: held by bounds, and written with defined variables (the model then has no fixed
  variable, the case in which Pyomo's writer evaluates right: ``bench/check_defined.py``): a table
  envelope once per node instead of inline in the two rows of its intervals, an interval time once.

The garbage of the variant before is collected first (a collection during Ipopt's callbacks walks
every Pyomo object alive and counts as function evaluations). Medians of ``--repeat`` of the
process's CPU seconds (build, NL write, solve) and, from Ipopt's own
timers of each solve (``print_timing_statistics``), of the CPU seconds of its whole algorithm and of
its function evaluations, per solve and per iteration; the iterations and the energy of the last.
"""
import argparse
import gc
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from bench.bench_lean import TIMER, setup  # noqa: E402
from bench.check_defined import held_by_bounds  # noqa: E402
from ecostudy.core.units import to_kwh  # noqa: E402
from ecostudy.ocp import problem, session, solver  # noqa: E402

PARAMS = {"case": "long", "points": 1000}
VARIANTS = ("shipped", "bounds", "defined")
FOLDER = Path(tempfile.mkdtemp(prefix="bench_defined_"))


def run(variant: str, state) -> dict:
    case, running_time, objective, guess, p = state
    gc.collect()  # the models of the variants before: a collection inside Ipopt's callbacks would walk them
    t0 = time.process_time()
    m = problem.build(case, guess, objective, {}, running_time=running_time)
    if variant != "shipped":
        held_by_bounds(m)
    t1 = time.process_time()
    options = {"export_defined_variables": variant == "defined"}
    session.NL_OPTIONS, shipped = options, session.NL_OPTIONS  # read by Session when it writes
    try:
        s = session.Session(m)
    finally:
        session.NL_OPTIONS = shipped
    t2 = time.process_time()
    path = FOLDER / f"{variant}_{p['case']}_{p['points']}.txt"
    outcome = s.solve({"print_timing_statistics": "yes", "output_file": str(path), "file_print_level": 5})
    t3 = time.process_time()
    cpu = {name.strip(): float(c) for name, c, _, _ in TIMER.findall(path.read_text())}
    return {"iterations": outcome.iterations, "ipopt": outcome.status, "stages": {"build": t1 - t0, "write": t2 - t1,
            "solve": t3 - t2}, "algorithm_cpu_s": cpu["OverallAlgorithm"],
            "functions_cpu_s": cpu["Function Evaluations"], "energy_kWh": to_kwh(float(m.objective.expr()) * m.energy_ref)}


for _variant in VARIANTS:
    harness.register(f"defined.{_variant}", lambda state, v=_variant: run(v, state), params=PARAMS, setup=setup,
                     reference=None if _variant == "shipped" else "defined.shipped",
                     doc=f"the space NLP, variant {_variant} (module docstring)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, nargs="+", default=[1000, 5000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--case", nargs="+", default=["long", "metro"])
    args = ap.parse_args()
    solver.configure()
    print(harness.command(__file__) + "\n")
    table = harness.Table(["case", "K", "variant", "CPU s", "write s", "solve s", "iterations", "Ipopt CPU s",
                           "functions CPU s", "Ipopt ms / iteration", "functions ms / iteration", "kWh",
                           "Ipopt CPU vs shipped"])
    for name in args.case:
        for points in args.points:
            runs = harness.measure([f"defined.{v}" for v in VARIANTS], args.repeat, {"case": name, "points": points})
            base = runs["defined.shipped"].median("algorithm_cpu_s")
            for variant in VARIANTS:
                r = runs[f"defined.{variant}"]
                it = r.last("iterations")
                table.add(name, points, variant, f"{r.median('cpu_s'):.2f}", f"{r.median('write_s'):.2f}",
                          f"{r.median('solve_s'):.2f}", f"{it} ({r.last('ipopt')})", f"{r.median('algorithm_cpu_s'):.3f}",
                          f"{r.median('functions_cpu_s'):.3f}", f"{1e3 * r.median('algorithm_cpu_s') / it:.1f}",
                          f"{1e3 * r.median('functions_cpu_s') / it:.2f}", f"{r.last('energy_kWh'):.6f}",
                          f"{r.median('algorithm_cpu_s') / base:.2f}x")


if __name__ == "__main__":
    main()
