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

from .conftest import DATA, STUDIES

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
    (lambda d: d["timing points"]["values"].__setitem__(3, [1300, 175, 185, 0, 0]),
     "timing points.values[3]: position 1300 m before the point above it"),
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
     "timing points.values[3]: at the position of timing points.values[2]: two timing points at one position are a "
     "stop's arrival and departure, both with speed bounds 0"),
    (lambda d: d["timing points"]["values"].insert(1, [0, 5, 10, 0, 0]),
     "timing points.values[1]: at the position of timing points.values[0]: two timing points at one position are an "
     "intermediate stop's arrival and departure, not the journey's ends"),
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
