"""The mass estimators over noise seeds on Yazhemsky 2017's Ch. 10 trip (20 % heavier train,
§10.1 noise, the convex controller at 10 Hz, compute delay 1; ``studies.estimator_trips``).

    .venv/bin/python bench/bench_estimator.py [--estimator state|mass] [--seeds 20] [--first 0] [--points 300]
        [--workers 2] [--until 2000]

Prints per seed the relative error of the mass estimate where the train passes 2 km and at the
stop (5 km), the stop error, and the 95th percentile of the absolute errors over the seeds
(numpy's linear interpolation). ``--until 2000``: the trips stop at 2 km (the 2 km errors are
the same as the whole trip's: the trip is the same up to there), as tests/test_estimator.py's.
"""
import argparse
import sys
from functools import partial
from multiprocessing import Pool
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.units import signed  # noqa: E402
from ecostudy.ocp.solver import configure  # noqa: E402
from ecostudy.studies.estimator_trips import estimator_trip  # noqa: E402

MARKS = (2000.0, 5000.0)


def trip_setup(p):
    configure()
    return p


@harness.case("estimator.trip", setup=trip_setup, params={"estimator": "state", "seed": 0, "points": 300, "until": 5000.0})
def one_trip(p):
    """One noisy trip with the estimator (Yazhemsky 2017): relative errors at 2 and 5 km, stop error."""
    trip = estimator_trip(ROOT, p["seed"], choice=p["estimator"], points=p["points"], marks=MARKS, until=p["until"])
    return {**{f"error_{m / 1e3:g}km_pct": 100 * trip.errors[m] for m in MARKS if m in trip.errors},
            "stop_error_m": trip.stop_error_m}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--estimator", default="state", choices=("state", "mass"))
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--points", type=int, default=300)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--first", type=int, default=0, help="the first seed")
    p.add_argument("--until", type=float, default=None, help="stop each trip at this position [m]")
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    configure()
    run = partial(estimator_trip, ROOT, choice=args.estimator, points=args.points, marks=MARKS, until=args.until)
    table = harness.Table(["seed", "error at 2 km [%]", "error at 5 km [%]", "stop error [m]"])

    def all_trips():
        with Pool(args.workers) as pool:
            trips = []
            for trip in pool.imap(run, range(args.first, args.first + args.seeds)):
                trips.append(trip)
                cells = [signed(100 * trip.errors[m], 3) if m in trip.errors else "-" for m in MARKS]
                table.add(trip.seed, *cells, "-" if trip.stop_error_m is None else signed(trip.stop_error_m, 3))
            return trips

    trips, _, wall = harness.timed(all_trips)
    for mark in [m for m in MARKS if all(m in t.errors for t in trips)]:
        errors = np.abs([t.errors[mark] for t in trips])
        print(f"\nat {mark / 1e3:g} km over {len(trips)} seeds: p95 |error| {100 * np.percentile(errors, 95):.3f} %, "
              f"max {100 * errors.max():.3f} %", end="")
    print(f"\n\n{wall:.0f} s wall, {args.workers} workers, K = {args.points}")


if __name__ == "__main__":
    main()
