"""What scaling and grid placement buy: solve time, iterations and accuracy of formulation variants.

    .venv/bin/python bench/bench_variants.py [--points 500 1000 2000] [--reference 5000]
        [--timeout 120] [--out bench/results]

Variants of the shipped formulation (nodes on every profile change, forces in kN, speed
recursion per unit mass) on the Amsterdam case at 76 s:

- ``uniform grid``: equally spaced nodes that ignore gradient and speed-limit changes;
- ``trapezoidal grid``: Yazhemsky 2017 §3.2.2, spacing growing over the first and shrinking over the
  last 15 % of the run, also ignoring profile changes;
- ``forces in N``: force variables in newtons;
- ``dynamics x M``: speed recursion multiplied by the mass (force balance in newtons);
- ``N and x M``: both, i.e. no scaling at all.

Energy errors are against the shipped formulation at ``--reference`` nodes.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
import ecostudy.ocp.space as model  # noqa: E402
import ecostudy.analysis.single as single  # noqa: E402
import ecostudy.ocp.problem as run  # noqa: E402
from ecostudy.core.grid import make_grid  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402


def uniform(segment, points, extra=()):
    """``points`` equal intervals (``extra``, make_grid's window positions: none on this trip)."""
    return np.linspace(0.0, segment.distance, points)


def trapezoidal(segment, points, extra=(), ramp=0.15, ratio=5.0):
    """Node density low-to-high over the first ``ramp`` share of the run, mirrored at the end
    (``extra``, make_grid's window positions: none on this trip)."""
    u = np.linspace(0.0, 1.0, 20001)
    density = np.clip(np.minimum(u, 1 - u) / ramp, 0, 1) * (ratio - 1) + 1  # spacing grows ratio-fold
    spacing = density / density.sum()
    s = np.concatenate([[0.0], np.cumsum(spacing[:-1])])
    s /= s[-1]
    return np.interp(np.linspace(0, 1, points), s, u) * segment.distance


VARIANTS = {
    "shipped": {},
    "uniform grid": {"grid": uniform},
    "trapezoidal grid": {"grid": trapezoidal},
    "forces in N": {"KN": 1.0},
    "dynamics x M": {"scale_mass": True},
    "N and x M": {"KN": 1.0, "scale_mass": True},
}


def solve(track, train, points, variant, timeout):
    model.FORCE_SCALE = variant.get("KN", 1000.0)
    model.DYNAMICS_SCALE = train.mass if variant.get("scale_mass") else 1.0
    run.make_grid = variant.get("grid", make_grid)
    try:
        return single.solve_run(track, train, "Rokin", "Centraal", Timing(running_time=76.0), points=points,
                                options={"max_cpu_time": float(timeout)})
    finally:
        model.FORCE_SCALE, model.DYNAMICS_SCALE, run.make_grid = 1000.0, 1.0, make_grid


def slug(name):
    return "variants." + name.replace(" ", "_")


def setup(p):
    return load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"), load_train(ROOT / "trains/amsterdam_metro.yaml"), p


def variant_case(name):
    """The harness case of one formulation variant: Ipopt seconds, iterations, energy, verification."""
    def run_variant(state):
        track, train, p = state
        r = solve(track, train, p["points"], VARIANTS[name], p["timeout"])
        s, v = r.summary, r.summary["verification"]
        return {"solve_s": r.stages["solve"], "iterations": s["solver"]["iterations"], "ipopt": s["solver"]["status"],
                "energy_kWh": s["traction_energy_kWh"], "verified": v["passed"], "stop_error_m": v["stop_error_m"],
                "overspeed_kmh": v["overspeed_max_kmh"]}
    harness.register(slug(name), run_variant, params={"points": 1000, "timeout": 120.0}, setup=setup,
                     reference=None if name == "shipped" else slug("shipped"),
                     doc=f"Rokin to Centraal in 76 s with the NLP's {name} formulation")


for _name in VARIANTS:
    variant_case(_name)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, nargs="+", default=[500, 1000, 2000])
    p.add_argument("--reference", type=int, default=5000)
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--timeout", type=float, default=120.0)
    p.add_argument("--out", default=str(ROOT / "bench/results"))
    args = p.parse_args()
    track = load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    train = load_train(ROOT / "trains/amsterdam_metro.yaml")
    ref = solve(track, train, args.reference, {}, args.timeout).summary["traction_energy_kWh"]
    lines = [harness.command(__file__), "", f"reference: shipped formulation, K = {args.reference}: {ref:.6f} kWh", ""]
    table = harness.Table(["variant", "K", "solve s", "iterations", "status", "energy error %", "verified",
                           "stop error m", "overspeed km/h"])
    for name in VARIANTS:
        for k in args.points:  # a variant that fails is a result too
            r = harness.measure([slug(name)], args.repeat, {"points": k, "timeout": args.timeout},
                                 errors="report", references=False)[slug(name)]
            if r.status != "ok":
                table.add(name, k, "-", "-", r.status[:70], "-", "-", "-", "-")
            else:
                table.add(name, k, f"{r.median('solve_s'):.3f}", r.last("iterations"), r.last("ipopt"),
                          signed(100 * (r.last('energy_kWh') / ref - 1), 4), r.last("verified"),
                          signed(r.last('stop_error_m'), 3), f"{r.last('overspeed_kmh'):.3f}")
    text = "\n".join(lines) + "\n" + table.text() + "\n"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_variants.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
