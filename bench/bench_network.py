"""Wall time of the joint optimum (all trains and the circuit of eq. 7.8 in one NLP) against the
number of trains, on the shipped 4-stop metro line.

    .venv/bin/python bench/bench_network.py [--trains 1 2 3] [--dt 0.5] [--offset 48] [--one-handle] [--floating] [--pivot-order N]
        [--repeat 1]

Trains depart ``offset`` seconds apart, +10 % running time per segment, 20 s dwells, the
substation at 1500 m. Per count: clock steps, NLP variables, build and solve seconds, Ipopt
iterations, substation energy of the independent runs and of the joint optimum (scored by the
circuit, ``circuit.solve_steps``, and the NLP's own).
"""
import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.network import fleet, scoring, rules, joint  # noqa: E402
from ecostudy.core.types import Supply  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402


def setup(p):
    """The fleet of ``trains`` on the 4-stop line and its independent runs (untimed)."""
    track, train = load_track(ROOT / "tracks/metro_line_4stops.yaml"), load_train(ROOT / "trains/amsterdam_metro.yaml")
    stops = list(track.stops)
    times = [1.1 * t for t in fleet.all_out_times(track, train, stops, 500)]
    n = p["trains"]
    f = fleet.plan(track, train, stops, times, 20.0, [p["offset"] * i for i in range(n)],
                   [f"T{i + 1}" for i in range(n)], p["dt"], Supply(position=1500.0))
    ind = rules.independent(f)
    return f, ind, scoring.evaluate(f, ind)[2]["substation_kWh"], p


@harness.case("network.joint", setup=setup,
              params={"trains": 2, "dt": 0.5, "offset": 48.0, "one_handle": False, "floating": False})
def joint_optimum(state):
    """The joint optimum (all trains and the circuit of eq. 7.8 in one NLP): build and solve seconds, iterations, energies."""
    f, ind, e_ind, p = state
    runs, info = joint.joint(f, ind, one_handle=p["one_handle"], floating=p["floating"])
    e_joint = scoring.evaluate(f, runs)[2]["substation_kWh"]
    return {"steps": f.steps, "variables": info["variables"], "independent_kWh": e_ind, "joint_kWh": e_joint,
            "nlp_kWh": info["nlp_substation_kWh"], "saving_pct": 100 * (1 - e_joint / e_ind),
            "stages": {"build": info["build_s"], "solve": info["solve_s"]}, "iterations": info["iterations"]}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trains", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--dt", type=float, default=0.5)
    p.add_argument("--offset", type=float, default=48.0)
    p.add_argument("--one-handle", action="store_true", help="hold traction and braking apart in the joint NLP")
    p.add_argument("--floating", action="store_true", help="the bus with the diode's complementarity")
    p.add_argument("--pivot-order", type=int, default=None, help="MUMPS ordering for the joint NLP (default: joint.ORDERING)")
    p.add_argument("--repeat", type=int, default=1, help="solves of each count (the iterations spread widely)")
    args = p.parse_args()
    if args.pivot_order is not None:
        joint.ORDERING = {"mumps_pivot_order": args.pivot_order}
    print(harness.command(__file__) + "\n")
    table = harness.Table(["trains", "steps", "variables", "independent kWh", "joint kWh", "NLP's own kWh", "saving %",
                           "build s", "solve s", "iterations"])
    for n in args.trains:
        params = {"trains": n, "dt": args.dt, "offset": args.offset, "one_handle": args.one_handle,
                  "floating": args.floating}
        for r in harness.measure(["network.joint"], args.repeat, params)["network.joint"]:  # every solve: they spread widely
            table.add(n, r["steps"], r["variables"], f"{r['independent_kWh']:.3f}", f"{r['joint_kWh']:.3f}",
                      f"{r['nlp_kWh']:.3f}", f"{r['saving_pct']:.2f}", f"{r['build_s']:.1f}", f"{r['solve_s']:.1f}",
                      r["iterations"])


if __name__ == "__main__":
    main()
