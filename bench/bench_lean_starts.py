"""The long case of ``bench_lean.py`` at large K: MUMPS's options and starts from a coarser solve.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_lean_starts.py [--points 5000] [--repeat 1] [--only capped|mumps|starts]

tracks/regional_line_20stops.yaml S01 to S20 with trains/regional_alstom.yaml, net energy, in 1.15
times its envelope time, as ``bench_lean.py``'s ``long`` case. Each row builds, writes and solves
the NLP at ``--points`` (CPU seconds of this process, medians of ``--repeat`` rounds, the rows
alternated in each round):

- ``mumps``: from the capped-speed start (``problem.capped_guess``) with one MUMPS option changed
  (the orderings, the workspace's ``mumps_mem_percent``);
- ``starts``: from the speeds of a solve at a coarser K interpolated onto the grid
  (``problem.warm_guess``), with Ipopt's defaults or a smaller barrier parameter and bound push;
  the coarse solve (build, write, solve) is counted in the row's CPU seconds.

Ipopt's timers (``print_timing_statistics``) give the linear system's and function evaluations'
CPU seconds (the last round's). Energies are compared with the first row's.
"""
import argparse
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.types import Trajectory  # noqa: E402
from ecostudy.core.units import signed, to_kwh  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import problem, session, solver, space  # noqa: E402

TIMER = re.compile(r"^\s*(\w[\w ]*?)\.*:\s+([\d.]+) \(sys", re.M)
CAPPED = {"capped start, MUMPS defaults": {}, "mumps_pivot_order 5 (METIS)": {"mumps_pivot_order": 5},
          "mumps_pivot_order 4 (PORD)": {"mumps_pivot_order": 4}, "mumps_pivot_order 0 (AMD)": {"mumps_pivot_order": 0},
          "mumps_mem_percent 100": {"mumps_mem_percent": 100}}
NEAR = {"mu_init": 1e-3, "bound_push": 1e-6, "bound_frac": 1e-6}
STARTS = {"from K = 500": (500, {}), "from K = 1000": (1000, {}), "from K = 1000, mu_init 1e-3": (1000, {"mu_init": 1e-3}),
          "from K = 1000, mu_init 1e-3, bound_push 1e-6": (1000, NEAR),
          "from K = 1000, mu_init 1e-4, bound_push 1e-8": (1000, {"mu_init": 1e-4, "bound_push": 1e-8, "bound_frac": 1e-8})}


class Solved:
    """A solved model's trajectory, as ``problem.warm_guess`` reads it."""

    def __init__(self, m, case):
        self.trajectory = Trajectory(case.nodes, *space.solution_arrays(m)[:4])


def solve(case, guess, running_time, options, log):
    """Build, write and solve: (model, outcome, Ipopt's CPU seconds by timer)."""
    m = problem.build(case, guess, "net_energy", {}, running_time=running_time)
    outcome = session.Session(m).solve({**options, "print_timing_statistics": "yes", "output_file": log,
                                        "file_print_level": 5})
    return m, outcome, {name.strip(): float(cpu) for name, cpu in TIMER.findall(Path(log).read_text())}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=5000)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--only", choices=["capped", "mumps", "starts"], help="capped: the first row only")
    args = ap.parse_args()
    solver.configure()
    track, train = load_track(ROOT / "tracks/regional_line_20stops.yaml"), load_train(ROOT / "trains/regional_alstom.yaml")
    cases = {k: problem.prepare(track, train, "S01", "S20", k) for k in (args.points, 500, 1000)}
    case = cases[args.points]
    running_time = round(1.15 * case.estimate)
    rows = {name: (None, opts) for name, opts in CAPPED.items()} if args.only != "starts" else {}
    rows.update({} if args.only in ("capped", "mumps") else STARTS)
    rows = dict(list(rows.items())[:1]) if args.only == "capped" else rows
    samples = {name: [] for name in rows}
    log = str(Path(tempfile.mkdtemp()) / "ipopt.txt")
    for _ in range(args.repeat):
        for name, (coarse, options) in rows.items():
            c0 = time.process_time()
            guess = problem.capped_guess(case, running_time)
            if coarse is not None:
                small = cases[coarse]
                m, _, _ = solve(small, problem.capped_guess(small, running_time), running_time, {}, log)
                guess = problem.warm_guess(Solved(m, small), case)
            m, outcome, timers = solve(case, guess, running_time, options, log)
            samples[name].append((time.process_time() - c0, outcome, timers, to_kwh(float(m.objective.expr()) * m.energy_ref)))
    print(harness.command(__file__) + "\n")
    table = harness.Table(["variant", "CPU s", "iterations", "linear system CPU s", "function evaluations CPU s",
                           "kWh", "difference %"])
    first = None
    for name, runs in samples.items():
        _, outcome, timers, kwh = runs[-1]
        first = kwh if first is None else first
        table.add(name, f"{statistics.median(r[0] for r in runs):.2f}", f"{outcome.iterations} ({outcome.status})",
                  f"{timers.get('PDSystemSolverTotal', float('nan')):.2f}",
                  f"{timers.get('Function Evaluations', float('nan')):.2f}", f"{kwh:.6f}", signed(100 * (kwh - first) / first, 5))


if __name__ == "__main__":
    main()
