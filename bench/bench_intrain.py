"""Heavy haul: what each in-train effect of the plant (air-brake propagation, draft gear, adhesion,
all three; the locomotives' notches) changes on the shipped line, at K_b = 1 and 60 (Np = 4, Nc = 2, f = 10): the largest draft
and buff forces and where, slack run-ins, the rainflow damage proxy and the energy balance [kWh].

    python bench/bench_intrain.py                      # the six plants, two K_b each (outputs in out/bench_intrain_*)
    python bench/bench_intrain.py none air_brake       # some of them
    python bench/bench_intrain.py --study heavyhaul_intrain_5km   # the same on the 5 km line with a hump

Each plant is a copy of studies/heavyhaul_brake_penalty.yaml with ``brake_penalty: [1, 60]`` and the
switches set (written beside it, removed after the run); runs are resumable. Prints markdown for
docs/heavyhaul.md ("In-train physics").
"""
import argparse
import sys
import warnings
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.api.blas import limit_blas_threads  # noqa: E402
from ecostudy.core.errors import EcostudyWarning  # noqa: E402

STUDY = "heavyhaul_brake_penalty"
PLANTS = {"none": {}, "air_brake": {"air_brake": True}, "draft_gear": {"draft_gear": True},
          "adhesion": {"adhesion": True}, "all": {"air_brake": True, "draft_gear": True, "adhesion": True},
          "notches": {"notches": True}}
FORCES = ["status", "tracking_mean_mps", "draft_max_kN", "draft_coupler", "buff_max_kN", "buff_coupler", "run_ins_count",
          "fatigue_damage", "fatigue_damage_max", "rainflow_cycles_over_100kN_count", "force_max_braking_kN"]
ENERGY = ["traction_kWh", "dynamic_brake_kWh", "wagon_brake_kWh", "running_resistance_kWh", "curve_resistance_kWh",
          "grade_kWh", "coupler_damping_kWh", "draft_gear_kWh", "stored_change_kWh", "balance_residual_kWh"]


def plant_runs(name, workers, study=STUDY):
    """The runs table of one plant (a copy of the shipped ``study`` with its switches)."""
    from ecostudy.studies.heavyhaul import heavyhaul_study
    path = ROOT / "studies" / f"{study}.yaml"
    doc = yaml.safe_load(path.read_text())
    doc.update({"brake_penalty": [1, 60], **PLANTS[name]})
    copy = path.with_name(f".{study}_intrain_{name}.yaml")
    copy.write_text(yaml.safe_dump(doc))
    out = ROOT / "out" / (f"bench_intrain_{name}" if study == STUDY else f"bench_intrain_{study}_{name}")
    try:
        return heavyhaul_study(copy, workers=workers, out=out).runs
    finally:
        copy.unlink()


@harness.case("intrain.plant", params={"plant": "air_brake", "workers": 2, "study": STUDY})
def one_plant(p):
    """A whole heavy-haul study (K_b 1 and 60) on one in-train plant (minutes; outputs in out/bench_intrain_*)."""
    limit_blas_threads(1)
    runs = plant_runs(p["plant"], p["workers"], p["study"])
    return {"runs": len(runs), "status": "ok" if (runs["status"] == "ok").all() else "flagged: a run is not ok"}


def table(rows, columns):
    print(harness.markdown([{"plant": name, "K_b": f"{row['K_b']:g}", **{c: row[c] for c in columns}} for name, row in rows],
                           ["plant", "K_b"] + list(columns)))


if __name__ == "__main__":
    warnings.simplefilter("ignore", EcostudyWarning)
    parser = argparse.ArgumentParser()
    parser.add_argument("plants", nargs="*", help=f"plants among {', '.join(PLANTS)} (default: all six)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--study", default=STUDY, help="a shipped heavy-haul study (default: Table IV's line)")
    args = parser.parse_args()
    if set(args.plants) - set(PLANTS):
        parser.error(f"unknown plants {sorted(set(args.plants) - set(PLANTS))} (known: {', '.join(PLANTS)})")
    limit_blas_threads(1)
    rows = []
    for name in args.plants or PLANTS:
        runs, _, wall = harness.timed(lambda: plant_runs(name, args.workers, args.study))
        print(f"{name}: {wall:.0f} s wall", file=sys.stderr, flush=True)
        rows += [(name, row) for _, row in runs.iterrows()]
    table(rows, FORCES)
    print()
    table(rows, ENERGY)
