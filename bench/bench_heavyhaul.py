"""Heavy haul: Zhang & Zhuan's Tables III-IV and Fig. 6 on the shipped representative line, and the
QP's solve time per step and memory for f = 1 and f = 10.

    python bench/bench_heavyhaul.py                  # the four studies (about 4 min on 2 cores)
    python bench/bench_heavyhaul.py --fence-weights virtual   # the same with eq. 11 read literally
    python bench/bench_heavyhaul.py --terms --scale limits heavyhaul_brake_penalty   # Table IV with eq. 4's terms
    python bench/bench_heavyhaul.py --terms heavyhaul_brake_penalty_cruise   # Table IV with a cruising reference
    python bench/bench_heavyhaul.py --terms [--scale limits] heavyhaul_brake_penalty_sags   # Table IV where the descents pass the dynamic brakes
    python bench/bench_heavyhaul.py --terms --effort magnitude heavyhaul_brake_penalty   # Table IV with eq. 11's magnitudes
    python bench/bench_heavyhaul.py --terms --notches heavyhaul_brake_penalty   # Table IV with the locomotives' notches
    python bench/bench_heavyhaul.py --terms --brake-on all heavyhaul_brake_penalty   # K_b on the dynamic brakes too
    python bench/bench_heavyhaul.py --terms --notch-count 2 heavyhaul_brake_penalty   # the same with 2 notches each way
    python bench/bench_heavyhaul.py --terms --unit-kn 30 heavyhaul_brake_penalty   # eq. 4 in units of 30 kN (not a shipped scale)
    python bench/bench_heavyhaul.py --balance [--adhesion] heavyhaul_brake_penalty   # the energy balance, an effect on
    python bench/bench_heavyhaul.py --stops heavyhaul_brake_penalty heavyhaul_brake_penalty_descents   # where each run stopped
    python bench/bench_heavyhaul.py --qp 1 [--solver daqp|condensed|clarabel|ipopt] [--blas-threads 2]   # one QP size: build + 20 solves

The studies run through ``ecostudy.studies.heavyhaul.heavyhaul_study`` (resumable: outputs in
out/bench_heavyhaul_*); the tables are printed as markdown for docs/benchmarks.md.
"""
import argparse
import resource
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.api.blas import limit_blas_threads  # noqa: E402
from ecostudy.core.errors import EcostudyWarning  # noqa: E402
from ecostudy.heavyhaul.linear import fence  # noqa: E402
from ecostudy.heavyhaul.loop import horizon, limits, reduced_state  # noqa: E402
from ecostudy.heavyhaul.plant import CascadePlant  # noqa: E402
from ecostudy.heavyhaul.reference import table_reference  # noqa: E402
from ecostudy.studies.heavyhaul import QP_FORMS  # noqa: E402
from ecostudy.io.loaders import load_consist  # noqa: E402

COLUMNS = ["K_b", "f", "Np", "Nc", "tracking_mean_mps", "tracking_std_mps", "force_max_kN", "force_max_braking_kN",
           "force_mean_kN", "force_std_kN", "wagon_brake_kWh", "energy_total_kWh", "stop_error_m", "qp_inputs",
           "qp_constraints", "solve_mean_ms", "solve_p95_ms", "solve_max_ms", "over_budget_count", "wall_s"]


def rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


QP_PARAMS = {"factor": 1, "solver": "daqp", "np": 8, "nc": 6, "solves": 20, "threads": 1}


@harness.case("heavyhaul.qp", params=QP_PARAMS)
def qp_case(p):
    """Build the controller for fence ``factor`` and solve ``solves`` samples of a 15 -> 20 m/s
    manoeuvre on a 10 per-mille climb (the plant stepping the full train between them)."""
    from ecostudy.core.grid import Profile, Segment
    limit_blas_threads(p["threads"])
    consist = load_consist(ROOT / "trains/heavyhaul_zhang_zhuan.yaml")
    segment = Segment(60000.0, Profile(np.zeros(1), np.array([0.010])), Profile(np.zeros(1), np.zeros(1)),
                      Profile(np.zeros(1), np.array([30.0])))
    plant = CascadePlant(consist, segment)
    reduction = fence(consist, p["factor"], 20.0)
    before = rss_mb()
    with harness.stage() as build:
        controller = QP_FORMS[p["solver"]](reduction.model, reduction.kinds, np_=p["np"], nc=p["nc"])
    u = np.zeros(consist.cars)
    u[consist.locomotives] = plant.resistance(plant.initial(5000.0, 15.0).positions, np.full(consist.cars, 15.0)).sum() / 4
    state = plant.quasi_static(5000.0, 15.0, u)
    controller.previous = reduction.reduce(u) / 1e3
    reference = table_reference([0.0, 1e6], [72.0, 72.0])
    seconds = []
    for _ in range(p["solves"]):
        x0 = reduced_state(plant, reduction, state)
        offsets, vr = horizon(plant, reduction, reference, state, x0[:len(reduction.kinds)], p["np"])
        low, high = limits(plant, reduction, state)
        planned = controller.solve(x0, offsets / 1e3, low / 1e3, high / 1e3, vr) * 1e3
        seconds.append(controller.last.seconds)
        state = plant.step(state, reduction.share(planned, consist.mass), 20.0).state
    seconds = np.array(seconds)
    return {"virtual_cars": len(reduction.kinds), **{k: controller.size[k] for k in ("inputs", "states", "constraints")},
            "stages": {"build": build.seconds}, "first_solve_s": seconds[0], "median_solve_s": np.median(seconds[1:]),
            "p95_solve_s": np.percentile(seconds[1:], 95), "max_solve_s": seconds.max(), "rss_growth_MB": rss_mb() - before}


def qp(factor, solver, threads=1):
    """One row: the QP of fence ``factor`` built and solved (``heavyhaul.qp``)."""
    r = harness.measure(["heavyhaul.qp"], 1, {"factor": factor, "solver": solver, "threads": threads})["heavyhaul.qp"][0]
    harness.Table(["solver", "f", "BLAS threads", "virtual cars", "Np/Nc", "inputs", "states", "constraints", "build s",
                   "first solve s", "median s", "p95 s", "max s", "RSS growth MB"]).add(
        solver, factor, threads, r["virtual_cars"], f"{QP_PARAMS['np']}/{QP_PARAMS['nc']}", r["inputs"], r["states"],
        r["constraints"], f"{r['build_s']:.2f}", f"{r['first_solve_s']:.3f}", f"{r['median_solve_s']:.3f}",
        f"{r['p95_solve_s']:.3f}", f"{r['max_solve_s']:.3f}", f"{r['rss_growth_MB']:.0f}")


EFFECTS = ["K_b", "status", "tracking_mean_mps", "force_max_kN", "force_max_braking_kN", "force_mean_kN", "energy_total_kWh",
           "traction_kWh", "dynamic_brake_kWh", "wagon_brake_kWh", "running_resistance_kWh", "curve_resistance_kWh",
           "grade_kWh", "coupler_damping_kWh", "stored_change_kWh", "balance_residual_kWh"]
TERMS = ["K_b", "status", "tracking_mean_mps", "force_max_kN", "force_max_braking_kN", "braking_samples",
         "stretch_braking_samples", "stretch_braking_kWh", "traction_kWh", "wagon_brake_kWh", "dynamic_brake_kWh",
         "energy_total_kWh", "running_resistance_kWh", "curve_resistance_kWh", "grade_kWh", "J_force", "J_tracking",
         "J_energy", "J_braking", "dynamic_brake_use_max", "dynamic_brake_use_mean", "stop_error_m"]

STOPS = ["K_b", "f", "Np", "Nc", "status", "arrived", "ended", "stop_error_m", "arrival_s", "reference_time_s", "arrival_late_s",
         "arrival_late_pct", "force_max_kN",
         "force_limit_kN", "speed_excess_kmh", "over_budget_count", "reason"]


def studies(names, weights=None, scale=None, columns=COLUMNS, workers=2, adhesion=False, effort=None, notches=False,
            observer=None, brake_on=None):
    """The shipped studies; ``weights``, ``scale``, ``adhesion``, ``effort``, ``notches`` and ``brake_on`` override
    their ``fence_weights``, ``objective_scale``, ``adhesion``, ``effort_penalty``, ``notches`` and
    ``brake_penalty_on`` (a copy of the
    study file beside it, removed after the run); ``notches`` a count: on, with a copy of the consist
    that has that many traction and dynamic-brake notches; ``observer`` (q, r): the Kalman observer on
    with those noises (``observer``, ``observer_q``, ``observer_r``)."""
    import yaml
    from ecostudy.studies.heavyhaul import heavyhaul_study
    for name in names or ("heavyhaul_brake_penalty", "heavyhaul_brake_penalty_limits", "heavyhaul_horizons",
                          "heavyhaul_fence"):
        path, out = ROOT / "studies" / f"{name}.yaml", ROOT / "out" / f"bench_{name}{UNIT_TAG[0]}"
        changes = {k: v for k, v in (("fence_weights", weights), ("objective_scale", scale), ("adhesion", adhesion),
                                     ("effort_penalty", effort), ("notches", notches), ("brake_penalty_on", brake_on),
                                     ("observer", bool(observer)),
                                     ("observer_q", observer and observer[0]), ("observer_r", observer and observer[1]))
                   if v}
        if changes:
            doc = yaml.safe_load(path.read_text())
            doc.update(changes)
            tag = "_".join(k if v is True else f"{k}_{v}" for k, v in changes.items())  # never another study's name
            path, out = path.with_name(f".{name}_{tag}.yaml"), out.with_name(f"{out.name}_{tag}")
            if notches is not True and notches:  # a count: the consist copied beside the study with it
                consist = yaml.safe_load((ROOT / "studies" / doc["consist"]).read_text())
                consist["notches"].update(traction=notches, dynamic_brake=notches)
                doc.update(consist=f".{name}_{tag}_consist.yaml", notches=True)
                path.with_name(doc["consist"]).write_text(yaml.safe_dump(consist))
            path.write_text(yaml.safe_dump(doc))
        try:
            outcome, _, wall = harness.timed(lambda: heavyhaul_study(path, workers=workers, out=out))
        finally:
            for copy in (path, path.with_name(f".{name}_{tag}_consist.yaml")) if changes else ():
                copy.unlink(missing_ok=True)
        print(f"\n`{name}`{f' ({changes})' if changes else ''} ({wall:.0f} s wall; "
              f"reference {outcome.reference.running_time:.0f} s, {outcome.reference.energy / 3.6e6:.0f} kWh single mass)\n")
        print(harness.markdown(outcome.runs[list(columns)].to_dict("records"), columns))


UNIT_TAG = [""]  # the output folders' suffix under ``--unit-kn`` (a store never mixes its runs with the scale's own)


def uniform_unit(kn):
    """Eq. 4 with every in-train force and every effort in units of ``kn`` kN and speed errors in
    m/s, whatever the studies' ``objective_scale`` (not a shipped scale: the paper states no units;
    100 kN is its ``paper`` reading). Patches the controllers' ``objective_terms`` in this process
    (the study's workers are forked from it)."""
    from ecostudy.heavyhaul import condensed, qp as qp_form, rhc
    plain = rhc.objective_terms

    def terms(model, kinds, weights, represented=None, scales=None, *rest, **kw):
        return plain(model, kinds, weights, represented, rhc.Scales(kn, np.full(len(kinds), kn), 1.0), *rest, **kw)
    for module in (rhc, condensed, qp_form):
        module.objective_terms = terms
    UNIT_TAG[0] = f"_unit_{kn:g}kN"


if __name__ == "__main__":
    warnings.simplefilter("ignore", EcostudyWarning)
    parser = argparse.ArgumentParser()
    parser.add_argument("--qp", type=int, help="fence factor: time and memory of the QP only")
    parser.add_argument("--solver", default="daqp", choices=sorted(QP_FORMS))
    parser.add_argument("--fence-weights", choices=["per_car", "virtual"], help="override the studies' fence_weights")
    parser.add_argument("--scale", choices=["paper", "limits"], help="override the studies' objective_scale")
    parser.add_argument("--effort", choices=["squared", "magnitude"], help="override the studies' effort_penalty")
    parser.add_argument("--brake-on", choices=["wagons", "all"], help="override the studies' brake_penalty_on")
    parser.add_argument("--adhesion", action="store_true", help="the plant's adhesion limit on (adhesion: true)")
    parser.add_argument("--notches", action="store_true", help="the locomotives' notches on (notches: true)")
    parser.add_argument("--notch-count", type=int, help="the locomotives' notches on, this many each way (a consist copy)")
    parser.add_argument("--observer", nargs=2, type=float, metavar=("Q", "R"),
                        help="the Kalman observer on, with Q = q I and R = r I (observer: true, observer_q, observer_r)")
    parser.add_argument("--unit-kn", type=float, help="eq. 4's forces and efforts in units of this many kN, speeds in m/s")
    parser.add_argument("--terms", action="store_true", help="print the brake-penalty columns (eq. 4's terms at the optimum)")
    parser.add_argument("--balance", action="store_true", help="print the energy balance columns")
    parser.add_argument("--stops", action="store_true", help="print the status columns (where each run stopped)")
    parser.add_argument("--blas-threads", type=int, default=1, help="OpenBLAS threads (the CLI's default: 1)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("studies", nargs="*", help="study names (default: all four)")
    args = parser.parse_args()
    limit_blas_threads(args.blas_threads)
    if args.unit_kn:
        uniform_unit(args.unit_kn)
    if args.qp:
        qp(args.qp, args.solver, threads=args.blas_threads)
    else:
        studies(args.studies, args.fence_weights, args.scale, TERMS if args.terms else EFFECTS if args.balance else STOPS if args.stops else COLUMNS, args.workers, args.adhesion, args.effort, args.notch_count or args.notches,
                args.observer, args.brake_on)
