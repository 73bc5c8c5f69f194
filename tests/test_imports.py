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


def test_a_train_never_runs_faster_than_its_top_speed(tmp_path):
    """TTOBench `max speed` (and OSRD `max_speed`) cap every limit: the Beijing subway train (80 km/h)
    on a 120 km/h line with 3 km between stops stays at 80 km/h, in the optimum and its re-simulation.
    Before, `max speed` was read and ignored, and the train ran at up to 120 km/h."""
    import json

    from ecostudy.analysis.single import solve_run
    from ecostudy.core.types import Timing
    from ecostudy.core.errors import InputError
    from ecostudy.io.loaders import load_train, track_from_dict
    train = load_train(DATA / "ttobench_subway_train.json")
    assert train.max_speed == pytest.approx(80 / 3.6)
    line = track_from_dict({"name": "fast line", "source": "test", "length_m": 3000,
                            "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 3000}],
                            "gradients": [{"position_m": 0, "gradient_permille": 0}],
                            "speed_limits": [{"position_m": 0, "speed_kmh": 120}]})
    allout = solve_run(line, train, "A", "B", Timing(), objective="time", points=300)
    assert allout.summary["top_speed_kmh"] <= 80.0 + 1e-6
    assert max(allout.trace.v) * 3.6 <= 80.5
    # the same speed given in m/s is converted; an unknown unit is refused by name
    doc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    doc["max speed"] = {"unit": "m/s", "value": 20.0}
    (tmp_path / "t.json").write_text(json.dumps(doc))
    assert load_train(tmp_path / "t.json").max_speed == pytest.approx(20.0)
    doc["max speed"] = {"unit": "mph", "value": 50.0}
    (tmp_path / "t.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="max speed.unit"):
        load_train(tmp_path / "t.json")
    osrd = load_train(DATA / "osrd_rolling_stock.json")
    assert osrd.max_speed == pytest.approx(38.88)


def test_ttobench_acceleration_bounds_sit_on_top_of_the_brake_forces(tmp_path):
    """ms-eetc's semantics (mseetc/train.py, ocp.py): `max acceleration` and `max deceleration`
    bound the net acceleration; the brakes are the regenerative and pneumatic forces. Before, a
    train with `max deceleration` lost its brake forces (the deceleration became the brake) and
    `max acceleration` was ignored."""
    doc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    doc["max acceleration"] = {"unit": "m/s^2", "value": 0.5}
    doc["max deceleration"] = {"unit": "m/s^2", "value": 1.0}
    doc["max reg braking force"] = {"unit": "kN", "value": 100.0}  # weaker than 1.0 m/s^2 on 278 t
    (tmp_path / "t.json").write_text(json.dumps(doc))
    train = load_train(tmp_path / "t.json")
    assert train.max_acceleration == 0.5 and train.max_deceleration == 1.0
    assert train.braking.peak == pytest.approx(100e3, rel=1e-3)  # the brake forces, not m * 1.0
    track = load_track(DATA / "ttobench_track.json")
    stops = list(track.stops)
    r = solve_run(track, train, stops[0], stops[1], Timing(), objective="time", points=400)
    v, x = r.trajectory.v, r.nodes
    mean_acc = (v[1:] ** 2 - v[:-1] ** 2) / (2 * np.diff(x))
    assert mean_acc.max() <= 0.5 + 1e-5  # the full traction envelope gives 1.1 m/s^2 at start
    assert r.trajectory.fb.max() <= 100e3 * 1.001 < train.mass * 1.0  # braked with its brake, 0.36 m/s^2
    assert -mean_acc.min() < 1.0
    dt = np.diff(r.trace.t)
    accel = np.diff(r.trace.v)[dt > 1e-6] / dt[dt > 1e-6]  # re-simulated (the plant keeps the bound too)
    assert accel.max() <= 0.5 + 0.02
