"""Cost of a network study's leg solves, one strategy at a time in one process.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_leg_solves.py studies/network_metro_3trains.yaml \
        receptivity triggering voltage dissension following [--leg-options '{"tol": 1e-6}']

Plans the study's fleet, solves the independent runs (the start of every other strategy), then
each named strategy from them as ``ecostudy network`` does (``strategies.one_strategy``), noting
every Ipopt solve. Per strategy: substation energy [kWh], the process's CPU seconds for it (less
sensitive than wall time to other work on a shared machine), solves, Ipopt iterations, cold solves
(the warm-against-cold check and relaxed-first pairs) with their iterations and CPU seconds, and
the largest leg's variables and rows. ``--leg-options``: Ipopt options added to the legs' own
(``ocp.solver.IPOPT["leg"]``) for this run, the independent runs included; ``--warm-options``: added to
the options of the solves that start near a feasible run (``legs.NEAR_START``: the warm legs and the
second solve of a cold leg relaxed first). ``--warm-relaxed B``:
warm legs that hold the one-handle rows are solved first with those rows relaxed to B kN^2, then at
their own bound from there, as cold legs are (``legs._relaxed_first``; measured, not adopted).
``--solves FILE``: every solve (variables, rows, iterations, CPU s, warm) per strategy as JSON, and
the iterations' median, 90th percentile and largest printed. Iterations and energies do not depend
on the machine; seconds do.
"""
import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.ocp import solver  # noqa: E402

solver.configure()

import pyomo.environ as pyo  # noqa: E402

from ecostudy.network import legs  # noqa: E402
from ecostudy.network.scoring import evaluate  # noqa: E402
from ecostudy.network.strategies import one_strategy, solve_independent  # noqa: E402
from ecostudy.ocp import session, timedomain  # noqa: E402
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


def warm_relaxed(bound):
    """``legs._solve`` with each warm leg that holds one-handle rows solved relaxed to ``bound`` first."""
    plain = legs._solve

    def solve(nlp, cold=False, retry=True):
        if not nlp.task[5] or cold or not nlp.relax(bound):
            return plain(nlp, cold, retry)
        first = nlp.solve({**legs.NEAR_START, **legs.KKT}, nlp.start(False))
        nlp.relax(timedomain.ONE_HANDLE)
        if first.usable:
            outcome = nlp.solve({**legs.NEAR_START, **legs.KKT})
            if outcome.usable:
                return timedomain.leg_arrays(nlp.block), outcome, float(pyo.value(nlp.model.objective))
        return plain(nlp, cold, retry)
    return solve


def spread(solves):
    """Iterations per solve: median, 90th percentile, largest."""
    its = sorted(s[2] for s in solves)
    return f"per solve: median {statistics.median(its):.0f}, p90 {its[int(0.9 * (len(its) - 1))]}, largest {its[-1]}"


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
    p.add_argument("--warm-options", default="{}", help="JSON: Ipopt options added to the warm legs' own (legs.NEAR_START)")
    p.add_argument("--warm-relaxed", type=float, help="warm legs' one-handle rows relaxed to this [kN^2] first")
    p.add_argument("--solves", help="JSON file: every solve of every strategy")
    a = p.parse_args()
    legs.KKT.update(json.loads(a.leg_options))
    legs.NEAR_START.update(json.loads(a.warm_options))
    if a.warm_relaxed is not None:
        legs._solve = warm_relaxed(a.warm_relaxed)
    noted_solves = {}
    session.Session.solve = noted(session.Session.solve)
    with tempfile.TemporaryDirectory() as out:
        fleet = expand_network(a.study, out=out).cases[0]["fleet"]
        SOLVES.clear()  # the plan's space-domain runs
        c0 = time.process_time()
        ind, wall = solve_independent(fleet)
        print(line("independent", evaluate(fleet, ind)[2]["substation_kWh"], time.process_time() - c0, SOLVES), flush=True)
        noted_solves["independent"] = list(SOLVES)
        for name in a.strategies:
            SOLVES.clear()
            c0 = time.process_time()
            res = one_strategy(fleet, name, ind, wall)
            if "totals" not in res:
                print(f"{name:12s} failed: {res.get('failed')}", flush=True)
                continue
            print(line(name, res["totals"]["substation_kWh"], time.process_time() - c0, SOLVES), flush=True)
            print(f"{'':12s} {spread(SOLVES)}", flush=True)
            noted_solves[name] = list(SOLVES)
    if a.solves:
        Path(a.solves).write_text(json.dumps(noted_solves))

if __name__ == "__main__":
    main()
