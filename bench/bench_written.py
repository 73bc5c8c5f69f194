"""A sweep of running times with the NL file written once per structure against a fresh build and
write per case, in one process.

    .venv/bin/python bench/bench_written.py [--points 1000] [--times 76 78 80 82 84 86 88 90 92 94]
        [--repeat 3]

Each case is ``analysis.single.solve_run`` on the Amsterdam case (traction energy); "written" passes
one ``ocp.problem.Written`` through the sweep, so every case after the first changes T's bounds and
the start point of the model written for the first. Prints per variant the seconds of the whole
sweep (median of ``--repeat``), the stage sums, the Ipopt iterations and the largest energy
difference between the variants.
"""
import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import Written  # noqa: E402

STAGES = ("build", "nl_write", "solve", "verify")
PARAMS = {"points": 1000, "times": [76.0, 78.0, 80.0, 82.0, 84.0, 86.0, 88.0, 90.0, 92.0, 94.0]}
VARIANTS = {"written.fresh": "fresh build and write per case", "written.once": "written once (ocp.problem.Written)"}


def setup(p):
    return load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"), load_train(ROOT / "trains/amsterdam_metro.yaml"), p


def sweep(state, once):
    """Rokin to Centraal at every running time: stage sums, iterations, all verified, the energies."""
    track, train, p = state
    written = Written() if once else None
    runs = [solve_run(track, train, "Rokin", "Centraal", Timing(running_time=t), points=p["points"],
                      written=written, structure="sweep" if written is not None else None) for t in p["times"]]
    return {"stages": {s: sum(r.stages.get(s, 0.0) for r in runs) for s in STAGES},
            "iterations": sum(r.summary["solver"]["iterations"] for r in runs), "verified": all(r.ok for r in runs),
            "energies_kWh": [r.summary["traction_energy_kWh"] for r in runs]}


harness.register("written.fresh", lambda state: sweep(state, False), params=PARAMS, setup=setup,
                 doc="A sweep of running times, each run its own model build and NL file")
harness.register("written.once", lambda state: sweep(state, True), params=PARAMS, setup=setup, reference="written.fresh",
                 doc="The same sweep with the model written once (ocp.problem.Written), bounds changed")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--times", type=float, nargs="+", default=PARAMS["times"])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(harness.command(__file__) + "\n")
    # alternating, so that both see the same machine
    runs = harness.measure(list(VARIANTS), args.repeat, {"points": args.points, "times": args.times})
    print(f"{len(args.times)} running times, K = {args.points}; seconds for the whole sweep (median of {args.repeat})\n")
    table = harness.Table(["variant", "sweep s", "ratio"] + [f"{s} s" for s in STAGES] + ["iterations", "all verified"])
    base = runs["written.fresh"].median("wall_s")
    for name, label in VARIANTS.items():
        r = runs[name]
        table.add(label, f"{r.median('wall_s'):.2f}", f"{r.median('wall_s') / base:.2f}",
                  *(f"{r.last(f'{s}_s'):.2f}" for s in STAGES), r.last("iterations"), r.last("verified"))
    fresh, kept = runs["written.fresh"].last("energies_kWh"), runs["written.once"].last("energies_kWh")
    diff = max(abs(a / b - 1) for a, b in zip(kept, fresh))
    print(f"\nlargest relative energy difference between the variants: {diff:.1e}")


if __name__ == "__main__":
    main()
