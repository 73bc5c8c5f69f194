"""Ipopt's barrier-parameter strategies on the shipped cold space NLPs: iterations, Ipopt CPU, energy.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_barrier.py [--repeat 3] [--case metro:1000 long:5000 ...]

Each case's NLP is built and written once; every strategy solves it from the same capped-speed
start in this process, the strategies alternated run by run, so the CPU ratios against the
adaptive default (``ocp.solver.IPOPT["space"]``) compare. Iterations and energies do not depend on
the machine; CPU seconds do (medians of ``--repeat``). Cases: ``metro`` (studies/default.yaml's
Rokin-Centraal in 76 s, traction energy), ``long`` (the 22.4 km regional line S01-S20 run through
in 1.15 times its envelope time, net energy, as bench/bench_lean.py), ``regional808``
(studies/regional_80s.yaml, net energy) and ``yazhemsky2017`` (studies/yazhemsky2017_advanced.yaml).
"""
import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.units import signed, to_kwh  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import problem, session, solver  # noqa: E402

CASES = {  # track, train, from, to (None: the first and last stops), running time [s] of the case, objective
    "metro": ("amsterdam_rokin_centraal", "amsterdam_metro", "Rokin", "Centraal", lambda c: 76.0, "energy"),
    "long": ("regional_line_20stops", "regional_alstom", "S01", "S20", lambda c: round(1.15 * c.estimate), "net_energy"),
    "regional808": ("regional_808m", "regional_alstom", None, None, lambda c: 80.0, "net_energy"),
    "yazhemsky2017": ("yazhemsky2017_advanced_1km", "yazhemsky2017_commuter", None, None, lambda c: 84.92, "energy"),
}
STRATEGIES = {
    "adaptive (quality function), the default": {},
    "adaptive, probing oracle": {"mu_oracle": "probing"},
    "adaptive, LOQO oracle": {"mu_oracle": "loqo"},
    "monotone": {"mu_strategy": "monotone"},
    "monotone, linear decrease 0.1": {"mu_strategy": "monotone", "mu_linear_decrease_factor": 0.1},
}


def written(name, points):
    """(model, session, start) of a case at ``points`` grid points, its NL file written once."""
    track_name, train_name, a, b, running, objective = CASES[name]
    track = load_track(ROOT / "tracks" / f"{track_name}.yaml")
    stops = list(track.stops)
    case = problem.prepare(track, load_train(ROOT / "trains" / f"{train_name}.yaml"), a or stops[0], b or stops[-1],
                           points)
    t = running(case)
    m = problem.build(case, problem.capped_guess(case, t), objective, {}, running_time=t)
    s = session.Session(m)
    return m, s, s.x.copy()


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--case", nargs="+", default=["metro:1000", "metro:5000", "long:1000", "long:5000",
                                                    "regional808:1000", "yazhemsky2017:500"])
    args = p.parse_args()
    solver.configure()
    print(harness.command(__file__) + "\n")
    table = harness.Table(["case", "K", "strategy", "iterations", "Ipopt CPU s (median)", "ratio to default",
                           "energy kWh", "difference %"])
    for spec in args.case:
        name, points = spec.split(":")
        m, s, x0 = written(name, int(points))
        runs = {key: [] for key in STRATEGIES}
        for _ in range(args.repeat):
            for key, options in STRATEGIES.items():
                c0 = time.process_time()
                out = s.solve(options, x0=x0)
                runs[key].append((out.iterations, time.process_time() - c0,
                                  to_kwh(float(m.objective.expr()) * m.energy_ref), out.status))
        base = statistics.median(r[1] for r in runs[next(iter(STRATEGIES))])
        e0 = runs[next(iter(STRATEGIES))][-1][2]
        for key, rows in runs.items():
            iterations, _, energy, status = rows[-1]
            cpu = statistics.median(r[1] for r in rows)
            table.add(name, points, key, f"{iterations} ({status})", f"{cpu:.3f}", f"{cpu / base:.2f}",
                      f"{energy:.6f}", signed(100 * (energy / e0 - 1), 5))


if __name__ == "__main__":
    main()
