"""TTOBench and OSRD JSON documents, recognised by content."""
import json

import numpy as np
import pytest

from ecostudy.core.errors import EcostudyWarning
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
    # transition 'infinity' -> -800 m over [500, 560]: a clothoid, curvature linear in distance
    # (signed: negative is a left-hand curve); its mean over any interval is the middle's value
    assert tk.curvatures[1] == 0.0 and tk.curvature_slopes[1] == pytest.approx(-1 / 800 / 60)
    assert tk.curvatures[2] == pytest.approx(-1 / 800) and tk.curvature_slopes[2] == 0.0
    assert tk.limits[1] == pytest.approx(80 / 3.6)
    from ecostudy.core.grid import make_segment
    train = load_train(DATA / "ttobench_subway_train.json")
    seg = make_segment(tk, train, "S0", "S1")
    assert seg.curvature(530.0) == pytest.approx(-0.5 / 800)
    back = make_segment(tk, train, "S1", "S0")  # the same clothoid met from the other end
    assert back.curvature(1500.0 - 545.0) == pytest.approx(seg.curvature(545.0))


def test_roeckl_curve_resistance_against_a_hand_calculation(tmp_path):
    """ms-eetc's curve resistance (Roeckl): 0.5 / (r - 30) of the weight for r >= 300 m,
    0.65 / (r - 55) below. By hand, 278 t on a 400 m curve: 278000 * 9.80665 * 0.5 / 370 = 3684 N;
    on a 250 m curve: 278000 * 9.80665 * 0.65 / 195 = 9087 N. The import makes TTOBench trains pay
    it; before, curves were read and cost nothing (the curve coefficient defaulted to 0)."""
    from ecostudy.core.grid import make_segment
    from ecostudy.core.kinematics import interval_grade_force
    from ecostudy.core.physics import roeckl_force
    assert float(roeckl_force(278000.0, 1 / 400)) == pytest.approx(278000 * 9.80665 * 0.5 / 370)
    assert float(roeckl_force(278000.0, -1 / 250)) == pytest.approx(278000 * 9.80665 * 0.65 / 195)
    doc = json.loads((DATA / "ttobench_track.json").read_text())
    doc["gradients"]["values"] = [[0.0, 0.0]]
    doc["curvatures"]["values"] = [[0.0, "infinity", "infinity"], [500.0, 400, 400], [900.0, "infinity", "infinity"]]
    (tmp_path / "curvy.json").write_text(json.dumps(doc))
    train = load_train(DATA / "ttobench_subway_train.json")
    assert train.curve_resistance == "roeckl"
    seg = make_segment(load_track(tmp_path / "curvy.json"), train, "S0", "S1")
    nodes = np.array([0.0, 500.0, 900.0, 1500.0])
    assert interval_grade_force(seg, train, nodes) == pytest.approx([0.0, 3684.3, 0.0], abs=0.5)


def test_tunnels_cost_the_trains_tunnel_coefficient(tmp_path):
    """TTOBench `tunnels` [position, length, cross section] and a train's `tunnel resistance`
    [cross section, coefficient kN/(km/h)^2]: inside the tunnel the quadratic resistance grows by
    the coefficient of that section; the optimum pays it and its re-simulation agrees."""
    from ecostudy.core.grid import make_segment
    doc = json.loads((DATA / "ttobench_track.json").read_text())
    doc["tunnels"] = {"units": {"position": "m", "length": "m", "cross section": "m^2"},
                      "values": [[600.0, 500.0, 24.0]]}
    (tmp_path / "tunnel.json").write_text(json.dumps(doc))
    tdoc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    tdoc["tunnel resistance"] = {"units": {"cross section": "m^2", "coefficient": "kN/(km/h)^2"},
                                 "values": [[24, 0.0011698], [40, 0.0005579]]}
    (tmp_path / "t.json").write_text(json.dumps(tdoc))
    train, track = load_train(tmp_path / "t.json"), load_track(tmp_path / "tunnel.json")
    seg = make_segment(track, train, "S0", "S1")
    assert seg.tunnel(700.0) == pytest.approx(0.0011698 * 1000 * 3.6**2)
    assert seg.tunnel(500.0) == 0.0 and seg.tunnel(1200.0) == 0.0
    assert train.tunnel_coefficient(32.0) == pytest.approx(0.5 * (0.0011698 + 0.0005579) * 1000 * 3.6**2)
    plain = solve_run(load_track(DATA / "ttobench_track.json"), train, "S0", "S1", Timing(running_time=110.0), points=300)
    tunnel = solve_run(track, train, "S0", "S1", Timing(running_time=110.0), points=300)
    assert tunnel.summary["verification"]["passed"]
    assert tunnel.summary["traction_energy_kWh"] > plain.summary["traction_energy_kWh"] * 1.01


def test_osrd_rolling_stock():
    with pytest.warns(EcostudyWarning, match="startup_acceleration, startup_time, loading_gauge: OSRD fields"):
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
    with pytest.raises(InputError, match="max speed: unknown unit .mph."):
        load_train(tmp_path / "t.json")
    with pytest.warns(EcostudyWarning, match="startup_acceleration, startup_time, loading_gauge: OSRD fields"):
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


def test_osrd_modes_table_end_and_comfort_acceleration(tmp_path):
    """OSRD semantics: a power mode chosen by `file.json#MODE` (the default mode otherwise), the
    train never faster than its effort table's last speed, `comfort_acceleration` bounds the
    acceleration, unmodelled fields named in a warning. Before, the default curve was extended
    beyond its last speed (an OSRD 140 km/h train ran at 185 km/h) and comfort_acceleration and
    startup_acceleration were ignored without a word."""
    doc = json.loads((DATA / "osrd_rolling_stock.json").read_text())
    slow = {"speeds": [0.0, 10.0, 20.0, 25.0], "max_efforts": [150000.0, 150000.0, 80000.0, 60000.0]}
    doc["effort_curves"]["modes"]["thermal"] = {"is_electric": False, "curves": [], "default_curve": slow}
    doc.update(comfort_acceleration=0.4, startup_acceleration=0.05, startup_time=20.0, loading_gauge="G1")
    path = tmp_path / "osrd.json"
    path.write_text(json.dumps(doc))
    with pytest.warns(UserWarning, match="startup_acceleration, startup_time, loading_gauge: OSRD fields"):
        electric = load_train(path)
    assert electric.max_speed == pytest.approx(38.88) and electric.max_acceleration == 0.4
    with pytest.warns(UserWarning) as caught:
        thermal = load_train(f"{path}#thermal")
    assert any("the curve ends at 90 km/h, below max_speed 140 km/h" in str(w.message) for w in caught)
    assert thermal.max_speed == pytest.approx(25.0)  # the table's last speed, not max_speed
    assert thermal.traction.force(np.array([5.0]))[0] == pytest.approx(150e3, rel=1e-3)
    from ecostudy.core.errors import InputError
    with pytest.raises(InputError, match=r"no mode 'diesel' \(modes: 1500V, thermal\)"), pytest.warns(UserWarning):
        load_train(f"{path}#diesel")
    from ecostudy.io.loaders import track_from_dict
    line = track_from_dict({"name": "fast line", "source": "test", "length_m": 4000,
                            "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 4000}],
                            "speed_limits": [{"position_m": 0, "speed_kmh": 200}]})
    r = solve_run(line, thermal, "A", "B", Timing(), objective="time", points=300)
    assert r.summary["verification"]["passed"] and max(r.trace.v) <= 25.0 + 0.05
    v, x = r.trajectory.v, r.nodes
    assert ((v[1:] ** 2 - v[:-1] ** 2) / (2 * np.diff(x))).max() <= 0.4 + 1e-5  # 150 kN / 170 t = 0.88 m/s^2


@pytest.mark.slow
def test_efficiency_maps_price_the_net_energy_and_its_check():
    """Efficiency over speed and force (a table, ms-eetc's load-dependent efficiency) instead of
    the constants: the net-energy objective and the re-simulation both use it. A map that is
    constant at the train's efficiencies reproduces the constant case; a map that is poor at low
    load costs more line energy, the same in the NLP and in the plant."""
    import yaml

    from ecostudy.core.physics import EfficiencyMap
    from ecostudy.io.loaders import train_from_dict
    from .conftest import TRAINS, TRACKS
    base = yaml.safe_load((TRAINS / "amsterdam_metro.yaml").read_text())
    track = load_track(TRACKS / "amsterdam_rokin_centraal.yaml")
    a, b = list(track.stops)[:2]
    eta_t, eta_r = base["traction_efficiency"], base["regenerative_braking"]["efficiency"]
    flat = {"speed_kmh": [0, 40, 80], "force_kN": [0, 100, 300]}
    same = {**base, "traction_efficiency_map": {**flat, "efficiency": [[eta_t] * 3] * 3},
            "regenerative_braking": {**base["regenerative_braking"],
                                     "efficiency_map": {**flat, "efficiency": [[eta_r] * 3] * 3}}}
    poor = {**base, "traction_efficiency_map": {**flat, "efficiency": [[0.5, 0.8, 0.9]] * 3}}
    runs = {}
    for name, doc in (("constant", base), ("same", same), ("poor", poor)):
        train = train_from_dict(doc)
        runs[name] = solve_run(track, train, a, b, Timing(running_time=80.0), objective="net_energy", points=300)
        s = runs[name].summary
        assert s["verification"]["passed"]
        assert s["verification"]["simulated_net_energy_kWh"] == pytest.approx(s["net_energy_kWh"], rel=0.01)
    assert isinstance(train_from_dict(poor).traction_efficiency_map, EfficiencyMap)
    assert runs["same"].summary["net_energy_kWh"] == pytest.approx(runs["constant"].summary["net_energy_kWh"], rel=2e-3)
    assert runs["poor"].summary["net_energy_kWh"] > runs["constant"].summary["net_energy_kWh"] * 1.02


def test_ttobench_units_are_read_not_assumed(tmp_path):
    """A TTOBench track whose speed limits are in m/s is converted (before: read as km/h), a unit
    ecostudy does not know is refused by name, and every train field's unit is honoured."""
    from ecostudy.core.errors import InputError
    doc = json.loads((DATA / "ttobench_track.json").read_text())
    doc["speed limits"] = {"units": {"position": "km", "velocity": "m/s"}, "values": [[0.0, 20.0], [1.0, 25.0]]}
    (tmp_path / "k.json").write_text(json.dumps(doc))
    track = load_track(tmp_path / "k.json")
    assert list(track.limits) == pytest.approx([20.0, 25.0]) and list(track.limit_positions) == [0.0, 1000.0]
    doc["speed limits"]["units"]["velocity"] = "mph"
    (tmp_path / "k.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"speed limits.values\[0\]: unknown unit 'mph' for a speed"):
        load_track(tmp_path / "k.json")
    train = json.loads((DATA / "ttobench_subway_train.json").read_text())
    train["mass"] = {"unit": "t", "value": 278}
    train["max traction force"] = {"unit": "N", "value": 310000}
    train["rolling resistance r2"] = {"unit": "N/(m/s)^2", "value": 28.89}
    (tmp_path / "t.json").write_text(json.dumps(train))
    t = load_train(tmp_path / "t.json")
    assert t.static_mass == pytest.approx(278000) and t.traction.peak == pytest.approx(310000)
    assert t.davis[2] == pytest.approx(28.89)


def test_etcs_service_brake_curve_as_the_braking_envelope(tmp_path):
    """`train.json#etcs`: a TTOBench train brakes on the service-brake deceleration curve of its
    `ETCS braking data` (times the effective mass) instead of its brake forces; without the
    selector the data is checked and reported as not modelled; incomplete data is refused."""
    from ecostudy.core.errors import InputError
    doc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    curve = {"units": {"velocity": "m/s", "deceleration": "m/s^2"}, "values": [[0, 0.55], [20, 0.5], [40, 0.45]]}
    doc["ETCS braking data"] = {"A_brake_emergency": curve, "A_brake_service": curve,
                                **{k: {"unit": "-", "value": 0.9} for k in ("K_dry_rst", "K_wet_rst")},
                                **{k: {"unit": "s", "value": 3} for k in ("T_traction", "T_be", "T_bs")},
                                "v_uncertainty": {"unit": "%", "value": 2.98}}
    path = tmp_path / "t.json"
    path.write_text(json.dumps(doc))
    with pytest.warns(UserWarning, match="ETCS braking data read and checked, not modelled"):
        plain = load_train(path)
    with pytest.warns(UserWarning, match="service-brake deceleration curve .A_brake_service. is the braking envelope"):
        etcs = load_train(f"{path}#etcs")
    assert plain.braking.force(10.0) == pytest.approx(260e3, rel=1e-3)  # the regenerative brake
    assert etcs.braking.force(10.0) == pytest.approx(etcs.mass * 0.525, rel=2e-3)
    r = solve_run(load_track(DATA / "ttobench_track.json"), etcs, "S0", "S1", Timing(), objective="time", points=300)
    vm = 0.5 * (r.trajectory.v[1:] + r.trajectory.v[:-1])
    assert np.all(r.trajectory.fb <= etcs.mass * np.interp(vm, [0, 20, 40], [0.55, 0.5, 0.45]) * 1.003)
    del doc["ETCS braking data"]["T_bs"]
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="ETCS braking data: missing T_bs"):
        load_train(path)
