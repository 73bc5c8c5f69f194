"""Re-solving from a mid-run state (one movable model, bounds only) against a cold build and solve.

    .venv/bin/python bench/bench_resolve.py [--points 200 500 1000] [--repeat 5]

Amsterdam metro, 76 s. Cold: prepare the remaining segment's grid is not what a controller has,
so the cold reference is what re-planning cost before ocp/restart.py existed: build the model
of the whole case, write the NL file, solve from the capped-speed guess. Re-solve: the movable
model (written once) re-planned from states on its own optimum at 20 %, 40 % and 60 % of the
distance (bounds changed, warm from the previous plan). Medians of --repeat runs in one process;
the ratio is cold / re-solve.
"""
import argparse
import shlex
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.core.types import State  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import session  # noqa: E402
from ecostudy.ocp.problem import build, capped_guess, prepare  # noqa: E402
from ecostudy.ocp.restart import Replanner  # noqa: E402

RUNNING_TIME = 76.0


def cold(case):
    t0 = time.perf_counter()
    m = build(case, capped_guess(case, RUNNING_TIME), "energy", {}, running_time=RUNNING_TIME)
    out = session.solve(m)
    return time.perf_counter() - t0, out.iterations


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, nargs="+", default=[200, 500, 1000])
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    print(f"`python bench/bench_resolve.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    track = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    train = load_train(ROOT / "trains/amsterdam_metro.yaml")
    print("| K | cold build + NL write + solve s | iterations | movable model written once s | "
          "re-solve s (median) | iterations (median) | ratio cold / re-solve | tail energy error % |\n"
          "|---|---|---|---|---|---|---|---|")
    for k_points in args.points:
        case = prepare(track, train, "Rokin", "Centraal", k_points)
        colds = [cold(case) for _ in range(args.repeat)]
        t0 = time.perf_counter()
        replanner = Replanner(case, running_time=RUNNING_TIME)
        full = replanner.solve()
        setup = time.perf_counter() - t0
        ds = np.diff(full.nodes)
        times, iterations, errors = [], [], []
        for _ in range(args.repeat):
            for share in (0.2, 0.4, 0.6):
                k = int(np.searchsorted(full.nodes, share * full.nodes[-1]))
                state = State(full.nodes[k], full.v[k], full.time[k])
                tail = float(np.sum(full.ft[k:] * ds[k:]))
                t1 = time.perf_counter()
                plan = replanner.solve(state)
                times.append(time.perf_counter() - t1)
                iterations.append(plan.outcome.iterations)
                if tail > 1e3:
                    errors.append(abs(plan.traction_energy / tail - 1) * 100)
        c = statistics.median(t for t, _ in colds)
        r = statistics.median(times)
        print(f"| {k_points} | {c:.3f} | {colds[0][1]} | {setup:.3f} | {r:.3f} | {statistics.median(iterations):.0f} | "
              f"{c / r:.1f} | {max(errors, default=0.0):.1e} |", flush=True)


if __name__ == "__main__":
    main()
