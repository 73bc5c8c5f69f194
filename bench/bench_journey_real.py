"""A long multi-stop journey by stage and grid size: the whole-journey NLP (all segments in one
model, running times free, their sum fixed) and the verified per-segment solves at its times.

    .venv/bin/python bench/bench_journey_real.py --track TRACK --train TRAIN [--supplement 10]
        [--points 150 300 600 1200]

Stages: grid (segments, grids, fastest envelopes), all-out (each segment's all-out NLP, for the
total time), journey NLP (build, NL write and Ipopt of the one model), segments (each segment
solved and re-simulated at its running time). The energy is the sum of the verified segments.
"""
import argparse
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.analysis.single import solve_run  # noqa: E402
from ecostudy.core.types import Timing  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402
from ecostudy.studies.journey import whole_journey  # noqa: E402


def run(track, train, supplement, points):
    stops = list(track.stops)
    pairs = list(zip(stops, stops[1:]))
    with harness.stage() as grid:
        cases = [prepare(track, train, a, b, points) for a, b in pairs]
    with harness.stage() as all_out_s:
        all_out = [solve_run(track, train, a, b, Timing(), objective="time", points=points, verify_result=False)
                   .summary["running_time_s"] for a, b in pairs]
    total = sum(all_out) * (1 + supplement)
    with harness.stage() as journey_nlp:
        times, nlp_status = whole_journey(track, train, pairs, total, [t * (1 + supplement) for t in all_out], points)
    with harness.stage() as segments:
        runs = [solve_run(track, train, a, b, Timing(running_time=t), points=points) for (a, b), t in zip(pairs, times)]
    return {"points": points, "segments": len(cases), "grid": grid.seconds, "all_out": all_out_s.seconds,
            "journey_nlp": journey_nlp.seconds, "segments_s": segments.seconds,
            "total": grid.seconds + all_out_s.seconds + journey_nlp.seconds + segments.seconds, "time": sum(times),
            "energy": sum(r.summary["traction_energy_kWh"] for r in runs),
            "verified": all(r.summary["verification"]["passed"] for r in runs), "nlp_status": str(nlp_status)}


@harness.case("journey_real.journey", setup=lambda p: (load_track(ROOT / p["track"]), load_train(ROOT / p["train"]), p),
              params={"track": "tracks/regional_line_20stops.yaml", "train": "trains/regional_alstom.yaml",
                      "supplement": 10.0, "points": 150})
def journey(state):
    """A whole journey (every segment's all-out run, the journey NLP sharing the time, each segment solved and verified)."""
    track, train, p = state
    r = run(track, train, p["supplement"] / 100, p["points"])
    return {"segments": r["segments"], "stages": {k: r[k] for k in ("grid", "all_out", "journey_nlp", "segments_s")},
            "energy_kWh": r["energy"], "verified": r["verified"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--track", required=True)
    ap.add_argument("--train", required=True)
    ap.add_argument("--supplement", type=float, default=10.0, help="[%] over the sum of all-out times")
    ap.add_argument("--points", type=int, nargs="+", default=[150, 300, 600, 1200])
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    track, train = load_track(args.track), load_train(args.train)
    print(harness.command(__file__) + "\n")
    table = harness.Table(["K per segment", "segments", "grid s", "all-out s", "journey NLP s",
                           "segments solved + verified s", "total s", "running time s", "traction kWh", "verified"])
    for k in args.points:
        r = run(track, train, args.supplement / 100, k)
        table.add(k, r["segments"], f"{r['grid']:.2f}", f"{r['all_out']:.1f}", f"{r['journey_nlp']:.1f}",
                  f"{r['segments_s']:.1f}", f"{r['total']:.1f}", f"{r['time']:.1f}", f"{r['energy']:.3f}", r["verified"])
        if r["nlp_status"] != "ok":  # the split the segments were solved at is not a proven optimum
            print(f"K = {k}: the whole-journey NLP is {r['nlp_status']}")


if __name__ == "__main__":
    main()
