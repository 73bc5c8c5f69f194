"""OSRD's realistic rolling stocks (``tests/data/rolling_stocks/realistic/*.json`` of
OpenRailAssociation/osrd) imported with OSRD's semantics and solved on a shipped line.

    .venv/bin/python bench/bench_osrd.py --folder PATH [--track tracks/regional_808m.yaml]
        [--modes] [--points 500]

Every file in its default mode (``--modes``: every mode): all-out, then +10 % energy-optimal,
re-simulated; the table gives the speed cap and acceleration bound read from the file, and the
re-simulated top speed and largest acceleration, which must stay within them.
"""
import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folder", required=True, help="OSRD's realistic rolling-stock folder.")
    ap.add_argument("--track", default=str(ROOT / "tracks" / "yazhemsky2017_5km_representative.yaml"))
    ap.add_argument("--modes", action="store_true", help="Every power mode, not only the default.")
    ap.add_argument("--points", type=int, default=500)
    args = ap.parse_args()
    track = load_track(args.track)
    a, b = list(track.stops)[0], list(track.stops)[-1]
    print(f"{harness.command(__file__)} on {track.name}\n")
    table = harness.Table(["file", "mode", "cap km/h", "comfort acc m/s^2", "warnings", "all-out s", "+10 % kWh",
                           "verified", "top speed km/h", "largest acc m/s^2"])
    for path in sorted(Path(args.folder).glob("*.json")):
        doc = json.loads(path.read_text())
        modes = list(doc["effort_curves"]["modes"]) if args.modes else [doc["effort_curves"]["default_mode"]]
        for mode in modes:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                train = load_train(f"{path}#{mode}")
                r = solve_run(track, train, a, b, Timing(supplement=0.10), points=args.points)
            dt = np.diff(r.trace.t)
            acc = np.diff(r.trace.v)[dt > 1e-3] / dt[dt > 1e-3]
            s = r.summary
            table.add(path.name, mode, f"{train.max_speed * 3.6:.0f}", f"{train.max_acceleration:g}", len(caught),
                      f"{s['all_out_time_s']:.1f}", f"{s['traction_energy_kWh']:.3f}", s["verification"]["passed"],
                      f"{max(r.trace.v) * 3.6:.1f}", f"{acc.max():.3f}")


if __name__ == "__main__":
    main()
