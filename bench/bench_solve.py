"""Per-stage timings of one ecostudy run against the grid size, and accuracy against K.

    .venv/bin/python bench/bench_solve.py [--points 200 500 1000 2000 5000] [--repeat 3]
        [--track tracks/amsterdam_rokin_centraal.yaml] [--train trains/amsterdam_metro.yaml]
        [--time 76] [--out bench/results]

Prints markdown tables (median of --repeat runs per cell, in seconds) headed by the command
line, and writes them to bench/results/. Stages: load (read and validate files), grid
(segment, grid, envelope guess), build (Pyomo model), nl_write (PyomoNLP: NL file written and
loaded through ASL), solve (Ipopt), verify (re-simulation), write (CSV, JSON, PNG).
"""
import argparse
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.report.files import write_run  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402

STAGES = ["load", "grid", "build", "nl_write", "solve", "verify", "write"]


def one_run(args, points, objective):
    t0 = time.perf_counter()
    track, train = load_track(args.track), load_train(args.train)
    load = time.perf_counter() - t0
    timing = Timing() if objective == "time" else Timing(running_time=args.time)
    t1 = time.perf_counter()
    r = solve_run(track, train, args.from_stop, args.to_stop, timing, objective=objective, points=points)
    run = time.perf_counter() - t1
    with tempfile.TemporaryDirectory() as d:
        t2 = time.perf_counter()
        write_run(r, d)
        write = time.perf_counter() - t2
    st = dict(r.stages, load=load, write=write)
    st["total"] = load + run + write
    return st, r


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, nargs="+", default=[200, 500, 1000, 2000, 5000])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--track", default=str(ROOT / "tracks/amsterdam_rokin_centraal.yaml"))
    p.add_argument("--train", default=str(ROOT / "trains/amsterdam_metro.yaml"))
    p.add_argument("--from-stop", default="Rokin")
    p.add_argument("--to-stop", default="Centraal")
    p.add_argument("--time", type=float, default=76.0)
    p.add_argument("--out", default=str(ROOT / "bench/results"))
    p.add_argument("--cli-points", type=int, nargs="*", default=[1000],
                   help="also time the whole `ecostudy solve` command (new process) at these K")
    args = p.parse_args()
    command = "python bench/bench_solve.py " + " ".join(shlex.quote(a) for a in sys.argv[1:])

    lines = [f"`{command}`", ""]
    energies = {}
    for objective in ("energy", "time"):
        lines += [f"### objective `{objective}`" + (f", running time {args.time:g} s" if objective == "energy" else " (all-out)"), "",
                  "| K | " + " | ".join(STAGES) + " | total | iterations | status | verified | energy kWh | time s |",
                  "|---" * (len(STAGES) + 7) + "|"]
        for k in args.points:
            runs = [one_run(args, k, objective) for _ in range(args.repeat)]
            med = {s: statistics.median(r[0].get(s, 0.0) for r in runs) for s in STAGES + ["total"]}
            res = runs[-1][1].summary
            energies[(objective, k)] = (res["traction_energy_kWh"], res["running_time_s"])
            lines.append(f"| {k} | " + " | ".join(f"{med[s]:.3f}" for s in STAGES)
                         + f" | {med['total']:.3f} | {res['solver']['iterations']} | {res['solver']['status']}"
                         + f" | {res['verification']['passed']} | {res['traction_energy_kWh']:.5f} | {res['running_time_s']:.4f} |")
            print(lines[-1], flush=True)
        lines.append("")
    kmax = max(args.points)
    lines += [f"### accuracy against K = {kmax}", "",
              "| K | energy-optimal: energy error % | all-out: time error % |", "|---|---|---|"]
    for k in args.points:
        e = 100 * (energies[("energy", k)][0] / energies[("energy", kmax)][0] - 1)
        t = 100 * (energies[("time", k)][1] / energies[("time", kmax)][1] - 1)
        lines.append(f"| {k} | {e:+.4f} | {t:+.4f} |")
    if args.cli_points:
        lines += ["", "### whole command: `ecostudy solve --track T --train R --time S --points K --out DIR` "
                  "(new Python process: imports, solve, verification, CSV/JSON/PNG)", "",
                  "| K | wall s (median) | runs |", "|---|---|---|"]
        exe = str(Path(sys.executable).parent / "ecostudy")
        for k in args.cli_points:
            walls = []
            for _ in range(args.repeat):
                with tempfile.TemporaryDirectory() as d:
                    t0 = time.perf_counter()
                    subprocess.run([exe, "solve", "--track", args.track, "--train", args.train, "--from",
                                    args.from_stop, "--to", args.to_stop, "--time", str(args.time),
                                    "--points", str(k), "--out", d], check=True, capture_output=True)
                    walls.append(time.perf_counter() - t0)
            lines.append(f"| {k} | {statistics.median(walls):.2f} | {len(walls)} |")
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_solve.md").write_text(text)


if __name__ == "__main__":
    main()
