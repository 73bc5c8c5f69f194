"""Cost of a network study's leg solves, one strategy at a time in one process.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_solves.py studies/network_metro_3trains.yaml \
        receptivity triggering voltage dissension following [--leg-options '{"tol": 1e-6}']

Plans the study's fleet, solves the independent runs (the start of every other strategy), then
each named strategy from them as ``ecostudy network`` does (``strategies.one_strategy``), noting
every Ipopt solve. Per strategy: substation energy [kWh], the process's CPU seconds for it (less
sensitive than wall time to other work on a shared machine), solves, Ipopt iterations, cold solves
(the warm-against-cold check and relaxed-first pairs) with their iterations and CPU seconds, and
the largest leg's variables and rows. ``--leg-options``: Ipopt options added to the legs' own
(``ocp.solver.IPOPT["leg"]``) for this run, the independent runs included. Iterations and energies
do not depend on the machine; seconds do.
"""
import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.ocp import solver  # noqa: E402

solver.configure()

from ecostudy.network import legs  # noqa: E402
from ecostudy.network.scoring import evaluate  # noqa: E402
from ecostudy.network.strategies import one_strategy, solve_independent  # noqa: E402
from ecostudy.ocp import session  # noqa: E402
from ecostudy.studies.network import expand_network  # noqa: E402

SOLVES: list = []  # (variables, rows, iterations, CPU s, warm) per Ipopt solve


def noted(solve):
    """``Session.solve`` noting each solve in :data:`SOLVES`."""
    def wrapper(self, options=None, x0=None):
        c0 = time.process_time()
        out = solve(self, options, x0)
        warm = bool(options and options.get("bound_push"))  # legs.NEAR_START: a warm leg
        SOLVES.append((self.nlp.n_primals(), self.nlp.n_constraints(), out.iterations, time.process_time() - c0, warm))
        return out
    return wrapper


def line(name, kwh, cpu, solves):
    cold = [s for s in solves if not s[4]]
    return (f"{name:12s} kWh {kwh:.3f} cpu {cpu:6.1f} solves {len(solves):3d} iterations {sum(s[2] for s in solves):5d} "
            f"cold {len(cold)} / {sum(s[2] for s in cold)} it / {sum(s[3] for s in cold):.1f} s "
            f"largest {max(s[0] for s in solves)} vars {max(s[1] for s in solves)} rows")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study")
    p.add_argument("strategies", nargs="+")
    p.add_argument("--leg-options", default="{}", help="JSON: Ipopt options added to the legs' own")
    a = p.parse_args()
    legs.KKT.update(json.loads(a.leg_options))
    session.Session.solve = noted(session.Session.solve)
    with tempfile.TemporaryDirectory() as out:
        fleet = expand_network(a.study, out=out).cases[0]["fleet"]
        SOLVES.clear()  # the plan's space-domain runs
        c0 = time.process_time()
        ind, wall = solve_independent(fleet)
        print(line("independent", evaluate(fleet, ind)[2]["substation_kWh"], time.process_time() - c0, SOLVES), flush=True)
        for name in a.strategies:
            SOLVES.clear()
            c0 = time.process_time()
            res = one_strategy(fleet, name, ind, wall)
            if "totals" not in res:
                print(f"{name:12s} failed: {res.get('failed')}", flush=True)
                continue
            print(line(name, res["totals"]["substation_kWh"], time.process_time() - c0, SOLVES), flush=True)

if __name__ == "__main__":
    main()
