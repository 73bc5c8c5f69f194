"""Throughput of a batch study: a 200-case study run serially and with 2 worker processes.

    .venv/bin/python bench/bench_study.py [--points 500] [--workers 1 2]

The study (written to a temporary folder): Amsterdam metro, 5 train-mass scenarios (nominal,
+/-10 t, +20 t, +30 t) x 40 running-time supplements (1 % to 40 %) = 200 cases, K = 500, each
energy-optimal and verified; the all-out time is solved once per scenario and process. Every
configuration starts from an empty store.
"""
import argparse
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
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


@harness.case("study.batch", params={"points": 500, "workers": 1})
def batch(p):
    """The 200-case run study (5 masses x 40 supplements, Amsterdam metro) through studies.batch, from an empty store."""
    with tempfile.TemporaryDirectory() as d:
        _, counts, _ = run_study(study(Path(d), p["points"]), workers=p["workers"])
    return {"cases": counts["computed"], "not_ok": counts["not_ok"]}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=500)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    table = harness.Table(["workers", "cases", "wall s", "cases per s", "s per case", "not ok"])
    for w in args.workers:
        r = harness.sample(batch, {"points": args.points, "workers": w})
        table.add(w, r["cases"], f"{r['wall_s']:.1f}", f"{r['cases'] / r['wall_s']:.2f}",
                  f"{r['wall_s'] / r['cases']:.3f}", r["not_ok"])


if __name__ == "__main__":
    main()
