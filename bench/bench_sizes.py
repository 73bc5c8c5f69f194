"""The study-size estimates (``ecostudy.studies.sizes``) against measurements of the current code:
runs of each study kind computed one after the other in this process, timed in CPU seconds (this
process and its finished children, the Ipopt processes: on a busy machine the wall clock measures
the load, the CPU time the work), beside what the estimate says for the same runs.

    .venv/bin/python bench/bench_sizes.py [--kinds run simulate network heavyhaul] [--draws 1]
        [--cases 4] [--samples 30] [--loop-study STUDY] [--shipped] [--no-heavy]

- ``run``: the first ``--cases`` cases of ``studies/metro_supplements.yaml`` (K = 1000): CPU per
  case against ``estimate.run_seconds``, and the CPU per grid point (``RUN_SECONDS_PER_POINT``);
- ``simulate``: draw 0 (``--draws N``: the first N) of every controller of
  ``studies/metro_monte_carlo.yaml`` (or ``--loop-study``): CPU per run against ``estimate.check_closed_loop``'s, and the
  CPU per sample (``estimate.SAMPLE_SECONDS``, set-up included);
- ``network``: the whole of ``studies/network_metro_2trains.yaml`` with one worker against
  ``sizes.network_runs`` (``NETWORK_SECONDS_PER_STEP``);
- ``heavyhaul``: the first ``--samples`` samples of each fence of ``studies/heavyhaul_fence.yaml``
  (f = 10 and f = 1) against ``HEAVYHAUL_SECONDS_PER_SAMPLE``;
- ``--shipped``: the estimate of every study in ``studies/`` with one worker and with every core
  (``--no-heavy``: without the heavy-haul ones, which solve their reference first).
"""
import argparse
import os
import tempfile
import shlex
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.core.budget import duration, study_estimate  # noqa: E402
from ecostudy.io.loaders import load_network_study  # noqa: E402
from ecostudy.io.yamlsafe import load_yaml  # noqa: E402
from ecostudy.ocp.solver import configure  # noqa: E402
from ecostudy.studies import batch, cases as run_cases, closedloop, heavyhaul, sizes  # noqa: E402
from ecostudy.studies.estimate import RUN_SECONDS_PER_POINT, check_closed_loop, run_seconds, spec_seconds  # noqa: E402
from ecostudy.studies.network import expand_network  # noqa: E402
from ecostudy.studies.workers import every_core  # noqa: E402

STUDIES = ROOT / "studies"


def cpu():
    """CPU seconds of this process and its waited-for children (the Ipopt processes) so far."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def timed(work):
    c0, w0 = cpu(), time.perf_counter()
    out = work()
    return out, cpu() - c0, time.perf_counter() - w0


def row(*cells):
    print("| " + " | ".join(str(c) for c in cells) + " |", flush=True)


def bench_run(n):
    path = STUDIES / "metro_supplements.yaml"
    _, _, cases = run_cases.expand(path, [])
    print(f"\n### run: the first {n} cases of {path.name}\n")
    row("case", "K", "status", "CPU s", "wall s", "estimate s", "CPU ms a point")
    print("|---|---|---|---|---|---|---|")
    per_point = []
    for case in cases[:n]:
        result, c, w = timed(lambda: batch.run_case(case))
        estimate = run_seconds(case["points"], case.get("das"), case.get("das_time_limit_s", 60.0))
        per_point.append(c / case["points"])
        row(case["labels"], case["points"], result["status"], f"{c:.2f}", f"{w:.2f}", f"{estimate:.2f}",
            f"{1e3 * per_point[-1]:.2f}")
    print(f"\nmean {1e3 * np.mean(per_point):.2f} ms a point (constant {1e3 * RUN_SECONDS_PER_POINT:.2f})")


def bench_simulate(draws, path):
    _, _, cases = closedloop.expand(path)
    chosen = [c for c in cases if c["labels"]["draw"] < draws]
    estimates = check_closed_loop(chosen, path)
    print(f"\n### simulate: draws 0..{draws - 1} of every controller of {path.name}\n")
    row("controller", "kind", "draw", "status", "samples", "CPU s", "wall s", "estimate s", "CPU ms a sample",
        "constant ms")
    print("|---|---|---|---|---|---|---|---|---|---|")
    by_kind = {}
    for case, estimate in zip(chosen, estimates):
        kind = closedloop.controller_spec(case)["kind"]
        result, c, w = timed(lambda: closedloop.run_loop_case(case))
        samples = (result["summary"] or {}).get("samples") or 0
        by_kind.setdefault(kind, []).append(c / max(samples, 1))
        row(case["labels"]["controller"], kind, case["labels"]["draw"], result["status"], samples, f"{c:.2f}",
            f"{w:.2f}", f"{estimate:.2f}", f"{1e3 * by_kind[kind][-1]:.2f}",
            f"{1e3 * spec_seconds(case['controller'], case['points']):.2f}")
    print("\nmean CPU a sample by kind (set-up included): " + ", ".join(
        f"{kind} {1e3 * np.mean(v):.2f} ms" for kind, v in by_kind.items()))


def bench_network():
    path = STUDIES / "network_metro_2trains.yaml"
    st = load_network_study(path)
    estimate = sum(sizes.network_runs(st, path))
    steps = estimate / sizes.NETWORK_SECONDS_PER_STEP
    with tempfile.TemporaryDirectory() as out:  # every strategy computed: a fresh store
        _, c, w = timed(lambda: batch.run_expanded("network", expand_network(path, out=out), path))
    print(f"\n### network: {path.name}, {len(st.strategies)} strategies, one worker\n")
    row("steps (legs x trains x strategies)", "CPU s", "wall s", "estimate s", "CPU ms a step", "constant ms")
    print("|---|---|---|---|---|---|")
    row(f"{steps:,.0f}", f"{c:.1f}", f"{w:.1f}", f"{estimate:.1f}", f"{1e3 * c / steps:.2f}",
        f"{1e3 * sizes.NETWORK_SECONDS_PER_STEP:.2f}")


def bench_heavyhaul(samples):
    path = STUDIES / "heavyhaul_fence.yaml"
    study, _, reference, cases = heavyhaul.expand(path)
    full = sizes.heavyhaul_runs(study, reference, cases)
    print(f"\n### heavyhaul: the first {samples} samples of each run of {path.name}\n")
    row("f", "status", "samples", "CPU s", "wall s", "CPU s a sample", "constant s", "estimate of the whole run s")
    print("|---|---|---|---|---|---|---|---|")
    for case, estimate in zip(cases, full):
        case = {**case, "max_samples": samples}
        result, c, w = timed(lambda: heavyhaul.run_heavyhaul_case(case))
        n = (result["summary"] or {}).get("samples") or 0
        f = case["labels"]["f"]
        constant = sizes.HEAVYHAUL_SECONDS_PER_SAMPLE.get(f, sizes.HEAVYHAUL_SECONDS_PER_SAMPLE_GROUPED)
        row(f, result["status"], n, f"{c:.1f}", f"{w:.1f}", f"{c / max(n, 1):.3f}", constant, f"{estimate:.0f}")


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
    row("study", "runs", "computing", "one worker", f"{cores} workers")
    print("|---|---|---|---|---|")
    for path in sorted(STUDIES.glob("*.yaml")):
        if not heavy and "consist" in load_yaml(path.read_text()):
            continue
        runs = shipped_runs(path)
        one, many = study_estimate(runs, 1), study_estimate(runs, cores)
        row(path.stem, len(runs), duration(one[0]), duration(one[1]), duration(many[1]))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kinds", nargs="*", default=["run", "simulate", "network", "heavyhaul"])
    p.add_argument("--cases", type=int, default=4)
    p.add_argument("--draws", type=int, default=1)
    p.add_argument("--samples", type=int, default=30)
    p.add_argument("--loop-study", type=Path, default=STUDIES / "metro_monte_carlo.yaml")
    p.add_argument("--shipped", action="store_true")
    p.add_argument("--no-heavy", action="store_true")
    args = p.parse_args()
    print(f"`python bench/bench_sizes.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`")
    configure()
    for kind in args.kinds:
        {"run": lambda: bench_run(args.cases), "simulate": lambda: bench_simulate(args.draws, args.loop_study),
         "network": bench_network, "heavyhaul": lambda: bench_heavyhaul(args.samples)}[kind]()
    if args.shipped:
        bench_shipped(not args.no_heavy)


if __name__ == "__main__":
    main()
