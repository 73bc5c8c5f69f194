"""TTOBench and OSRD JSON documents, recognised by content."""
import json

import numpy as np
import pytest

from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train
from ecostudy.analysis.single import solve_run

from .conftest import DATA


def test_ttobench_train_units():
    t = load_train(DATA / "ttobench_subway_train.json")
    assert t.mass == pytest.approx(278000.0)
    assert t.davis[0] == pytest.approx(3947.6)
    assert t.davis[2] == pytest.approx(2.2294 * 3.6**2)       # kN/(km/h)^2 -> N/(m/s)^2
    assert t.traction.force(5.0) == pytest.approx(310e3)
    assert t.traction.force(20.0) == pytest.approx(3100e3 / 20.0)
    assert t.traction_efficiency == pytest.approx(0.70)
    assert t.regeneration_efficiency == pytest.approx(0.80)


def test_ttobench_track_profiles():
    tk = load_track(DATA / "ttobench_track.json")
    assert list(tk.stops.values()) == [0.0, 1500.0, 2600.0]
    assert tk.gradients[1] == pytest.approx(0.012)
    # transition 'infinity' -> -800 m: mean curvature of the section, sign (direction) ignored
    assert tk.curvatures[1] == pytest.approx(0.5 / 800)
    assert tk.curvatures[2] == pytest.approx(1 / 800)
    assert tk.limits[1] == pytest.approx(80 / 3.6)


def test_osrd_rolling_stock():
    t = load_train(DATA / "osrd_rolling_stock.json")
    assert t.mass == pytest.approx(160000 * 1.06)
    assert t.length == 75.0
    assert t.braking.force(10.0) == pytest.approx(t.mass * 0.9)
    assert t.traction.force(np.array([20.0]))[0] == pytest.approx(110e3, rel=0.005)


def test_imported_case_solves_and_verifies():
    r = solve_run(load_track(DATA / "ttobench_track.json"), load_train(DATA / "ttobench_subway_train.json"),
                  "S0", "S1", Timing(supplement=0.1), points=400)
    assert r.summary["verification"]["passed"]


def test_unrecognised_json_is_one_clear_error(tmp_path):
    from ecostudy.core.errors import InputError
    p = tmp_path / "x.json"
    p.write_text(json.dumps({"hello": 1}))
    with pytest.raises(InputError, match="not a TTOBench or OSRD train"):
        load_train(p)
