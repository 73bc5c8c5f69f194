"""Timetables read as written by `journey`, `compare` and `pareto`: `--dwell` at the stops of a
fixed-times timetable that give none (it was added to the running times), a first stop's dwell
in a timetable with windows (the train left at once), a departure that contradicts the dwell, a
speed window above what the train reaches (an internal error), a crawl refused by `compare`
as `solve` refuses it (real loads and solves)."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.api.fronts import associated_track
from ecostudy.cli import app
from ecostudy.core.errors import InputError
from ecostudy.io.loaders import load_timetable, load_track
from ecostudy.io.timetable import journey_plan, name_stops, segment_timing

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml

LINE, METRO = TRACKS / "metro_line_4stops.yaml", TRAINS / "amsterdam_metro.yaml"
FIXED = {"name": "no dwells", "stops": [{"stop": "Noord", "departure_s": 0}, {"stop": "Station", "arrival_s": 58},
                                        {"stop": "Centrum", "arrival_s": 181}, {"stop": "Zuid", "arrival_s": 276}]}


def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def named(path):
    return name_stops(load_timetable(path), load_track(LINE), path)[0]


def test_dwell_applies_at_the_stops_of_a_fixed_timetable_that_give_none(tmp_path):
    """25 s of --dwell were counted as running time: Station-Centrum 123 s instead of 98 s."""
    path = write_yaml(tmp_path / "tt.yaml", FIXED)
    assert segment_timing(named(path), "Station", "Centrum", path, dwell=25)[0].running_time == 98
    assert segment_timing(named(path), "Noord", "Station", path, dwell=25)[0].running_time == 58  # not at the first
    result = run("journey", "--track", LINE, "--train", METRO, "--timetable", path, "--dwell", 25, "-K", 50,
                 "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    table = pd.read_csv(tmp_path / "o" / "journey.csv")
    timetabled = table[table["distribution"] == "as timetabled"]["running_time_s"].round(6).tolist()
    assert timetabled == [58.0, 98.0, 70.0], timetabled
    unused = run("journey", "--track", LINE, "--train", METRO, "--supplement", 10, "--dwell", 25, "-K", 50, "--no-plot",
                 "--out", tmp_path / "u")
    assert "warning: command line: --dwell: applies at the stops of a --timetable that give no dwell" in unused.output


def test_a_first_stops_dwell_delays_the_departure_with_windows(tmp_path):
    doc = {"name": "w", "stops": [{"stop": "Noord", "arrival_s": 0, "dwell_s": 30},
                                  {"stop": "Station", "earliest_s": 80, "latest_s": 100},
                                  {"stop": "Zuid", "earliest_s": 300, "latest_s": 400}]}
    path = write_yaml(tmp_path / "w.yaml", doc)
    assert journey_plan(named(path), load_track(LINE), path).departure[0] == (30.0, 30.0)


def test_a_departure_before_the_dwell_is_refused(tmp_path):
    doc = {**FIXED, "stops": [FIXED["stops"][0], {"stop": "Station", "arrival_s": 58, "departure_s": 70, "dwell_s": 25},
                              *FIXED["stops"][2:]]}
    with pytest.raises(InputError, match=r"stops\[1\]: departure_s: 70 s leaves 12 s after arrival_s \(58 s\), "
                                         r"less than dwell_s \(25 s\)"):
        load_timetable(write_yaml(tmp_path / "tt.yaml", doc))


def test_a_speed_window_the_train_cannot_reach_is_one_line(tmp_path):
    """A passing point at 70 km/h on a 60 km/h stretch: `internal error: RuntimeError: Some variables
    have lower bounds that are greater than the upper bounds`, exit 3."""
    doc = {"name": "w", "stops": [{"stop": "Noord", "departure_s": 0}, {"stop": "Station", "earliest_s": 55, "latest_s": 70},
                                  {"stop": "Centrum", "earliest_s": 150, "latest_s": 200}],
           "windows": [{"position_m": 1400, "min_speed_kmh": 70}]}
    path = write_yaml(tmp_path / "w.yaml", doc)
    result = run("journey", "--track", LINE, "--train", METRO, "--timetable", path, "-K", 50, "--no-plot",
                 "--out", tmp_path / "o")
    assert result.exit_code == 2, result.output
    assert f"{path}: windows: infeasible: at 750 m from Station the train reaches at most 60.0 km/h" in result.output


def test_a_crawl_is_refused_by_compare_as_by_solve(tmp_path):
    """compare solved the all-out run, then failed every strategy (exit 1). A front keeps its points:
    there the study's own time fails alone, named (as one under the all-out time does)."""
    result = run("compare", "--track", TRACKS / "amsterdam_rokin_centraal.yaml", "--train", METRO, "--time", 500,
                 "-K", 150, "--no-plot", "--out", tmp_path / "c")
    assert result.exit_code == 2 and "--time: 500 s is over 5 times the fastest possible run's" in result.output
    assert not (tmp_path / "c").exists()
    doc = {**load_yaml(STUDIES / "default.yaml"), "running_time_s": 500, "output": str(tmp_path / "p"),
           "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"), "train": str(METRO)}
    study = write_yaml(tmp_path / "slow.yaml", doc)
    front = run("pareto", study, "--count", 2, "-K", 60, "--workers", 1, "--no-plot", "--out", tmp_path / "p")
    assert front.exit_code == 1 and "failed: study 500 s: infeasible: 500 s is over 5 times" in front.stderr, front.stderr
    assert (pd.read_csv(tmp_path / "p" / "pareto.csv")["status"] == "ok").sum() == 2


def test_the_shipped_journey_finds_its_track():
    """The shipped TTOBench journey names `metro_line_4stops`: `track not found` without --track."""
    path = STUDIES / "timetables" / "metro_line_4stops_Journey_01.json"
    assert associated_track(load_timetable(path), path) == LINE.resolve()


def test_a_timetabled_crawl_is_refused_by_journey_before_any_front(tmp_path):
    """Noord - Station timetabled at 400 s, over 5 times its fastest possible run: every front and
    split was solved before that row failed; refused in one line naming the arrival, as `solve` does."""
    doc = {**FIXED, "stops": [FIXED["stops"][0], {"stop": "Station", "arrival_s": 400}, {"stop": "Centrum", "arrival_s": 523}]}
    result = run("journey", "--train", METRO, "--track", LINE, "--timetable", write_yaml(tmp_path / "crawl.yaml", doc),
                 "-K", 60, "--no-plot", "--out", tmp_path / "j")
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "stops[1].arrival_s: 400.0 s from Noord to Station is over 5 times the fastest possible run's" in lines[0]
    assert not (tmp_path / "j" / "journey.csv").exists()


def test_a_timetable_of_one_stop_is_refused_naming_the_timetable_and_its_stops(tmp_path):
    """It read 'command line: --stops: need two or more stops' though no --stops was given."""
    from .test_bad_input_studies import refused
    timetable = write_yaml(tmp_path / "one.yaml", {"name": "t", "stops": [{"stop": "Noord", "departure_s": 0}]})
    refused(run("journey", "--track", LINE, "--train", METRO, "--timetable", timetable, "-K", 100, "--no-plot",
                "--out", tmp_path / "out"), f"{timetable}: stops: need two or more stops")


def test_a_ttobench_journey_s_refusals_name_its_timing_points_not_the_timetable_schema_s_fields(tmp_path):
    """A TTOBench journey has no 'stops[1].latest_s': its refusals name the rows of 'timing points.values'
    that give the times or the position (the first row is the departure, the second Station's arrival)."""
    import json

    from .test_bad_input_studies import refused
    doc = json.loads((STUDIES / "timetables" / "metro_line_4stops_Journey_01.json").read_text())
    doc["timing points"]["values"][1][2] = 40  # Station by 40 s: the fastest run takes 50 s
    fast = tmp_path / "fast.json"
    fast.write_text(json.dumps(doc))
    journey = ("journey", "--track", LINE, "--train", METRO, "-K", 100, "--no-plot", "--out", tmp_path / "out")
    refused(run(*journey, "--timetable", fast), f"{fast}: timing points.values[0], timing points.values[1]: "
                                                "infeasible: the departure from Noord (not before 0 s)")
    doc["timing points"]["values"][1][2] = 56
    doc["timing points"]["values"] += [[3000, None, None, 0, 0], [3500, None, 400, 0, 0]]  # past the line's end
    beyond = tmp_path / "beyond.json"
    beyond.write_text(json.dumps(doc))
    refused(run(*journey, "--timetable", beyond), f"{beyond}: timing points.values[8]: 3500 m is not on track")
