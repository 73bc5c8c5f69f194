"""The study-size estimates (``ecostudy.studies.sizes``) against measurements of the current code:
runs of each study kind computed one after the other in this process, timed in CPU seconds (this
process and its finished children, the Ipopt processes: on a busy machine the wall clock measures
the load, the CPU time the work), beside what the estimate says for the same runs.

    .venv/bin/python bench/bench_sizes.py [--kinds run simulate network heavyhaul] [--draws 1]
        [--cases 4] [--samples 30] [--fences F ...] [--horizon NP NC] [--loop-study STUDY] [--shipped] [--no-heavy]

- ``run``: the first ``--cases`` cases of ``studies/metro_supplements.yaml`` (K = 1000): CPU per
  case against ``estimate.run_seconds``, and the CPU per grid point (``RUN_SECONDS_PER_POINT``);
- ``simulate``: draw 0 (``--draws N``: the first N) of every controller of
  ``studies/metro_monte_carlo.yaml`` (or ``--loop-study``): CPU per run against ``estimate.check_closed_loop``'s, and the
  CPU per sample (``estimate.SAMPLE_SECONDS``, set-up included);
- ``network``: the whole of ``studies/network_metro_2trains.yaml`` with one worker against
  ``sizes.network_runs``: its clock steps, the same weighted by their legs' slowness
  (``estimate.leg_slowness``), and the CPU a weighted step once the first runs' estimate is taken
  off the CPU (``NETWORK_SECONDS_PER_STEP``);
- ``heavyhaul``: each run of ``studies/heavyhaul_fence.yaml`` (f = 10 and f = 1, or ``--fences``;
  Np = 8, Nc = 6, or ``--horizon``): its set-up alone (the plant and the controller, the condensed QP
  built) against ``sizes.heavyhaul_setup_seconds``, then its first ``--samples`` samples, set-up
  included, against the estimate of the same work (the set-up and ``sizes.heavyhaul_sample_seconds``
  a sample);
- ``--shipped``: the estimate of every study in ``studies/`` with one worker and with every core
  (``--no-heavy``: without the heavy-haul ones, which solve their reference first).
"""
import argparse
import tempfile
import sys
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.budget import duration, study_estimate  # noqa: E402
from ecostudy.io.loaders import load_network_study  # noqa: E402
from ecostudy.io.yamlsafe import load_yaml  # noqa: E402
from ecostudy.ocp.solver import configure  # noqa: E402
from ecostudy.studies import batch, cases as run_cases, closedloop, heavyhaul, sizes  # noqa: E402
from ecostudy.studies.estimate import (RUN_SECONDS_PER_POINT, check_closed_loop, check_network, first_runs,  # noqa: E402
                                       horizon_samples, run_seconds, spec_seconds)
from ecostudy.studies.network import expand_network  # noqa: E402
from ecostudy.studies.workers import every_core  # noqa: E402

STUDIES = ROOT / "studies"


def summary_of(result):
    """A study case's result as the harness reports it: its status and samples."""
    return {"status": result["status"], "samples": (result["summary"] or {}).get("samples") or 0}


def nth_run(p):
    return run_cases.expand(Path(p["study"]), [])[2][p["case"]]


@harness.case("sizes.run", setup=nth_run, params={"study": str(STUDIES / "metro_supplements.yaml"), "case": 0})
def one_run(case):
    """One case of a run study (``batch.run_case``), beside ``estimate.run_seconds``."""
    return {"status": batch.run_case(case)["status"], "points": case["points"],
            "estimate_s": run_seconds(case["points"], case.get("das"), case.get("das_time_limit_s", 60.0))}


def nth_loop(p):
    return closedloop.expand(Path(p["study"]))[2][p["case"]]


@harness.case("sizes.simulate", setup=nth_loop, params={"study": str(STUDIES / "metro_monte_carlo.yaml"), "case": 0})
def one_loop(case):
    """One closed-loop run (``closedloop.run_loop_case``): CPU per sample, set-up included."""
    return summary_of(closedloop.run_loop_case(case))


@harness.case("sizes.network", setup=lambda p: Path(p["study"]),
              params={"study": str(STUDIES / "network_metro_2trains.yaml")})
def one_network(path):
    """A whole network study with one worker (the study kind ``network``, every strategy computed
    into a fresh store), beside ``sizes.network_runs``."""
    with tempfile.TemporaryDirectory() as out:
        batch.run_expanded("network", expand_network(path, out=out), path)


def nth_heavyhaul(p):
    return {**heavyhaul.expand(Path(p["study"]))[3][p["case"]], "max_samples": p["samples"]}


@harness.case("sizes.heavyhaul", setup=nth_heavyhaul,
              params={"study": str(STUDIES / "heavyhaul_fence.yaml"), "case": 0, "samples": 30})
def one_heavyhaul(case):
    """The first samples of one heavy-haul run (``run_heavyhaul_case``): CPU per sample."""
    return summary_of(heavyhaul.run_heavyhaul_case(case))


def bench_run(n):
    path = STUDIES / "metro_supplements.yaml"
    _, _, cases = run_cases.expand(path, [])
    print(f"\n### run: the first {n} cases of {path.name}\n")
    table = harness.Table(["case", "K", "status", "CPU s", "wall s", "estimate s", "CPU ms a point"])
    per_point = []
    for case in cases[:n]:
        r = harness.sample(one_run, case)
        per_point.append(r["cpu_s"] / case["points"])
        table.add(case["labels"], case["points"], r["status"], f"{r['cpu_s']:.2f}", f"{r['wall_s']:.2f}",
                  f"{r['estimate_s']:.2f}", f"{1e3 * per_point[-1]:.2f}")
    print(f"\nmean {1e3 * np.mean(per_point):.2f} ms a point (constant {1e3 * RUN_SECONDS_PER_POINT:.2f})")


def bench_simulate(draws, path):
    _, _, cases = closedloop.expand(path)
    chosen = [c for c in cases if c["labels"]["draw"] < draws]
    estimates = check_closed_loop(chosen, path)
    print(f"\n### simulate: draws 0..{draws - 1} of every controller of {path.name}\n")
    table = harness.Table(["controller", "kind", "draw", "status", "samples", "CPU s", "wall s", "estimate s",
                           "CPU ms a sample", "constant ms"])
    by_kind = {}
    for case, estimate in zip(chosen, estimates):
        kind = closedloop.controller_spec(case)["kind"]
        horizon = horizon_samples(case["window"][1], case["sample_time"])
        r = harness.sample(one_loop, case)
        by_kind.setdefault(kind, []).append(r["cpu_s"] / max(r["samples"], 1))
        table.add(case["labels"]["controller"], kind, case["labels"]["draw"], r["status"], r["samples"],
                  f"{r['cpu_s']:.2f}", f"{r['wall_s']:.2f}", f"{estimate:.2f}", f"{1e3 * by_kind[kind][-1]:.2f}",
                  f"{1e3 * spec_seconds(case['controller'], case['points'], horizon):.2f}")
    print("\nmean CPU a sample by kind (set-up included): " + ", ".join(
        f"{kind} {1e3 * np.mean(v):.2f} ms" for kind, v in by_kind.items()))


def bench_network():
    path = STUDIES / "network_metro_2trains.yaml"
    st = load_network_study(path)
    runs = sizes.network_runs(st, path)
    firsts, legs = sum(first_runs(st)), check_network(st, path)
    each = len(st.names) * len(st.strategies)  # every leg for every train and strategy
    steps, weighted = each * sum(leg.steps for leg in legs), each * sum(leg.weighted for leg in legs)
    r = harness.sample(one_network, path)
    print(f"\n### network: {path.name}, {len(st.strategies)} strategies, one worker\n")
    harness.Table(["clock steps (legs x trains x strategies)", "weighted steps", "estimate s (first runs + steps)",
                   "CPU s", "wall s", "CPU ms a weighted step (first runs' estimate taken off)", "constant ms"]
                  ).add(f"{steps:,}", f"{weighted:,.0f}", f"{sum(runs):.1f} ({firsts:.1f} + {sum(runs) - firsts:.1f})",
                        f"{r['cpu_s']:.1f}", f"{r['wall_s']:.1f}", f"{1e3 * (r['cpu_s'] - firsts) / weighted:.2f}",
                        f"{1e3 * sizes.NETWORK_SECONDS_PER_STEP:.2f}")


@harness.case("sizes.heavyhaul_setup", setup=nth_heavyhaul,
              params={"study": str(STUDIES / "heavyhaul_fence.yaml"), "case": 0, "samples": 0})
def heavyhaul_setup(case):
    """One heavy-haul run's set-up alone: its plant and its controller (the condensed QP built)."""
    consist, plant, _ = heavyhaul.case_plant(case)
    reduction, _ = heavyhaul.case_controller(case, consist, plant)
    return {"cars": len(reduction.members)}


def mutated(path, fences, horizon, folder):
    """``path`` as a study of these ``fences`` and ``horizon`` (Np, Nc), written in ``folder``."""
    doc = load_yaml(path.read_text())
    doc.update({k: str((path.parent / doc[k]).resolve()) for k in ("consist", "track")})
    if fences:
        doc["fence"] = list(fences)
    if horizon:
        doc["horizons"] = [{"np": horizon[0], "nc": horizon[1]}]
    out = Path(folder) / path.name
    out.write_text(yaml.safe_dump(doc))
    return out


def bench_heavyhaul(samples, fences=None, horizon=None):
    source = STUDIES / "heavyhaul_fence.yaml"
    with tempfile.TemporaryDirectory() as folder:
        path = mutated(source, fences, horizon, folder)
        study, _, reference, cases = heavyhaul.expand(path)
    full = sizes.heavyhaul_runs(study, reference, cases)
    print(f"\n### heavyhaul: each run's set-up, then its first {samples} samples (set-up included), of {source.name}"
          f"{f' with fences {fences}' if fences else ''}{f', Np, Nc = {horizon}' if horizon else ''}\n")
    table = harness.Table(["f", "Np", "Nc", "QP inputs", "set-up CPU s", "set-up estimate s", "status", "samples",
                           "CPU s", "wall s", "CPU s a sample", "estimate s", "estimate / CPU",
                           "estimate of the whole run s"])
    for case, whole in zip(cases, full):
        case = {**case, "max_samples": samples}
        labels = case["labels"]
        setup = harness.sample(heavyhaul_setup, case)
        cars = setup["cars"]
        setup_estimate = sizes.heavyhaul_setup_seconds(cars, labels["Nc"], labels["Np"])
        r = harness.sample(one_heavyhaul, case)
        estimate = setup_estimate + r["samples"] * sizes.heavyhaul_sample_seconds(cars * labels["Nc"])
        table.add(labels["f"], labels["Np"], labels["Nc"], cars * labels["Nc"], f"{setup['cpu_s']:.3f}",
                  f"{setup_estimate:.3f}", r["status"], r["samples"], f"{r['cpu_s']:.1f}", f"{r['wall_s']:.1f}",
                  f"{r['cpu_s'] / max(r['samples'], 1):.3f}", f"{estimate:.1f}", f"{estimate / r['cpu_s']:.2f}",
                  f"{whole:.0f}")


def shipped_runs(path):
    """(runs, estimated seconds of each) of a shipped study, by its kind."""
    doc = load_yaml(path.read_text())
    if "controllers" in doc:
        _, _, cases = closedloop.expand(path)
        return check_closed_loop(cases, path)
    if "trains" in doc:
        return sizes.network_runs(load_network_study(path), path)
    if "consist" in doc:
        study, _, reference, cases = heavyhaul.expand(path)
        return sizes.heavyhaul_runs(study, reference, cases)
    _, _, cases = run_cases.expand(path, [])
    return [run_seconds(c["points"], c.get("das"), c.get("das_time_limit_s", 60.0)) for c in cases]


def bench_shipped(heavy):
    cores = every_core(None)
    print(f"\n### the estimate of every shipped study (one worker, every core: {cores})\n")
    table = harness.Table(["study", "runs", "computing", "one worker", f"{cores} workers"])
    for path in sorted(STUDIES.glob("*.yaml")):
        if not heavy and "consist" in load_yaml(path.read_text()):
            continue
        runs = shipped_runs(path)
        one, many = study_estimate(runs, 1), study_estimate(runs, cores)
        table.add(path.stem, len(runs), duration(one[0]), duration(one[1]), duration(many[1]))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kinds", nargs="*", default=["run", "simulate", "network", "heavyhaul"])
    p.add_argument("--cases", type=int, default=4)
    p.add_argument("--draws", type=int, default=1)
    p.add_argument("--samples", type=int, default=30)
    p.add_argument("--fences", type=int, nargs="*", help="heavyhaul: these fences (default: the study's, 10 and 1)")
    p.add_argument("--horizon", type=int, nargs=2, metavar=("NP", "NC"), help="heavyhaul: this Np and Nc (default 8, 6)")
    p.add_argument("--loop-study", type=Path, default=STUDIES / "metro_monte_carlo.yaml")
    p.add_argument("--shipped", action="store_true")
    p.add_argument("--no-heavy", action="store_true")
    args = p.parse_args()
    print(harness.command(__file__))
    configure()
    for kind in args.kinds:
        {"run": lambda: bench_run(args.cases), "simulate": lambda: bench_simulate(args.draws, args.loop_study),
         "network": bench_network, "heavyhaul": lambda: bench_heavyhaul(args.samples, args.fences, args.horizon)}[kind]()
    if args.shipped:
        bench_shipped(not args.no_heavy)


if __name__ == "__main__":
    main()
