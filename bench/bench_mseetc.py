"""TTOBench's own train and track files read by ecostudy against the solver of their authors (ms-eetc).

    .venv/bin/python bench/bench_mseetc.py --ttobench PATH --mseetc PATH [--points 1000] \
        [--trains NL_Intercity_VIRM6] [--pneumatic on off]

The same files on both sides, nothing typed in: TTOBench's ``tracks/00_var_speed_limit_100.json``
(48 531 m, flat, 140 / 100 / 140 km/h) and ``trains/<train>.json`` (TTOBench and ms-eetc ship the same
VIRM6 file), read by ecostudy's TTOBench reader and by ms-eetc's ``Train`` and ``Track`` (their
``pathJSON`` pointed at the TTOBench checkout). Both minimise the net energy (traction / eta_T -
eta_R x regenerated) from 1 m/s to 1 m/s in ``--time`` seconds: ecostudy's space NLP
(``ocp.restart.Replanner``, K nodes, Ipopt through Pyomo) re-driven by its plant, ms-eetc's
``casadiSolver`` (K intervals, RK4, its ``simulations/config.json`` options, CasADi's Ipopt).
``--pneumatic off`` sets the file's ``max pn braking force`` to 0 on both sides (ms-eetc through its
train configuration, ecostudy through a copy of the file). ms-eetc needs CasADi
(``pip install -e '.[bench]'``); its repository is not a dependency. Its ``Track`` forward-fills
with ``fillna(method='ffill')``, which pandas 3 removed: the bench hands that call to ``ffill()``,
the same fill (:func:`forward_fill_as_pandas_2`), and changes nothing else of ms-eetc.
"""
import argparse
import contextlib
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import pandas as pd  # noqa: E402

from bench import harness  # noqa: E402
from bench.bench_gpops import run  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402

TRACK = "00_var_speed_limit_100"
PNEUMATIC = "max pn braking force"
END_SPEED = 1.0  # [m/s] both ends: ms-eetc's space-domain NLP divides by the speed


def train_file(ttobench: Path, name: str, pneumatic: bool, folder: Path) -> Path:
    """The TTOBench train file, or a copy with no pneumatic brake."""
    path = ttobench / "trains" / f"{name}.json"
    if pneumatic:
        return path
    doc = json.loads(path.read_text())
    doc[PNEUMATIC] = {"unit": "kN", "value": 0.0}
    copy = folder / path.name
    copy.write_text(json.dumps(doc))
    return copy


def forward_fill_as_pandas_2() -> None:
    """``DataFrame.fillna(method='ffill')`` as pandas 2 had it (ms-eetc's ``Track`` calls it)."""
    fillna = pd.DataFrame.fillna
    if getattr(fillna, "as_pandas_2", False):
        return

    def patched(self, *args, method=None, **kwargs):
        return self.ffill() if method == "ffill" and not args and not kwargs else fillna(self, *args, **kwargs)
    patched.as_pandas_2 = True  # type: ignore[attr-defined]
    pd.DataFrame.fillna = patched  # type: ignore[method-assign]


@contextlib.contextmanager
def quiet():
    """Standard output of C code too (CasADi's Ipopt prints every iteration) sent to /dev/null."""
    sys.stdout.flush()
    saved, null = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(null)
        os.close(saved)


def mseetc_run(mseetc: Path, ttobench: Path, name: str, pneumatic: bool, points: int, seconds: float) -> dict:
    """ms-eetc's own optimum of the case: its cost [kWh], Ipopt's status and iterations, seconds."""
    sys.path.insert(0, str(mseetc))
    forward_fill_as_pandas_2()
    from mseetc.ocp import casadiSolver  # noqa: PLC0415 (ms-eetc and CasADi only when asked for)
    from mseetc.track import Track  # noqa: PLC0415
    from mseetc.train import Train  # noqa: PLC0415
    config = {"id": name, **({} if pneumatic else {PNEUMATIC: {"unit": "kN", "value": 0.0}})}
    train = Train(config=config, pathJSON=ttobench / "trains")
    track = Track(config={"id": TRACK}, pathJSON=ttobench / "tracks")
    options = json.loads((mseetc / "simulations" / "config.json").read_text())
    options.update(numIntervals=points, minimumVelocity=END_SPEED)
    with quiet(), harness.stage() as solving:
        _, stats = casadiSolver(train, track, options).solve(seconds, terminalVelocity=END_SPEED,
                                                             initialVelocity=END_SPEED)
    return {"kWh": float(stats["Cost"]), "status": stats["Solver status"], "iterations": stats["IP iterations"],
            "seconds": solving.seconds}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ttobench", required=True, type=Path, help="A TTOBench checkout (tracks/, trains/).")
    ap.add_argument("--mseetc", required=True, type=Path, help="An ms-eetc checkout (mseetc/, simulations/).")
    ap.add_argument("--points", type=int, nargs="+", default=[1000])
    ap.add_argument("--trains", nargs="+", default=["NL_Intercity_VIRM6"])
    ap.add_argument("--pneumatic", nargs="+", choices=["on", "off"], default=["on", "off"])
    ap.add_argument("--time", type=float, default=1541.0, help="Running time [s] (ms-eetc's GPOPS-II case).")
    args = ap.parse_args()
    track = load_track(args.ttobench / "tracks" / f"{TRACK}.json")
    print(harness.command(__file__) + "\n")
    table = harness.Table(["train", "pneumatic brake", "K", "ecostudy Ipopt", "iterations", "s", "NLP net kWh",
                           "re-driven kWh", "re-driven time s", "ms-eetc Ipopt", "iterations", "s", "ms-eetc kWh",
                           "NLP vs ms-eetc", "re-driven vs ms-eetc"])
    with tempfile.TemporaryDirectory() as folder:
        for name in args.trains:
            for pn in args.pneumatic:
                train = load_train(train_file(args.ttobench, name, pn == "on", Path(folder)))
                for k in args.points:
                    eco = run(track, train, k, v_end=END_SPEED, running_time=args.time)
                    try:
                        ms = mseetc_run(args.mseetc, args.ttobench, name, pn == "on", k, args.time)
                    except ValueError as exc:  # ms-eetc reads TTOBench library versions 1.1-1.3 only
                        table.add(name, pn, k, eco["ipopt"], eco["iterations"], f"{eco['seconds']:.1f}",
                                  f"{eco['model_kWh']:.4f}", f"{eco['simulated_kWh']:.4f}",
                                  f"{eco['simulated_time_s']:.2f}", f"refused: {exc}", "", "", "", "", "")
                        continue
                    table.add(name, pn, k, eco["ipopt"], eco["iterations"], f"{eco['seconds']:.1f}",
                              f"{eco['model_kWh']:.4f}", f"{eco['simulated_kWh']:.4f}", f"{eco['simulated_time_s']:.2f}",
                              ms["status"], ms["iterations"], f"{ms['seconds']:.1f}", f"{ms['kWh']:.4f}",
                              f"{signed(100 * (eco['model_kWh'] / ms['kWh'] - 1), 4)} %",
                              f"{signed(100 * (eco['simulated_kWh'] / ms['kWh'] - 1), 4)} %")


if __name__ == "__main__":
    main()
