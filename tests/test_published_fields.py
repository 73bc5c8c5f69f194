"""Published files read as their authors meant them. A TTOBench train (``nuorail/ttobench``
utils/validate_trains.py and ms-eetc's train.py): the fields TTOBench requires are refused when
missing, never filled in; the checks ms-eetc makes refused as it refuses them; a field inside a field
that ecostudy does not read warned by name (edits of the published Beijing subway train, tests/data).
A TTOBench journey in seconds, along the line. An OSRD effort curve (tests/data): speeds that fall
refused, a step read as OSRD interpolates it."""
import json

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.io.loaders import load_timetable, load_track, load_train

from .conftest import DATA, STUDIES, TRACKS, TRAINS

TRAIN = json.loads((DATA / "ttobench_subway_train.json").read_text())


def edited(tmp_path, change, base=TRAIN, name="CN_Beijing_Subway.json"):
    """``base`` (a published document) changed by ``change``, written to ``tmp_path / name``."""
    doc = json.loads(json.dumps(base))
    change(doc)
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("edit, line", [
    # read as no electric brake at all: the net energy doubled (10.191 against 4.925 kWh on the FLIRT), status ok
    (lambda d: d.pop("max reg braking force"), "max reg braking force: missing field (TTOBench requires "
                                               "'max reg braking force')"),
    (lambda d: d.pop("max reg braking power"), "max reg braking power: missing field"),
    # read as 0: traction 7.961 against 9.172 kWh
    (lambda d: [d.pop("rolling resistance r1"), d.pop("rolling resistance r2")],
     "rolling resistance r1: missing field (TTOBench requires 'rolling resistance r1', 'rolling resistance r2')"),
    # read as 100 %: net -6.037 against -4.330 kWh (KISS)
    (lambda d: d.pop("efficiency reg brake"), "efficiency reg brake: missing: give both efficiencies or neither"),
    (lambda d: d.update({"max acceleration": {"unit": "m/s^2", "value": -1.0}}),
     "max acceleration: must be above 0, not -1 m/s^2"),
    (lambda d: d.update({"rho": {"unit": "-", "value": 0.99}}), "rho: the rotating-mass factor 1.99 is outside 1-1.5"),
    (lambda d: d.update({"max traction force": {"unit": "kN", "value": 0}}), "max traction force: must be above 0, not 0"),
    (lambda d: d.update({"rolling resistance r2": {"unit": "kN/(km/h)^2", "value": -0.002}}),
     "rolling resistance r2: must be 0 or more"),
    (lambda d: d.update({"max reg braking power": {"unit": "kW", "value": 0}}),
     "max reg braking power: 0 beside a regenerative force of 260 kN"),
])
def test_a_field_ttobench_requires_or_ms_eetc_refuses_is_one_line(tmp_path, edit, line):
    refused(load_train, edited(tmp_path, edit), line)


def refused(load, path, line):
    with pytest.raises(InputError) as caught:
        load(path)
    assert str(caught.value).startswith(f"{path}: {line}"), str(caught.value)


def test_the_command_refuses_it_before_solving(tmp_path):
    path = edited(tmp_path, lambda d: d.pop("max reg braking force"))
    result = CliRunner().invoke(app, ["solve", "--track", str(DATA / "ttobench_track.json"), "--train", str(path),
                                      "--supplement", "10", "-K", "50", "--no-plot", "--out", str(tmp_path / "o")])
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and len(errors) == 1 and "max reg braking force" in errors[0], result.output
    assert not (tmp_path / "o").exists()


def test_no_efficiencies_is_read_as_mechanical_energy_and_said(tmp_path):
    path = edited(tmp_path, lambda d: [d.pop("efficiency traction"), d.pop("efficiency reg brake")])
    with pytest.warns(EcostudyWarning, match="efficiency traction: no efficiencies given: traction and regenerative "
                                             "braking counted at 100 %"):
        train = load_train(path)
    assert train.traction_efficiency == 1.0 and train.regeneration_efficiency == 1.0


def test_a_field_inside_a_field_is_warned_by_name(tmp_path):
    path = edited(tmp_path, lambda d: d["max speed"].update({"comment": "line speed"}))
    with pytest.warns(EcostudyWarning, match=r"max speed\.comment: a 'max speed' field ecostudy does not model"):
        load_train(path)


def test_a_field_inside_etcs_braking_data_is_warned_by_name(tmp_path):
    """`T_extra` in `ETCS braking data` was ignored under a warning that said the block was "read and
    checked" (TTOBench's validator refuses it as redundant)."""
    curve = {"units": {"velocity": "m/s", "deceleration": "m/s^2"}, "values": [[0, 0.55], [20, 0.5], [40, 0.45]]}
    path = edited(tmp_path, lambda d: d.update({"ETCS braking data": {
        "A_brake_emergency": curve, "A_brake_service": curve, **{k: {"unit": "-", "value": 0.9} for k in ("K_dry_rst",
                                                                                                          "K_wet_rst")},
        **{k: {"unit": "s", "value": 3} for k in ("T_traction", "T_be", "T_bs", "T_extra")},
        "v_uncertainty": {"unit": "%", "value": 2.98}}}))
    with pytest.warns(EcostudyWarning) as seen:
        load_train(path)
    assert f"{path}: ETCS braking data.T_extra: a 'ETCS braking data' field ecostudy does not model: ignored" in [
        str(w.message) for w in seen]


def test_a_tunnel_coefficient_in_kg_per_m_is_newtons_per_speed_squared(tmp_path):
    """TTOBench's validator allows kg/m for the tunnel coefficient (N/(m/s)^2 = kg/m)."""
    rows = [[10.0, 6.5], [40.0, 3.2]]
    trains = [load_train(edited(tmp_path, lambda d, u=u: d.update(
        {"tunnel resistance": {"units": {"cross section": "m^2", "coefficient": u}, "values": rows}})))
        for u in ("kg/m", "N/(m/s)^2")]
    assert trains[0].tunnel_resistance == trains[1].tunnel_resistance and trains[0].tunnel_resistance


JOURNEY = STUDIES / "timetables" / "metro_line_4stops_Journey_01.json"


def journey(tmp_path, change):
    doc = json.loads(JOURNEY.read_text())
    change(doc)
    path = tmp_path / "metro_line_4stops_Journey_01.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("edit, line", [
    # minutes read as seconds: a window 60 times too early, or the file taken as seconds
    (lambda d: d["timing points"]["units"].update({"upper time constraint": "min"}),
     "timing points.units.upper time constraint: expected s, got 'min'"),
    # read as a window the train must leave 520 s early
    (lambda d: d["timing points"]["values"].__setitem__(4, [1300, 175, 185, 0, 0]),
     "timing points.values[4]: position 1300 m before the point above it"),
    # read as m, s and km/h without a word: a journey in km gave "the train would crawl" (TTOBench requires all five)
    (lambda d: d["timing points"].pop("units"),
     "timing points.units: missing field (TTOBench requires the unit of each column: 'position', 'lower time "
     "constraint', 'upper time constraint', 'lower speed constraint', 'upper speed constraint')"),
    (lambda d: [d["timing points"]["units"].pop(k) for k in ("position", "upper speed constraint")],
     "timing points.units.position: missing field (TTOBench requires 'position', 'upper speed constraint')"),
    # the middle stop of three at 650 m dropped, its window gone, no word (TTOBench's validator refuses it)
    (lambda d: d["timing points"]["values"].__setitem__(slice(2, 2), [[650, 70, 80, 0, 0], [650, 90, 95, 0, 0]]),
     "timing points.values[3]: at the position of timing points.values[2]: a third timing point at one position "
     "(one arrival and one departure per stop)"),
    # two passing points at 1400 m: both kept as windows of one place (TTOBench's validator refuses it)
    (lambda d: d["timing points"]["values"].insert(3, [1400, 125, 140, None, 50]),
     "timing points.values[4]: at the position of timing points.values[3]: two timing points at one position are a "
     "stop's arrival and departure, both with speed bounds 0"),
    (lambda d: d["timing points"]["values"].insert(1, [0, 5, 10, 0, 0]),
     "timing points.values[1]: at the position of timing points.values[0]: two timing points at one position are an "
     "intermediate stop's arrival and departure, not the journey's ends"),
    # Station's arrival without its departure point: read as a stop with --dwell (TTOBench's validator refuses it)
    (lambda d: d["timing points"]["values"].pop(2),
     "timing points.values[1]: an intermediate stopping point (both speed constraints 0) with no second at its "
     "position: an intermediate stop is an arrival and a departure point at one position"),
])
def test_a_journey_is_read_in_seconds_along_the_line(tmp_path, edit, line):
    refused(load_timetable, journey(tmp_path, edit), line)


def test_a_journey_field_ecostudy_does_not_read_is_warned(tmp_path):
    path = journey(tmp_path, lambda d: d.update({"comment": "x"}) or d["timing points"].update({"extra": 1}))
    with pytest.warns(EcostudyWarning) as seen:
        load_timetable(path)
    said = [str(w.message) for w in seen]
    assert f"{path}: comment: a journey field ecostudy does not model: ignored" in said
    assert f"{path}: timing points.extra: a 'timing points' field ecostudy does not model: ignored" in said


OSRD = json.loads((DATA / "osrd_rolling_stock.json").read_text())
UNMODELLED = "startup_acceleration, startup_time, loading_gauge: OSRD fields ecostudy does not model"


def osrd(tmp_path, speeds, efforts_kN):
    doc = json.loads(json.dumps(OSRD))
    mode = doc["effort_curves"]["default_mode"]
    curve = doc["effort_curves"]["modes"][mode]["default_curve"]
    doc["effort_curves"]["modes"][mode]["curves"] = []
    curve.update({"speeds": speeds, "max_efforts": [f * 1e3 for f in efforts_kN]})
    path = tmp_path / "stock.json"
    path.write_text(json.dumps(doc))
    return path, mode


def test_an_osrd_curve_whose_speeds_fall_is_refused(tmp_path):
    """[0, 20, 10, 30, 40] m/s loaded as [0, 20, 30, 40], the point at 10 m/s dropped, no word."""
    path, mode = osrd(tmp_path, [0, 20, 10, 30, 40], [200, 100, 150, 75, 56])
    with pytest.raises(InputError, match=rf"effort_curves\.modes\.{mode}\.default_curve\.speeds\[2\]: 10 m/s after 20: "
                                         "the speeds must increase"), pytest.warns(EcostudyWarning, match=UNMODELLED):
        load_train(path)


def test_an_osrd_step_is_read_as_osrd_interpolates_it(tmp_path):
    """A step at 10 m/s (200 kN below, 110 kN from it on): the 110 kN point was dropped, so 15 m/s
    allowed 150 kN where OSRD's getMaxEffort gives 105 kN. Now the step is there, and said."""
    path, mode = osrd(tmp_path, [0, 10, 10, 20, 30, 40], [200, 200, 110, 100, 75, 56])
    with pytest.warns(EcostudyWarning) as seen:
        train = load_train(path)
    said = [str(w.message).partition(": ")[2] for w in seen]
    assert said == [f"{UNMODELLED}: ignored", f"effort_curves.modes.{mode}.default_curve.speeds[2]: a step of the effort "
                    "at 10 m/s (200 -> 110 kN), read as a change over the 0.01 m/s below it"], said
    force = dict(zip(train.traction.speeds, train.traction.forces))
    assert force[10.0] == 110e3 and force[9.99] == 200e3 and force[20.0] == 100e3


def test_a_ttobench_tracks_bad_row_is_named_as_the_file_names_it(tmp_path):
    """A speed limit of 0 was 'speed_limits[1].speed_kmh', a name of ecostudy's schema, not the file's."""
    doc = json.loads((DATA / "ttobench_track.json").read_text())
    doc["speed limits"]["values"][1][1] = 0
    path = tmp_path / "track.json"
    path.write_text(json.dumps(doc))
    refused(load_track, path, "speed limits.values[1].velocity: Input should be greater than 0")


def test_a_journeys_passing_point_no_run_keeps_is_named_by_its_row(tmp_path):
    """It was `timing points.values, timing points.values[0]` (the HEAD St. Gallen-Wil journey:
    `timing points.values, timing points.values[5]` for its point values[4]): every passing point shared one name."""
    path = journey(tmp_path, lambda d: d["timing points"]["values"].__setitem__(3, [1400, 20, 30, None, 40]))
    result = CliRunner().invoke(app, ["journey", "--timetable", str(path), "--track", str(TRACKS / "metro_line_4stops.yaml"),
                                      "--train", str(TRAINS / "amsterdam_metro.yaml"), "-K", "50", "--no-plot",
                                      "--out", str(tmp_path / "o")])
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and lines == [
        f"error: {path}: timing points.values[0], timing points.values[3]: infeasible: the departure from Noord (not "
        "before 0 s) and the timing point at 1400 m (not after 30 s) leave 30 s; the fastest run between them takes 98 s"]


TRACK = json.loads((DATA / "ttobench_track.json").read_text())
TUNNELS = {"units": {"position": "m", "length": "m", "cross section": "m^2"}, "values": [[800, 500, 40], [100, 200, 40]]}
TUNNEL_COEFFICIENTS = {"units": {"cross section": "m^2", "coefficient": "kN/(km/h)^2"}}


@pytest.mark.parametrize("load, base, edit, line", [
    # was "mass: Input should be greater than or equal to 1" (the schema's tonnes, no unit)
    (load_train, TRAIN, lambda d: d.update({"mass": {"unit": "kg", "value": 122}}),
     "mass: expected 1000 to 1e+08 kg (1 to 100000 t), got 122 kg"),
    # was "(top level): tunnel_resistance cross sections must be strictly increasing"
    (load_train, TRAIN, lambda d: d.update({"tunnel resistance": {**TUNNEL_COEFFICIENTS, "values": [[40, 1e-3], [10, 2e-3]]}}),
     "tunnel resistance.values[1].cross section: 10 m^2 does not follow tunnel resistance.values[0]'s 40 m^2"),
    # was "tunnel_resistance[0].c_kN_per_kmh2: ..."
    (load_train, TRAIN, lambda d: d.update({"tunnel resistance": {**TUNNEL_COEFFICIENTS, "values": [[10, -1e-3]]}}),
     "tunnel resistance.values[0].coefficient: Input should be greater than or equal to 0"),
    # was "(top level): tunnels[1] starts inside tunnels[0]"
    (load_track, TRACK, lambda d: d.update({"tunnels": TUNNELS}),
     "tunnels.values[1].position: 100 m is before tunnels.values[0] (800 to 1300 m)"),
    # was "... does not follow speed_limits[1]'s 1450 m"
    (load_track, TRACK, lambda d: d["speed limits"].update({"values": [[0, 60], [1450, 80], [1440, 60]]}),
     "speed limits.values[2].position: 1440 m does not follow speed limits.values[1]'s 1450 m"),
    # was "gradients: the first entry must start at position_m 0"
    (load_track, TRACK, lambda d: d["gradients"]["values"][0].__setitem__(0, 10),
     "gradients.values[0].position: the first entry must start at 0 m, not at 10 m"),
])
def test_a_ttobench_refusal_names_the_files_field_and_unit(tmp_path, load, base, edit, line):
    refused(load, edited(tmp_path, edit, base, "file.json"), line)
