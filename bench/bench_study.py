"""Throughput of a batch study: a 200-case study run serially and with 2 worker processes.

    .venv/bin/python bench/bench_study.py [--points 500] [--workers 1 2]

The study (written to a temporary folder): Amsterdam metro, 5 train-mass scenarios (nominal,
+/-10 t, +20 t, +30 t) x 40 running-time supplements (1 % to 40 %) = 200 cases, K = 500, each
energy-optimal and verified; the all-out time is solved once per scenario and process. Every
configuration starts from an empty store.
"""
import argparse
import shlex
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.studies.batch import run_study  # noqa: E402


def study(folder, points):
    extra = [(-10, "minus10t"), (10, "plus10t"), (20, "plus20t"), (30, "plus30t")]
    data = {"name": "bench_200", "track": str(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
            "train": str(ROOT / "trains/amsterdam_metro.yaml"), "from": "Rokin", "to": "Centraal",
            "supplement_percent": 10, "points": points,
            "scenarios": [{"name": n, "train_overrides": {"mass_t": 131.403 + dm, "effective_mass_t": 142.403 + dm}}
                          for dm, n in extra],
            "sweep": {"supplement_percent": list(range(1, 41))}, "output": str(folder / "out")}
    path = folder / "study.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=500)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = p.parse_args()
    print(f"`python bench/bench_study.py {' '.join(shlex.quote(a) for a in sys.argv[1:])}`\n")
    print("| workers | cases | wall s | cases per s | s per case | not ok |\n|---|---|---|---|---|---|")
    for w in args.workers:
        with tempfile.TemporaryDirectory() as d:
            path = study(Path(d), args.points)
            t0 = time.perf_counter()
            table, counts, _ = run_study(path, workers=w)
            wall = time.perf_counter() - t0
            print(f"| {w} | {counts['computed']} | {wall:.1f} | {counts['computed'] / wall:.2f} | "
                  f"{wall / counts['computed']:.3f} | {counts['not_ok']} |", flush=True)


if __name__ == "__main__":
    main()
