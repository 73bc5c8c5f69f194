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
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.network import fleet, scoring, rules, joint
from ecostudy.core.types import Supply
from ecostudy.io.loaders import load_track, load_train  # noqa: E402


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
    print(f"`python bench/bench_network.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    track, train = load_track(ROOT / "tracks/metro_line_4stops.yaml"), load_train(ROOT / "trains/amsterdam_metro.yaml")
    stops = list(track.stops)
    times = [1.1 * t for t in fleet.all_out_times(track, train, stops, 500)]
    print("| trains | steps | variables | independent kWh | joint kWh | NLP's own kWh | saving % | build s | solve s | iterations |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in args.trains:
        f = fleet.plan(track, train, stops, times, 20.0, [args.offset * i for i in range(n)],
                       [f"T{i + 1}" for i in range(n)], args.dt, Supply(position=1500.0))
        ind = rules.independent(f)
        e_ind = scoring.evaluate(f, ind)[2]["substation_kWh"]
        for _ in range(args.repeat):
            runs, info = joint.joint(f, ind, one_handle=args.one_handle, floating=args.floating)
            e_joint = scoring.evaluate(f, runs)[2]["substation_kWh"]
            print(f"| {n} | {f.steps} | {info['variables']} | {e_ind:.3f} | {e_joint:.3f} | {info['nlp_substation_kWh']:.3f} | "
                  f"{100 * (1 - e_joint / e_ind):.2f} | {info['build_s']:.1f} | {info['solve_s']:.1f} | "
                  f"{info['iterations']} |", flush=True)


if __name__ == "__main__":
    main()
