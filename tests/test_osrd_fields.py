"""An OSRD rolling stock's problems named as the file names them (``effort_curves.modes.1500V.
default_curve.max_efforts[3]``, ``rolling_resistance.A``, ``gamma.value``), never by ecostudy's schema
(``traction.table.force_kN``, ``davis.a_N``, ``rotating_mass_factor``); every effort curve checked as
OSRD checks it (editoast ``editoast_schemas/src/rolling_stock/effort_curves.rs``, core
``RJSRollingStockParser.parseEffortCurve``): OSRD's own example of invalid effort curves
(``editoast/src/tests/example_rolling_stock_3.json``: 17 speeds, no efforts) refused as OSRD refuses it.
Edits of tests/data/osrd_rolling_stock.json; each refusal comes before any computing."""
import dataclasses
import json

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy import api
from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.core.grid import make_segment
from ecostudy.io.loaders import load_track, load_train

from .conftest import DATA, STUDIES, TRACKS, TRAINS
from .test_published_fields import edited

OSRD = json.loads((DATA / "osrd_rolling_stock.json").read_text())
CURVE = "effort_curves.modes.1500V.default_curve"
UNMODELLED = "startup_acceleration, startup_time, loading_gauge: OSRD fields ecostudy does not model"


def stock(tmp_path, change):
    return edited(tmp_path, change, OSRD, "stock.json")


def curve(doc):
    return doc["effort_curves"]["modes"]["1500V"]["default_curve"]


def plain_curve(doc):
    """The mode's curves get one for comfort STANDARD with no electrical condition: OSRD uses it,
    not the default curve."""
    doc["effort_curves"]["modes"]["1500V"]["curves"] = [
        {"cond": {"comfort": "STANDARD", "electrical_profile_level": None, "power_restriction_code": None},
         "curve": {"speeds": [0, 10, 20, 30, 40], "max_efforts": [2e5, 2e5, 1.1e5, 7.5e4, 5.6e4]}}]
    return doc["effort_curves"]["modes"]["1500V"]["curves"][0]["curve"]


def refused_line(tmp_path, path):
    """The one error line of ``ecostudy solve`` with this train (exit 2, no traceback)."""
    result = CliRunner().invoke(app, ["solve", "--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"),
                                      "--train", str(path), "--supplement", "10", "--no-plot",
                                      "--out", str(tmp_path / "o")])
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and len(lines) == 1 and "Traceback" not in result.output, result.output
    return lines[0]


@pytest.mark.parametrize("change, line", [
    # OSRD's example_rolling_stock_3.json: was "effort_curves.modes.25000V: speeds and max_efforts need equal lengths"
    (lambda d: curve(d).update({"max_efforts": []}),
     f"{CURVE}: effort curve invalid, max_efforts and speeds arrays should have the same length (6 speeds, "
     "0 max_efforts)"),
    # a curve ecostudy does not use: OSRD refuses the file all the same (it was read)
    (lambda d: d["effort_curves"]["modes"].update({"25000V": {"is_electric": True, "curves": [], "default_curve": {
        "speeds": [0, 10], "max_efforts": [1e5]}}}),
     "effort_curves.modes.25000V.default_curve: effort curve invalid, max_efforts and speeds arrays should have "
     "the same length (2 speeds, 1 max_efforts)"),
    (lambda d: curve(d).update({"speeds": [0], "max_efforts": [1e5]}),
     f"{CURVE}: effort curve should have at least 2 points."),
    # was "effort_curves.modes.1500V: forces must lie in [0, 100000] kN"
    (lambda d: curve(d)["max_efforts"].__setitem__(3, -5.0),
     f"{CURVE}.max_efforts[3]: max_efforts values must be equal or greater than 0., got -5"),
    (lambda d: plain_curve(d)["max_efforts"].__setitem__(3, -5.0),
     "effort_curves.modes.1500V.curves[0].curve.max_efforts[3]: max_efforts values must be equal or greater than "
     "0., got -5"),
    (lambda d: curve(d)["speeds"].__setitem__(0, -1.0),
     f"{CURVE}.speeds[0]: speeds values must be equal or greater than 0., got -1"),
    # was read as 10 m/s, no word (a curve with conditions), or "expected a curve with 'speeds' and 'max_efforts'"
    (lambda d: plain_curve(d)["speeds"].__setitem__(2, "20"),
     "effort_curves.modes.1500V.curves[0].curve.speeds[2]: expected a number, got '20'"),
    (lambda d: curve(d)["max_efforts"].__setitem__(1, None), f"{CURVE}.max_efforts[1]: expected a number, got None"),
    (lambda d: curve(d).pop("speeds"), f"{CURVE}.speeds: missing field"),
    (lambda d: curve(d)["max_efforts"].__setitem__(3, 1e12),
     f"{CURVE}.max_efforts: forces must lie in [0, 100000] kN"),
    # an integer too large for a float: was "internal error: OverflowError", exit 3
    (lambda d: curve(d)["max_efforts"].__setitem__(5, 10 ** 400),
     f"{CURVE}.max_efforts[5]: expected a number, got 1000"),
    (lambda d: d.update({"mass": 10 ** 400}), "mass: expected a positive number, got 1000"),
    # was "mass: expected a positive number, got None"
    (lambda d: d.pop("mass"), "mass: missing field"),
    # was "mass: Input should be less than or equal to 100000" (tonnes, of a mass in kg)
    (lambda d: d.update({"mass": 2e9}), "mass: expected 1000 to 1e+08 kg (1 to 100000 t), got 2e+09 kg"),
    # was "davis: a_N must be >= 0"
    (lambda d: d["rolling_resistance"].update({"A": -3.0}),
     "rolling_resistance.A: Input should be greater than or equal to 0"),
    # was "rotating_mass_factor: Input should be greater than or equal to 0"
    (lambda d: d.update({"inertia_coefficient": 0.5}), "inertia_coefficient: expected 1 to 2"),
    # was "gamma: value: expected a positive number, got -0.5"
    (lambda d: (d.pop("const_gamma"), d.update({"gamma": {"type": "CONST", "value": -0.5}})),
     "gamma.value: expected a positive number, got -0.5"),
    # was "max_deceleration_mps2: Input should be greater than or equal to 0.1"
    (lambda d: d.update({"const_gamma": 0.01}), "const_gamma: Input should be greater than or equal to 0.1"),
    # was "max_acceleration_mps2: Input should be less than or equal to 10"
    (lambda d: d.update({"comfort_acceleration": 50}),
     "comfort_acceleration: Input should be less than or equal to 10"),
])
def test_a_bad_osrd_field_is_named_as_the_file_names_it(tmp_path, change, line):
    path = stock(tmp_path, change)
    said = refused_line(tmp_path, path)
    assert said.startswith(f"error: {path}: {line}"), said


def test_a_step_is_named_by_its_index_in_the_file(tmp_path):
    """A point given twice at 5 m/s (read once), then a step at 10 m/s: the step's second point is
    speeds[4] in the file; the warning said speeds[3], the index after the repeated point was dropped."""
    path = stock(tmp_path, lambda d: curve(d).update({"speeds": [0, 5, 5, 10, 10, 20, 30, 40],
                                                      "max_efforts": [2e5, 2e5, 2e5, 2e5, 1.1e5, 1e5, 7.5e4, 5.6e4]}))
    with pytest.warns(EcostudyWarning) as seen:
        train = load_train(path)
    steps = [str(w.message) for w in seen if "a step of the effort" in str(w.message)]
    assert steps == [f"{path}: {CURVE}.speeds[4]: a step of the effort at 10 m/s (200 -> 110 kN), read as a change "
                     "over the 0.01 m/s below it"]
    assert list(train.traction.speeds) == [0, 5, 9.99, 10, 20, 30, 40]


def test_a_step_at_the_curves_first_speed_reads_its_second_effort_from_there(tmp_path):
    """Efforts 250 and 200 kN both at 0 m/s: the step's first point was moved 0.01 m/s below 0 and
    the file refused for `speeds must lie in [0, 1000] km/h`, a range its speeds keep. The second
    effort holds from 0 m/s (OSRD's interpolation gives the first at 0 m/s exactly), said in a warning."""
    path = stock(tmp_path, lambda d: curve(d).update({"speeds": [0, 0, 10, 20, 30, 40],
                                                      "max_efforts": [2.5e5, 2e5, 2e5, 1.1e5, 7.5e4, 5.6e4]}))
    with pytest.warns(EcostudyWarning) as seen:
        train = load_train(path)
    assert any(f"{CURVE}.speeds[1]: a step of the effort at 0 m/s (250 -> 200 kN) at the curve's first speed"
               in str(w.message) for w in seen), [str(w.message) for w in seen]
    assert list(train.traction.speeds) == [0, 10, 20, 30, 40] and train.traction.forces[0] == 2e5


def test_a_curve_of_no_effort_is_refused_naming_its_efforts(tmp_path):
    """Every effort 0 (nothing negative: OSRD reads it): the command went on to solve and blamed the
    track (`gradients: infeasible: the train cannot overcome its running resistance`), after 40
    numpy warnings. A table that gives no force at any speed is refused where the file gives it."""
    path = stock(tmp_path, lambda d: curve(d).update({"max_efforts": [0.0] * 6}))
    said = refused_line(tmp_path, path)
    assert said == f"error: {path}: {CURVE}.max_efforts: every force is 0 kN: a table that gives no force at any speed", said


def test_the_closed_loop_study_names_an_osrd_field_as_the_file_does(tmp_path):
    """``simulate`` read its train without the file's names: ``davis: a_N must be >= 0``,
    ``max_acceleration_mps2: ...``."""
    path = stock(tmp_path, lambda d: d["rolling_resistance"].update({"A": -3.0}))
    study = tmp_path / "loop.yaml"
    study.write_text(STUDY.format(track=TRACKS / "amsterdam_rokin_centraal.yaml", train=path))
    result = CliRunner().invoke(app, ["simulate", str(study), "--out", str(tmp_path / "o")])
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and lines == [f"error: {path}: rolling_resistance.A: Input should be greater than or "
                                               "equal to 0"], result.output


def test_the_heavyhaul_study_names_a_track_field_in_the_track_file(tmp_path):
    """``heavyhaul`` named the study (``study.yaml track: speed_limits[1].speed_kmh``), not the track file
    and its field (a TTOBench track's ``speed limits.values[1].velocity``)."""
    doc = json.loads((DATA / "ttobench_track.json").read_text())
    doc["speed limits"]["values"][1][1] = 0
    track = tmp_path / "track.json"
    track.write_text(json.dumps(doc))
    study = tmp_path / "hh.yaml"
    study.write_text((STUDIES / "heavyhaul_brake_penalty.yaml").read_text()
                     .replace("../trains/", f"{TRAINS}/").replace("../tracks/heavyhaul_representative_45km.yaml",
                                                                   str(track)))
    result = CliRunner().invoke(app, ["heavyhaul", str(study), "--out", str(tmp_path / "o")])
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and lines == [f"error: {track}: speed limits.values[1].velocity: Input should be "
                                               "greater than 0"], result.output


def test_the_library_names_an_osrd_field_as_the_file_does(tmp_path):
    path = stock(tmp_path, lambda d: d.update({"comfort_acceleration": 50}))
    with pytest.raises(InputError) as caught, pytest.warns(EcostudyWarning, match=UNMODELLED):
        api.load_train(path)
    assert str(caught.value) == f"{path}: comfort_acceleration: Input should be less than or equal to 10"


STUDY = """name: loop
track: {track}
train: {train}
window_s: [0, 120]
points: 100
sample_time_s: 0.5
controllers:
  - {{name: plan, kind: open_loop, settings: {{time: 1, energy: 1}}}}
draws: 1
"""


@pytest.mark.parametrize("key", ["comfort_acceleration", "inertia_coefficient", "length", "max_speed", "name",
                                 "railjson_version", "startup_time", "startup_acceleration", "loading_gauge"])
@pytest.mark.parametrize("how", ["absent", "null"])
def test_a_field_osrd_requires_is_refused_when_missing(tmp_path, key, how):
    """OSRD's parser (core RJSRollingStockParser.parse) refuses a file without any of these. ecostudy
    filled them in without a word: no acceleration bound (the commuter train's run 4.8x the energy,
    ok), an inertia coefficient of 1.0, a length of 0 m, the table's last speed, the file's path."""
    path = stock(tmp_path, lambda d: d.pop(key) if how == "absent" else d.update({key: None}))
    said = refused_line(tmp_path, path)
    assert said == f"error: {path}: {key}: missing field (OSRD's rolling-stock parser requires '{key}')", said


def test_every_missing_field_osrd_requires_is_listed(tmp_path):
    path = stock(tmp_path, lambda d: [d.pop(k) for k in ("comfort_acceleration", "length")])
    assert refused_line(tmp_path, path) == (f"error: {path}: length: missing field (OSRD's rolling-stock parser "
                                            "requires 'length', 'comfort_acceleration')")


@pytest.mark.parametrize("change, line", [
    # gamma was used and const_gamma dropped, no word (142.73 s against 152.91 s on the commuter train)
    (lambda d: d.update({"gamma": {"type": "CONST", "value": 0.5}}),
     "gamma, const_gamma: both given: one braking deceleration, gamma {type, value} (railjson 3.2) or const_gamma (3.3)"),
    (lambda d: d.pop("const_gamma"),
     "gamma: missing field: one braking deceleration, gamma {type, value} (railjson 3.2) or const_gamma (3.3)"),
    # was read as CONST
    (lambda d: (d.pop("const_gamma"), d.update({"gamma": {"value": 0.5}})), "gamma.type: missing field (CONST or MAX)"),
    # was read as no mode at all ("no mode None")
    (lambda d: d["effort_curves"].pop("default_mode"), "effort_curves.default_mode: missing field"),
    # a mode's key OSRD does not know: was ignored, no word (editoast: deny_unknown_fields)
    (lambda d: d["effort_curves"]["modes"]["1500V"].update({"electrical_profiles": {}}),
     "effort_curves.modes.1500V.electrical_profiles: unknown field `electrical_profiles`, expected one of `curves`, "
     "`default_curve`, `is_electric`"),
    (lambda d: d["effort_curves"]["modes"]["1500V"].pop("curves"), "effort_curves.modes.1500V.curves: missing field"),
    (lambda d: plain_curve(d) and d["effort_curves"]["modes"]["1500V"]["curves"][0]["cond"].update({"temperature": 20}),
     "effort_curves.modes.1500V.curves[0].cond.temperature: unknown field `temperature`, expected one of `comfort`, "
     "`electrical_profile_level`, `power_restriction_code`"),
    # was read as a condition that matches everything
    (lambda d: plain_curve(d) and d["effort_curves"]["modes"]["1500V"]["curves"][0].pop("cond"),
     "effort_curves.modes.1500V.curves[0].cond: missing field"),
    # was read as two steps 0.005 m/s apart: the middle effort held over 0.005 m/s, a reading of nothing
    (lambda d: curve(d).update({"speeds": [0, 10, 10, 10, 20, 30], "max_efforts": [2e5, 2e5, 1.5e5, 1.1e5, 7.5e4, 5.6e4]}),
     f"{CURVE}.speeds[3]: 10 m/s given a third time with another effort: one step per speed"),
])
def test_osrd_braking_modes_and_conditions_are_read_as_osrd_reads_them(tmp_path, change, line):
    path = stock(tmp_path, change)
    assert refused_line(tmp_path, path) == f"error: {path}: {line}"


def test_a_condition_without_comfort_matches_every_comfort_as_in_osrd(tmp_path):
    """OSRD (core RollingStock.EffortCurveConditions.match, first match wins): a null comfort matches
    any comfort. ecostudy skipped the curve and used the next one, STANDARD, without a word."""
    def two(d):
        plain_curve(d)["max_efforts"] = [2.2e5, 2.2e5, 1.1e5, 7.5e4, 5.6e4]
        d["effort_curves"]["modes"]["1500V"]["curves"].insert(0, {
            "cond": {"comfort": None, "electrical_profile_level": None, "power_restriction_code": None},
            "curve": {"speeds": [0, 10, 20, 30, 40], "max_efforts": [1e5, 1e5, 1e5, 7.5e4, 5.6e4]}})
    path = stock(tmp_path, two)
    with pytest.warns(EcostudyWarning, match=UNMODELLED):
        train = load_train(path)
    assert train.traction.forces[0] == 1e5  # the first curve, which OSRD uses (the second gives 220 kN)
    with pytest.warns(EcostudyWarning, match=UNMODELLED):
        cooled = load_train(f"{path}#1500V/AIR_CONDITIONING")
    assert cooled.traction.forces[0] == 1e5


def test_curves_and_tunnels_without_resistance_named_in_the_train_files_own_fields():
    """A curved track with a tunnel and a train that gives neither a resistance: the warning named
    the YAML's curve_coefficient_m2ps2 and tunnel_resistance, fields an OSRD file cannot carry (and
    a TTOBench file spells 'tunnel resistance')."""
    with pytest.warns(EcostudyWarning, match="OSRD fields ecostudy does not model"):
        osrd = load_train(DATA / "osrd_rolling_stock.json")
    tto = load_train(DATA / "ttobench_subway_train.json")
    track = dataclasses.replace(load_track(DATA / "ttobench_track.json"), name="curved, with a tunnel",
                                tunnels=((100.0, 200.0, 40.0),))
    first, last = list(track.stops)[0], list(track.stops)[-1]
    said = {}
    for train in (osrd, dataclasses.replace(tto, tunnel_resistance=())):
        with pytest.warns(EcostudyWarning) as caught:
            make_segment(track, train, first, last)
        said[train.name] = [str(w.message) for w in caught]
    lines = said[osrd.name]
    assert any(f"curves cost nothing: the train's file {DATA / 'osrd_rolling_stock.json'} gives curves no resistance: "
               "its rolling_resistance has no curve term" in line for line in lines), lines
    assert any("tunnels cost nothing: the train's file" in line and "its rolling_resistance has no tunnel term" in line
               for line in lines), lines
    assert not any("curve_coefficient_m2ps2" in line or "tunnel_resistance" in line for line in lines), lines
    assert any(line.endswith("tunnels cost nothing: the train gives no tunnel resistance")
               for line in said[tto.name]), said[tto.name]


@pytest.mark.parametrize("version, words", [
    ("4.0", "railjson_version: '4.0': major version 4, but this reader reads OSRD rolling stock of major version 3"),
    ("2.1", "railjson_version: '2.1': major version 2, but"),
    (3.3, "railjson_version: expected a string 'MAJOR.MINOR' such as '3.3', got 3.3"),
])
def test_a_railjson_major_version_not_read_is_refused(tmp_path, version, words):
    """OSRD's parser refuses a major version it does not read; ecostudy read any version as 3.x."""
    path = stock(tmp_path, lambda d: d.update(railjson_version=version))
    line = refused_line(tmp_path, path)
    assert line.startswith(f"error: {path}: {words}"), line


def test_a_railjson_minor_version_not_followed_is_read_with_a_warning_naming_it(tmp_path):
    path = stock(tmp_path, lambda d: d.update(railjson_version="3.4"))
    with pytest.warns(EcostudyWarning) as caught:
        train = load_train(path)
    said = [str(w.message) for w in caught]
    assert any(s.startswith(f"{path}: railjson_version: '3.4' is not a version this reader follows (3.2, 3.3): read "
                            "as railjson 3.x") for s in said), said
    assert train.mass == load_train_quietly(DATA / "osrd_rolling_stock.json").mass


def load_train_quietly(path):
    with pytest.warns(EcostudyWarning):
        return load_train(path)
