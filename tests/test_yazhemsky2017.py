"""Yazhemsky 2017 Ch.9 trips at their published arrival times.

The published controller keeps a 1 m/s speed buffer and a 20 % braking reserve, so the true
optimum of the same model can only use less energy than the published figure.
Published numbers: tests/data/yazhemsky2017_published.csv (Yazhemsky 2017 Figs. 9.1-9.4).
"""
import pandas as pd
import pytest

from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train

from ecostudy.analysis.single import solve_run

from .conftest import DATA, TRACKS, TRAINS

CASES = pd.read_csv(DATA / "yazhemsky2017_published.csv").to_dict("records")


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c['track']}-{c['running_time_s']}")
def test_energy_at_most_published(case):
    train = load_train(TRAINS / "yazhemsky2017_commuter.yaml")
    track = load_track(TRACKS / f"{case['track']}.yaml")
    r = solve_run(track, train, "A", "B", Timing(running_time=case["running_time_s"]), points=1000)
    assert r.summary["verification"]["passed"], r.summary["verification"]
    assert r.summary["solver"]["status"] == "optimal"
    assert r.summary["traction_energy_J_per_kg"] <= case["published_energy_J_per_kg"]
    # and not absurdly far below: the buffers cost a few per cent, not half
    assert r.summary["traction_energy_J_per_kg"] >= 0.75 * case["published_energy_J_per_kg"]
