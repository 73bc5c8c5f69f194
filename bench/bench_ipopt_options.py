"""Ipopt and MUMPS options on one NLP: iterations, Ipopt seconds and seconds per iteration.

    .venv/bin/python bench/bench_ipopt_options.py [--points 1000] [--repeat 3]

Amsterdam metro, 76 s, energy objective. The model and its NL file are built once; every
variant solves it from the same capped-speed start (Session.solve with x0), in one process, so
the ratios against the default compare. Energies are checked against the default to 0.01 %.
"""
import argparse
import functools
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import pyomo.environ as pyo  # noqa: E402

from bench import harness  # noqa: E402
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


@functools.lru_cache(maxsize=1)
def written(points):
    """(model, session, start point): Rokin to Centraal in 76 s at K = ``points``, its NL file written once."""
    case = prepare(load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
                   load_train(ROOT / "trains/amsterdam_metro.yaml"), "Rokin", "Centraal", points)
    m = build(case, capped_guess(case, 76.0), "energy", {}, running_time=76.0)
    session = Session(m)
    return m, session, session.x.copy()


def key(options):
    return "ipopt_options." + ("_".join(f"{k}_{v}" for k, v in options.items()) or "default")


def solve_with(state):
    """One Ipopt solve of the written model with an option set: Ipopt seconds, iterations, energy."""
    options, p = state
    m, session, x0 = written(p["points"])
    out = session.solve(options, x0=x0)
    return {"ipopt_s": out.seconds, "ipopt": out.status, "iterations": out.iterations,
            "energy_kWh": pyo.value(m.traction_work) / 3.6e6}


for _name, _options in VARIANTS.items():
    harness.register(key(_options), solve_with, params={"points": 1000}, setup=lambda p, o=_options: (o, p),
                     reference=None if not _options else key({}), doc=f"Ipopt on the metro NLP (written once): {_name}")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=1000)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--timing", action="store_true", help="Ipopt's own timing statistics of the default run")
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    m, session, x0 = written(args.points)
    reference, base = None, None
    table = harness.Table(["options", "status", "iterations", "Ipopt s (median)", "ms per iteration", "ratio to default",
                           "energy kWh"])
    runs = harness.measure([key(o) for o in VARIANTS.values()], args.repeat, {"points": args.points})  # alternating
    for name, options in VARIANTS.items():
        r = runs[key(options)]
        energy = r.last("energy_kWh")
        reference = reference or energy
        s = r.median("ipopt_s")
        base = base or s
        flag = "" if abs(energy / reference - 1) < 1e-4 else " (differs)"
        table.add(name, r.last("ipopt"), r.last("iterations"), f"{s:.3f}", f"{1e3 * s / max(r.last('iterations'), 1):.1f}",
                  f"{s / base:.2f}", f"{energy:.5f}{flag}")
    if args.timing:
        log = Path(tempfile.mkdtemp()) / "ipopt.out"
        session.solve({"output_file": str(log), "file_print_level": 5, "print_timing_statistics": "yes"}, x0=x0)
        text = log.read_text()
        print("\n```\n" + text[text.index("Timing Statistics:"):text.index("EXIT:")].strip() + "\n```")


if __name__ == "__main__":
    main()
