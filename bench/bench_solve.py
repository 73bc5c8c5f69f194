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
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.report.files import write_run  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402

STAGES = ["load", "grid", "build", "nl_write", "solve", "verify", "write"]
PARAMS = {"points": 1000, "track": str(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
          "train": str(ROOT / "trains/amsterdam_metro.yaml"), "from_stop": "Rokin", "to_stop": "Centraal",
          "time": 76.0, "write": True}


def one_run(p, objective):
    """One whole run (load, solve_run's stages, write): the stages, Ipopt's iterations and status,
    the run's status, energy and running time."""
    with harness.stage() as load:
        track, train = load_track(p["track"]), load_train(p["train"])
    timing = Timing() if objective == "time" else Timing(running_time=p["time"])
    r = solve_run(track, train, p["from_stop"], p["to_stop"], timing, objective=objective, points=p["points"])
    with tempfile.TemporaryDirectory() as d, harness.stage() as write:
        if p["write"]:
            write_run(r, d)
    res = r.summary
    stages = {k: v for k, v in r.stages.items() if k in STAGES}
    return {"stages": dict(stages, load=load.seconds, write=write.seconds), "iterations": res["solver"]["iterations"],
            "ipopt": res["solver"]["status"], "verified": res["verification"]["passed"], "status": str(r.status),
            "energy_kWh": res["traction_energy_kWh"], "time_s": res["running_time_s"]}


for _objective in ("energy", "time"):
    harness.register(f"solve.{_objective}", lambda p, o=_objective: one_run(p, o), params=PARAMS,
                     doc=f"One whole run (load, grid, build, NL write, Ipopt, verify, write), objective {_objective}"
                         + (" in `time` s" if _objective == "energy" else " (all-out)") + ": seconds per stage")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, nargs="+", default=[200, 500, 1000, 2000, 5000])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--track", default=PARAMS["track"])
    p.add_argument("--train", default=PARAMS["train"])
    p.add_argument("--from-stop", default="Rokin")
    p.add_argument("--to-stop", default="Centraal")
    p.add_argument("--time", type=float, default=76.0)
    p.add_argument("--out", default=str(ROOT / "bench/results"))
    p.add_argument("--cli-points", type=int, nargs="*", default=[1000],
                   help="also time the whole `ecostudy solve` command (new process) at these K")
    args = p.parse_args()
    params = {k: getattr(args, k) for k in PARAMS if k not in ("points", "write")}

    lines = [harness.command(__file__), ""]
    energies = {}
    for objective in ("energy", "time"):
        lines += [f"### objective `{objective}`" + (f", running time {args.time:g} s" if objective == "energy" else " (all-out)"), ""]
        table = harness.Table(["K"] + STAGES + ["total", "iterations", "status", "verified", "energy kWh", "time s"])
        for k in args.points:
            runs = harness.measure([f"solve.{objective}"], args.repeat, dict(params, points=k))[f"solve.{objective}"]
            energies[(objective, k)] = (runs.last("energy_kWh"), runs.last("time_s"))
            table.add(k, *(f"{runs.median(f'{s}_s', 0.0):.3f}" for s in STAGES), f"{runs.median('wall_s'):.3f}",
                      runs.last("iterations"), runs.last("ipopt"), runs.last("verified"),
                      f"{runs.last('energy_kWh'):.5f}", f"{runs.last('time_s'):.4f}")
        lines += [table.text(), ""]
    kmax = max(args.points)
    lines += [f"### accuracy against K = {kmax}", ""]
    accuracy = harness.Table(["K", "energy-optimal: energy error %", "all-out: time error %"], show=False)
    for k in args.points:
        e = 100 * (energies[("energy", k)][0] / energies[("energy", kmax)][0] - 1)
        t = 100 * (energies[("time", k)][1] / energies[("time", kmax)][1] - 1)
        accuracy.add(k, signed(e, 4), signed(t, 4))
    lines.append(accuracy.text())
    if args.cli_points:
        lines += ["", "### whole command: `ecostudy solve --track T --train R --time S --points K --out DIR` "
                  "(new Python process: imports, solve, verification, CSV/JSON/PNG)", ""]
        whole = harness.Table(["K", "wall s (median)", "runs"], show=False)
        exe = str(Path(sys.executable).parent / "ecostudy")
        for k in args.cli_points:
            def command(d):
                subprocess.run([exe, "solve", "--track", args.track, "--train", args.train, "--from", args.from_stop,
                                "--to", args.to_stop, "--time", str(args.time), "--points", str(k), "--out", d],
                               check=True, capture_output=True)
            walls = harness.Samples("solve command", {})
            for _ in range(args.repeat):
                with tempfile.TemporaryDirectory() as d:
                    walls.append(harness.sample(command, d))
            whole.add(k, f"{walls.median('wall_s'):.2f}", len(walls))
        lines.append(whole.text())
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_solve.md").write_text(text)


if __name__ == "__main__":
    main()
