"""Ipopt and MUMPS options on one NLP: iterations, Ipopt seconds and seconds per iteration.

    .venv/bin/python bench/bench_ipopt_options.py [--points 1000] [--repeat 3]

Amsterdam metro, 76 s, energy objective. The model and its NL file are built once; every
variant solves it from the same capped-speed start (Session.solve with x0), in one process, so
the ratios against the default compare. Energies are checked against the default to 0.01 %.
"""
import argparse
import shlex
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import pyomo.environ as pyo  # noqa: E402

from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import build, capped_guess, prepare  # noqa: E402
from ecostudy.ocp.session import Session  # noqa: E402

VARIANTS = {
    "default (adaptive mu, MUMPS defaults)": {},
    "mu_strategy monotone": {"mu_strategy": "monotone"},
    "nlp_scaling_method none": {"nlp_scaling_method": "none"},
    "mumps_permuting_scaling 0": {"mumps_permuting_scaling": 0},
    "mumps_scaling 0": {"mumps_scaling": 0},
    "mumps_pivot_order 0 (AMD)": {"mumps_pivot_order": 0},
    "mumps_pivot_order 2 (AMF)": {"mumps_pivot_order": 2},
    "mumps_pivot_order 4 (PORD)": {"mumps_pivot_order": 4},
    "mumps_pivot_order 6 (QAMD)": {"mumps_pivot_order": 6},
    "mumps_pivtol 1e-6": {"mumps_pivtol": 1e-6},
    "linear_system_scaling none": {"linear_system_scaling": "none"},
    "bound_push 1e-4": {"bound_push": 1e-4, "bound_frac": 1e-4},
}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--timing", action="store_true", help="Ipopt's own timing statistics of the default run")
    args = p.parse_args()
    print(f"`python bench/bench_ipopt_options.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    track = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    train = load_train(ROOT / "trains/amsterdam_metro.yaml")
    case = prepare(track, train, "Rokin", "Centraal", args.points)
    m = build(case, capped_guess(case, 76.0), "energy", {}, running_time=76.0)
    session = Session(m)
    x0 = session.x.copy()
    reference, base = None, None
    print("| options | status | iterations | Ipopt s (median) | ms per iteration | ratio to default | energy kWh |\n"
          "|---|---|---|---|---|---|---|")
    for name, options in VARIANTS.items():
        seconds, out = [], None
        for _ in range(args.repeat):
            out = session.solve(options, x0=x0)
            seconds.append(out.seconds)
        energy = pyo.value(m.traction_work) / 3.6e6
        reference = reference or energy
        s = statistics.median(seconds)
        base = base or s
        flag = "" if abs(energy / reference - 1) < 1e-4 else " (differs)"
        print(f"| {name} | {out.status} | {out.iterations} | {s:.3f} | {1e3 * s / max(out.iterations, 1):.1f} | "
              f"{s / base:.2f} | {energy:.5f}{flag} |", flush=True)
    if args.timing:
        log = Path(tempfile.mkdtemp()) / "ipopt.out"
        session.solve({"output_file": str(log), "file_print_level": 5, "print_timing_statistics": "yes"}, x0=x0)
        text = log.read_text()
        print("\n```\n" + text[text.index("Timing Statistics:"):text.index("EXIT:")].strip() + "\n```")


if __name__ == "__main__":
    main()
