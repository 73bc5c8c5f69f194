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
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.types import State  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import session  # noqa: E402
from ecostudy.ocp.problem import build, capped_guess, prepare  # noqa: E402
from ecostudy.ocp.restart import Replanner  # noqa: E402

RUNNING_TIME = 76.0


def prepared(p):
    return prepare(load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
                   load_train(ROOT / "trains/amsterdam_metro.yaml"), "Rokin", "Centraal", p["points"])


@harness.case("resolve.cold", params={"points": 500}, setup=prepared)
def cold(case):
    """A cold solve, Rokin to Centraal in 76 s: build + NL write + Ipopt."""
    m = build(case, capped_guess(case, RUNNING_TIME), "energy", {}, running_time=RUNNING_TIME)
    return {"iterations": session.solve(m).iterations}


def replanning(p):
    """(Replanner with its movable model written once, its whole-trip optimum, share)."""
    replanner = Replanner(prepared(p), running_time=RUNNING_TIME)
    return replanner, replanner.solve(), p["share"]


@harness.case("resolve.replan", params={"points": 500, "share": 0.4}, setup=replanning, reference="resolve.cold")
def replan(state):
    """A re-solve of the written model (bounds changed) from the optimum's state at ``share`` of the trip."""
    replanner, full, share = state
    ds = np.diff(full.nodes)
    k = int(np.searchsorted(full.nodes, share * full.nodes[-1]))
    tail = float(np.sum(full.ft[k:] * ds[k:]))
    plan = replanner.solve(State(full.nodes[k], full.v[k], full.time[k]))
    return {"iterations": plan.outcome.iterations,
            "tail_error_pct": abs(plan.traction_energy / tail - 1) * 100 if tail > 1e3 else float("nan")}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, nargs="+", default=[200, 500, 1000])
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    table = harness.Table(["K", "cold build + NL write + solve s", "iterations", "movable model written once s",
                           "re-solve s (median)", "iterations (median)", "ratio cold / re-solve", "tail energy error %"])
    for k_points in args.points:
        colds = harness.measure(["resolve.cold"], args.repeat, {"points": k_points})["resolve.cold"]
        (replanner, full, _), _, setup = harness.timed(lambda: replanning({"points": k_points, "share": 0.0}))
        resolves = harness.Samples("resolve.replan", {"points": k_points})
        for _ in range(args.repeat):
            for share in (0.2, 0.4, 0.6):
                resolves.append(harness.sample(replan, (replanner, full, share)))
        c, r = colds.median("wall_s"), resolves.median("wall_s")
        errors = [e for e in resolves.values("tail_error_pct") if np.isfinite(e)]
        table.add(k_points, f"{c:.3f}", colds[0]["iterations"], f"{setup:.3f}", f"{r:.3f}",
                  f"{resolves.median('iterations'):.0f}", f"{c / r:.1f}", f"{max(errors, default=0.0):.1e}")


if __name__ == "__main__":
    main()
