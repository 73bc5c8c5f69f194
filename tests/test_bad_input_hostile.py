"""A hostile or careless user's copies of the shipped files, through the command line: each is
refused in one line naming the file, the field and what is wrong (exit status 2, no traceback,
no output folder), where it once was an internal error, a line naming no field or the wrong
one, or a run computed on a value that makes no physical sense."""
import os

import pytest

from .conftest import DATA, TRACKS, TRAINS
from .test_bad_input_studies import refused, run

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"


def solve(tmp_path, train=METRO, track=AMS, *options):
    return run("solve", "--track", track, "--train", train, "--time", 80, "--points", 50, "--no-plot",
               "--out", tmp_path / "o", *options)


def edited(tmp_path, source, old, new, name="t.yaml"):
    text = source.read_text()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


BRAKE_TABLE = "braking:\n  table:\n    speed_kmh: [0, 60, 80, 90]\n    force_kN: [171, 171, 150, 140]"


@pytest.mark.parametrize("old, new, fragments", [
    # an effective mass of 1e308 t overflowed to inf: "cannot overcome its running resistance", no file, no field
    ("effective_mass_t: 142.403", "effective_mass_t: 1.0e+308", ["t.yaml: effective_mass_t", "twice"]),
    ("effective_mass_t: 142.403", "effective_mass_t: 1.0e+9", ["t.yaml: effective_mass_t", "262.806 t"]),
    ("effective_mass_t: 142.403", "rotating_mass_factor: 1.06", ["t.yaml: rotating_mass_factor", "1"]),
    # lambda_t of 1e308: NaN in the NLP, exit 3 (internal error)
    ("curve_coefficient_m2ps2: 6.0", "curve_coefficient_m2ps2: 1.0e+308", ["t.yaml: curve_coefficient_m2ps2", "100"]),
    # a braking deceleration of 1e308 m/s^2 was solved and flagged (the stop 100 m off)
    (BRAKE_TABLE, "braking:\n  max_deceleration_mps2: 1.0e+308", ["t.yaml: braking.max_deceleration_mps2", "10"]),
    ("curve_coefficient_m2ps2: 6.0", "curve_coefficient_m2ps2: 6.0\nmax_deceleration_mps2: 12",
     ["t.yaml: max_deceleration_mps2", "10"]),
    # an empty list of handle levels: Python's "min() arg is an empty sequence"
    ("curve_coefficient_m2ps2: 6.0", "curve_coefficient_m2ps2: 6.0\ndas_handle_levels: []",
     ["t.yaml: das_handle_levels", "need a braking level"]),
])
def test_a_train_field_without_physical_sense_is_named(tmp_path, old, new, fragments):
    refused(solve(tmp_path, train=edited(tmp_path, METRO, old, new)), *fragments)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("old, new, fragments", [
    # positions out of order were reported at "(top level)"
    ("{name: Centraal, position_m: 1106}", "{name: Centraal, position_m: 0}",
     ["k.yaml: stops[1].position_m", "0 m does not follow stops[0]'s 0 m"]),
    ("{position_m: 380, gradient_permille: 3}", "{position_m: 80, gradient_permille: 3}",
     ["k.yaml: gradients[2].position_m", "80 m does not follow gradients[1]'s 80 m"]),
    ("{position_m: 950, speed_kmh: 60}", "{position_m: 100, speed_kmh: 60}",
     ["k.yaml: speed_limits[2].position_m", "strictly increasing"]),
])
def test_track_positions_out_of_order_name_the_entry(tmp_path, old, new, fragments):
    line = refused(solve(tmp_path, track=edited(tmp_path, AMS, old, new, "k.yaml")), *fragments)
    assert "(top level)" not in line


def test_a_link_that_leads_nowhere_and_a_device_are_named(tmp_path):
    os.symlink(tmp_path / "b.yaml", tmp_path / "a.yaml")
    os.symlink(tmp_path / "a.yaml", tmp_path / "b.yaml")
    refused(solve(tmp_path, train=tmp_path / "a.yaml"), "a.yaml: a symbolic link that leads nowhere")
    refused(solve(tmp_path, track="/dev/null"), "/dev/null: not a regular file")


def test_a_byte_order_mark_before_json_is_read(tmp_path):
    """Windows editors write a byte order mark; json refused it ("Unexpected UTF-8 BOM")."""
    from ecostudy.io.loaders import load_track, load_train
    for name in ("ttobench_track.json", "ttobench_subway_train.json"):
        (tmp_path / name).write_bytes(b"\xef\xbb\xbf" + (DATA / name).read_bytes())
    assert repr(load_track(tmp_path / "ttobench_track.json")) == repr(load_track(DATA / "ttobench_track.json"))
    assert repr(load_train(tmp_path / "ttobench_subway_train.json")) == repr(load_train(DATA / "ttobench_subway_train.json"))


@pytest.mark.parametrize("options, fragments", [
    # 1e308 s ended in "Ipopt failed (restoration_failed)", exit 3; 1e6 s was solved and flagged (1102 m short)
    (["--time", "1e308"], ["command line: --time", "would crawl"]),
    (["--time", "1e6"], ["command line: --time", "1e+06 s is over 5 times"]),
    (["--window", "70,1e308"], ["command line: --window", "would crawl"]),
    (["--supplement", "1e308"], ["command line: --supplement", "at most 200"]),
])
def test_a_running_time_the_train_would_crawl_is_refused_before_solving(tmp_path, options, fragments):
    refused(run("solve", "--track", AMS, "--train", METRO, "--points", 50, "--no-plot", "--out", tmp_path / "o",
                *options), *fragments)
    assert not (tmp_path / "o" / "summary.json").exists()


def test_a_study_running_time_the_train_would_crawl_names_the_field(tmp_path):
    from .conftest import load_yaml, write_yaml
    doc = load_yaml(TRAINS.parent / "studies" / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=50, running_time_s=1e308, output=str(tmp_path / "o"))
    refused(run("solve", write_yaml(tmp_path / "s.yaml", doc), "--no-plot"), "s.yaml: running_time_s", "would crawl")
    doc.pop("running_time_s")
    doc["supplement_percent"] = 1e6
    refused(run("solve", write_yaml(tmp_path / "s.yaml", doc), "--no-plot"), "s.yaml: supplement_percent",
            "less than or equal to 200")


@pytest.mark.parametrize("changes, fragments", [
    # two timings were reported at "(top level)"
    ({"timetable": "../timetables/any.yaml"}, ["s.yaml: timetable: running_time_s given too"]),
    ({"supplement_percent": 10}, ["s.yaml: supplement_percent: running_time_s given too"]),
    # an empty file name was "a folder, not a file" (the study's own folder)
    ({"track": ""}, ["s.yaml: track: an empty file name"]),
    ({"train": " "}, ["s.yaml: train: an empty file name"]),
])
def test_a_study_field_is_named_not_the_top_level(tmp_path, changes, fragments):
    from .conftest import load_yaml, write_yaml
    doc = load_yaml(TRAINS.parent / "studies" / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=50, output=str(tmp_path / "o"))
    doc.update(changes)
    line = refused(run("solve", write_yaml(tmp_path / "s.yaml", doc), "--no-plot"), *fragments)
    assert "(top level)" not in line and "a folder" not in line


TIMETABLE = TRAINS.parent / "studies" / "timetables" / "metro_line.yaml"
LINE4 = TRACKS / "metro_line_4stops.yaml"


def journey(*options):
    return run("journey", "--track", LINE4, "--train", METRO, "--points", 50, "--no-plot", *options)


@pytest.mark.parametrize("old, new, fragments", [
    # an arrival at 1e308 s: "Var 'T' created with an invalid non-finite lower bound", exit 3
    ("arrival_s: 276", "arrival_s: 1.0e+308", ["tt.yaml: stops[3].arrival_s", "less than or equal to 604800"]),
    # leaving a stop before arriving there was solved and flagged
    ("{stop: Station, arrival_s: 58, dwell_s: 25}", "{stop: Station, arrival_s: 58, departure_s: 40}",
     ["tt.yaml: stops[1]: departure_s: 40 s is before this stop's arrival_s (58 s)"]),
    # stops out of track order made a journey that turns back twice (refused only as too fast)
    ("{stop: Station, arrival_s: 58, dwell_s: 25}\n  - {stop: Centrum, arrival_s: 181",
     "{stop: Centrum, arrival_s: 58, dwell_s: 25}\n  - {stop: Station, arrival_s: 181",
     ["tt.yaml: stops: 'Station' lies back toward 'Noord' after 'Centrum'"]),
])
def test_a_timetable_that_no_train_can_run_is_named(tmp_path, old, new, fragments):
    refused(journey("--timetable", edited(tmp_path, TIMETABLE, old, new, "tt.yaml"), "--out", tmp_path / "o"),
            *fragments)
    assert not (tmp_path / "o").exists()


def test_a_timetable_without_stops_names_the_field(tmp_path):
    """It was reported at "(top level)"."""
    path = tmp_path / "tt.yaml"
    path.write_text("name: empty\nstops: []\n")
    refused(journey("--timetable", path, "--out", tmp_path / "o"), "tt.yaml: stops: give either")


def test_stops_that_turn_back_are_refused(tmp_path):
    refused(journey("--stops", "Noord,Centrum,Station", "--supplement", 10, "--out", tmp_path / "o"),
            "command line: --stops", "'Station' lies back toward 'Noord' after 'Centrum'")
    assert journey("--stops", "Zuid,Centrum,Noord", "--supplement", 10, "--out", tmp_path / "p").exit_code in (0, 1)


@pytest.mark.parametrize("options, fragments", [
    # a total of 1e308 s: "Var 'T' created with an invalid non-finite lower bound", exit 3
    (["--time", "1e308"], ["would crawl"]),
    (["--supplement", "10", "--dwell", "1e308"], ["command line: --dwell", "at most 86400"]),
])
def test_a_journey_time_without_physical_sense_is_refused(tmp_path, options, fragments):
    refused(journey(*options, "--out", tmp_path / "o"), *fragments)
    assert not (tmp_path / "o" / "journey.csv").exists()


@pytest.mark.parametrize("changes, fragments", [
    # a 1 uV substation was simulated and flagged (38.9 kWh not served); 1e308 Ohm ran on past 40 s
    ({"substation": {"position_m": 1500, "voltage_V": 1e-6}}, ["n.yaml: substation.voltage_V", "100"]),
    ({"substation": {"position_m": 1500, "internal_resistance_ohm": 1e308}},
     ["n.yaml: substation.internal_resistance_ohm", "10"]),
    # no line resistance: the floating bus's bisection ended at max_voltage_V unbalanced, 6.3 kWh of
    # regeneration "used" by no train, a 65 % balance error, status ok; a cut-off at 1e12 V the same
    ({"substation": {"position_m": 1500, "line_resistance_ohm_per_km": 0}},
     ["n.yaml: substation.line_resistance_ohm_per_km", "greater than 0"]),
    ({"substation": {"position_m": 1500, "max_voltage_V": 1e12}},
     ["n.yaml: substation", "max_voltage_V: 1e+12 V is over 1.5 times voltage_V (750 V)"]),
    # stops out of track order: a network of trains turning back
    ({"stops": ["Noord", "Centrum", "Station"]}, ["n.yaml: stops", "'Station' lies back toward 'Noord'"]),
])
def test_a_network_study_without_physical_sense_is_named(tmp_path, changes, fragments):
    from .conftest import STUDIES, load_yaml, write_yaml
    doc = load_yaml(STUDIES / "network_metro_2trains.yaml")
    doc.update(track=str(LINE4), train=str(METRO), output=str(tmp_path / "o"), strategies=["independent"], points=50)
    doc.update(changes)
    refused(run("network", write_yaml(tmp_path / "n.yaml", doc), "--no-plot", "--workers", 1), *fragments)
    assert not (tmp_path / "o").exists()


def test_a_closed_loop_window_without_end_is_named(tmp_path):
    """window_s [0, 1e308]: "OverflowError: cannot convert float infinity to integer", exit 3."""
    from .conftest import STUDIES, load_yaml, write_yaml
    doc = load_yaml(STUDIES / "metro_monte_carlo.yaml")
    doc.update(track=str(AMS), train=str(METRO), output=str(tmp_path / "o"), draws=1, window_s=[0, 1e308],
               controllers=[{"name": "convex", "kind": "convex"}])
    refused(run("simulate", write_yaml(tmp_path / "m.yaml", doc), "--no-plot", "--workers", 1, "--no-progress"),
            "m.yaml: window_s[1]", "less than or equal to 86400")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("edit, fragment", [
    # these were reported at "(top level)"
    (lambda c: c["vehicles"].append({"type": "caboose", "count": 1}), "c.yaml: vehicles: unknown types caboose"),
    (lambda c: c.update(vehicles=[{"type": "locomotive", "count": 1}]), "c.yaml: vehicles: a consist needs at least two"),
    (lambda c: c.update(vehicles=[{"type": "wagon", "count": 3}]), "c.yaml: vehicles: a consist needs a locomotive"),
])
def test_a_consist_names_its_vehicles_field(tmp_path, edit, fragment):
    from .conftest import STUDIES, load_yaml, write_yaml
    doc = load_yaml(STUDIES / "heavyhaul_fence.yaml")
    consist = load_yaml((STUDIES / doc["consist"]).resolve())
    edit(consist)
    doc.update(consist=str(write_yaml(tmp_path / "c.yaml", consist)), track=str((STUDIES / doc["track"]).resolve()),
               output=str(tmp_path / "o"))
    refused(run("heavyhaul", write_yaml(tmp_path / "h.yaml", doc), "--no-plot", "--workers", 1, "--no-progress"),
            fragment)


@pytest.mark.parametrize("old, new, fragment", [
    # these were reported at "(top level)"
    ("effective_mass_t: 142.403", "effective_mass_t: 142.403\nrotating_mass_factor: 0.05",
     "t.yaml: effective_mass_t: give either"),
    ("effective_mass_t: 142.403\n", "", "t.yaml: rotating_mass_factor: give either"),
    ("curve_coefficient_m2ps2: 6.0", "curve_coefficient_m2ps2: 6.0\ncurve_resistance: roeckl",
     "t.yaml: curve_coefficient_m2ps2: goes with"),
])
def test_a_train_check_across_fields_names_its_field(tmp_path, old, new, fragment):
    assert "(top level)" not in refused(solve(tmp_path, train=edited(tmp_path, METRO, old, new)), fragment)


@pytest.mark.parametrize("changes, fragment", [
    ({"train": None}, "s.yaml: train: give 'track' and 'train'"),
    ({"running_time_s": None, "window_s": [80, 70]}, "s.yaml: window_s: must be [earliest, latest]"),
])
def test_a_study_check_across_fields_names_its_field(tmp_path, changes, fragment):
    from .conftest import load_yaml, write_yaml
    doc = load_yaml(TRAINS.parent / "studies" / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=50, output=str(tmp_path / "o"))
    doc.update(changes)
    doc = {k: v for k, v in doc.items() if v is not None}
    assert "(top level)" not in refused(run("solve", write_yaml(tmp_path / "s.yaml", doc), "--no-plot"), fragment)


def test_a_network_leg_that_would_crawl_names_its_segment(tmp_path):
    """running_times_s [60, 1e308, 100]: "OverflowError: cannot convert float infinity to integer", exit 3."""
    from .conftest import STUDIES, load_yaml, write_yaml
    doc = load_yaml(STUDIES / "network_metro_2trains.yaml")
    doc.pop("supplement_percent")
    doc.update(track=str(LINE4), train=str(METRO), output=str(tmp_path / "o"), strategies=["independent"], points=50,
               running_times_s=[60, 1e308, 100])
    refused(run("network", write_yaml(tmp_path / "n.yaml", doc), "--no-plot", "--workers", 1),
            "n.yaml: running_times_s[1]", "would crawl")
    assert not (tmp_path / "o").exists()
