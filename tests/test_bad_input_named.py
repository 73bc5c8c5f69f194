"""Refusals that named a train by its name, a window by nothing, or printed an overflow: each now one
line naming the file and the field (exit status 2, no traceback), through the command line."""
import pytest

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml
from .test_bad_input_studies import hostile, nothing_written, refused, run

METRO, AMS, LINE4 = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml", TRACKS / "metro_line_4stops.yaml"
ROKIN = ["--track", AMS, "--points", 50, "--no-plot"]


def long_train(tmp_path, metres=5000):
    """The Amsterdam metro at ``metres`` long (its track is 1106 m, the 4-stop line 3000 m)."""
    path = tmp_path / "long.yaml"
    path.write_text(METRO.read_text().replace("length_m: 90", f"length_m: {metres}", 1))
    return path


@pytest.mark.parametrize("command", [
    ["solve", *ROKIN, "--time", 80],
    ["pareto", *ROKIN, "--count", 4],  # an internal error (exit 3): a front of failed points
    ["compare", *ROKIN, "--time", 80],  # computed, every strategy failed (exit 1)
    ["journey", "--track", LINE4, "--points", 50, "--no-plot", "--supplement", 10],
])
def test_a_train_longer_than_its_track_names_the_train_file(tmp_path, command):
    """It named the train ("train 'Amsterdam metro ...': length_m: ...") and not its file."""
    train = long_train(tmp_path)
    refused(run(*command, "--train", train, "--out", tmp_path / "out"), f"{train}: length_m: 5000 m is longer than "
            "the track")
    nothing_written(tmp_path)


def test_a_study_train_longer_than_its_track_names_the_train_file(tmp_path):
    train = long_train(tmp_path)
    network = hostile(tmp_path, "network_metro_2trains.yaml", train=str(train), strategies=["independent"], points=50)
    refused(run("network", network, "--no-plot", "--workers", 1), f"{train}: length_m: 5000 m is longer than the track")
    loop = hostile(tmp_path, "metro_monte_carlo.yaml", train=str(train), draws=1,
                   controllers=[{"name": "convex", "kind": "convex"}])
    refused(run("simulate", loop, "--no-plot", "--workers", 1, "--no-progress"), f"{train}: length_m: 5000 m")
    nothing_written(tmp_path)


def test_a_consist_longer_than_its_track_names_its_vehicles(tmp_path):
    consist = load_yaml(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    consist["vehicles"] = [{"type": "locomotive", "count": 2}] + [{"type": "wagon", "count": 1000}] * 4
    path = write_yaml(tmp_path / "c.yaml", consist)  # 4000 wagons of 12.07 m: 48 km on a 45 km line
    study = hostile(tmp_path, "heavyhaul_brake_penalty.yaml", consist=str(path))
    refused(run("heavyhaul", study, "--no-plot", "--workers", 1, "--no-progress"),
            f"{path}: vehicles: 48320.9 m is longer than the track 'Heavy-haul line")
    nothing_written(tmp_path)


def test_a_scenario_train_longer_than_its_track_names_the_field(tmp_path):
    doc = load_yaml(STUDIES / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=50, output=str(tmp_path / "out"),
               scenarios=[{"name": "long", "train_overrides": {"length_m": 5000}}])
    refused(run("run", write_yaml(tmp_path / "s.yaml", doc), "--workers", 1),
            "s.yaml: scenarios[0].train_overrides.length_m: scenario 'long': train 'Amsterdam metro (Alstom, Rokin-Centraal "
            "case)': length_m: 5000 m is longer than the track")


def window_study(tmp_path, **window):
    doc = load_yaml(STUDIES / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=50, output=str(tmp_path / "out"), running_time_s=80,
               windows=[{"position_m": 600, **window}])
    return write_yaml(tmp_path / "s.yaml", doc)


@pytest.mark.parametrize("window, fragment", [
    ({"latest_s": 10}, "s.yaml: windows[0].latest_s: infeasible: the fastest run passes 600 m from Rokin at"),
    ({"min_speed_kmh": 200}, "s.yaml: windows[0].min_speed_kmh: infeasible: at 600 m from Rokin the train reaches"),
])
def test_a_window_no_run_keeps_names_the_study_field(tmp_path, window, fragment):
    """It was "infeasible: the fastest run passes 600 m ..." with neither file nor field."""
    refused(run("solve", window_study(tmp_path, **window), "--no-plot"), fragment)
    nothing_written(tmp_path)


@pytest.mark.parametrize("windows, fragment", [
    ([{"position_m": 500, "earliest_s": 50}, {"position_m": 600, "latest_s": 45}],
     "s.yaml: windows[0].earliest_s, windows[1].latest_s: infeasible: the timing point at 500 m (not before 50 s) and "
     "the timing point at 600 m (not after 45 s) leave -5 s; the fastest run between them takes 4 s"),
    ([{"position_m": 500, "latest_s": 45}, {"position_m": 500, "earliest_s": 50}],
     "s.yaml: windows[1].earliest_s, windows[0].latest_s: infeasible: the timing point at 500 m (not before 50 s) and "
     "the timing point at 500 m (not after 45 s) leave -5 s; one place is passed at one time"),
])
def test_windows_no_run_keeps_together_are_refused_naming_both(tmp_path, windows, fragment):
    """Each window passed the fastest envelope alone; together they were solved (the all-out NLP at
    K = 100, 300 and 1000) and refused as 'infeasible on this grid ... though the fastest envelope
    does: try more points', which no grid keeps. The rule is the journey timetable's
    (ocp.problem.check_times_reachable), before computing."""
    doc = load_yaml(STUDIES / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=100, output=str(tmp_path / "out"), running_time_s=80,
               windows=windows)
    refused(run("solve", write_yaml(tmp_path / "s.yaml", doc), "--no-plot"), fragment)
    nothing_written(tmp_path)


def test_windows_a_command_does_not_keep_are_refused_naming_the_file(tmp_path):
    """``pareto`` and ``compare`` named the study's name ('s: windows/window_s'); ``run`` ignored its windows."""
    study = window_study(tmp_path, latest_s=10)
    for command in ("pareto", "compare"):
        refused(run(command, study, "--no-plot"), f"{study}: windows: {command} does not keep timing windows")
    refused(run("run", study, "--workers", 1), f"{study}: windows: `ecostudy run` does not keep timing windows")
    nothing_written(tmp_path)


@pytest.mark.parametrize("stops, windows, fragment", [
    ("{stop: Station, earliest_s: 20, latest_s: 30, dwell_s: 25}", "",
     "tt.yaml: stops[0].departure_s, stops[1].latest_s: infeasible: the departure from Noord (not before 0 s) and "
     "the arrival at Station (not after 30 s) leave 30 s"),
    ("{stop: Station, arrival_s: 58, dwell_s: 25}", "windows:\n  - {position_m: 500, latest_s: 5}\n",
     "tt.yaml: stops[0].departure_s, windows[0].latest_s: infeasible: the departure from Noord (not before 0 s) and "
     "the timing point at 500 m (not after 5 s)"),
    # a dwell between the two times: 98 s of running leave 110 s, 20 s of dwell do not; it said "takes 98 s" alone
    ("{stop: Station, latest_s: 56, dwell_s: 20}", "windows:\n  - {position_m: 1400, earliest_s: 90, latest_s: 110}\n",
     "tt.yaml: stops[0].departure_s, windows[0].latest_s: infeasible: the departure from Noord (not before 0 s) and "
     "the timing point at 1400 m (not after 110 s) leave 110 s; the fastest run between them takes 98 s and the dwells "
     "20 s"),
])
def test_a_timetable_window_no_run_keeps_names_its_fields(tmp_path, stops, windows, fragment):
    """It was "infeasible: the departure from Noord ... and the arrival at Station ..." with neither file nor field."""
    path = tmp_path / "tt.yaml"
    path.write_text(f"name: tt\nstops:\n  - {{stop: Noord, departure_s: 0}}\n  - {stops}\n"
                    "  - {stop: Centrum, arrival_s: 181, dwell_s: 30}\n  - {stop: Zuid, arrival_s: 276}\n" + windows)
    refused(run("journey", "--track", LINE4, "--train", METRO, "--timetable", path, "--points", 50, "--no-plot",
                "--out", tmp_path / "out"), fragment)
    nothing_written(tmp_path)


@pytest.mark.parametrize("old, new, fragment", [
    # 1e308 kN overflowed: "... against inf kN of running resistance", naming neither file nor field
    ("  a_N: 3975.9\n  b_N_per_mps: 24.36\n  c_N_per_mps2: 4.38", "  a_kN: 1.0e+308\n  b_kN_per_kmh: 0.0068\n"
     "  c_kN_per_kmh2: 0.00034", "t.yaml: davis.a_kN: 1e+308 gives a resistance of more than any number holds (an overflow)"),
    ("c_N_per_mps2: 4.38", "c_N_per_mps2: 1.0e+308", "t.yaml: davis.c_N_per_mps2: 1e+308 gives a resistance"),
    ("c_N_per_mps2: 4.38", "c_N_per_mps2: 2000", "t.yaml: davis.c_N_per_mps2: 2000 gives a resistance of 1.54e+03 kN "
     "at 100 km/h, above the train's weight (1289 kN"),
])
def test_a_davis_term_above_the_weight_is_refused_at_the_file(tmp_path, old, new, fragment):
    path = tmp_path / "t.yaml"
    text = METRO.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    line = refused(run("solve", *ROKIN, "--train", path, "--time", 80, "--out", tmp_path / "out"), fragment)
    assert "inf" not in line
    nothing_written(tmp_path)


def test_a_davis_term_within_the_bound_is_solved(tmp_path):
    """Five times the metro's C (a 13 per mille term at 100 km/h) is a train, if a draggy one."""
    path = tmp_path / "t.yaml"
    path.write_text(METRO.read_text().replace("c_N_per_mps2: 4.38", "c_N_per_mps2: 21.9", 1))
    assert run("solve", *ROKIN, "--train", path, "--time", 80, "--out", tmp_path / "out").exit_code == 0


@pytest.mark.parametrize("sample_time, fragment", [
    # 1e-300 s printed "199,999,999,999,999,977,191,...": a count of 303 digits
    (1e-300, "convex: 7.6e+301 samples of 1e-300 s at K = 100: an estimated 8.3e+294 days of computing"),
    # 1e-320 s (a subnormal): "OverflowError: cannot convert float infinity to integer", exit 3
    (1e-320, "convex: more than 1e+308 samples of"),
])
def test_a_tiny_sample_time_is_refused_with_a_readable_estimate(tmp_path, sample_time, fragment):
    study = hostile(tmp_path, "metro_monte_carlo.yaml", sample_time_s=sample_time, draws=1,
                    controllers=[{"name": "convex", "kind": "convex"}])
    line = refused(run("simulate", study, "--no-plot", "--workers", 1, "--no-progress"), "sample", fragment)
    assert len(line) < 400 and "give --force" in line
    nothing_written(tmp_path)


@pytest.mark.parametrize("where, fragment", [
    # a folder or a missing folder: a rich traceback of IsADirectoryError / FileNotFoundError, exit 1
    ("", "Is a directory"),
    ("no/x.log", "No such file or directory"),
])
def test_a_log_file_that_cannot_be_written_is_one_line(tmp_path, where, fragment):
    log = tmp_path / where
    refused(run("--log-file", log, "solve", *ROKIN, "--train", METRO, "--time", 80, "--out", tmp_path / "out"),
            f"command line: --log-file: {log}: cannot write the log file ({fragment})")
    nothing_written(tmp_path)


def test_a_minlp_time_limit_past_the_run_budget_is_refused_with_its_estimate(tmp_path):
    """--das-time-limit 1e308 was accepted: the MINLP search ran on past a 30 s timeout."""
    refused(run("solve", *ROKIN, "--train", METRO, "--time", 80, "--das", "minlp", "--das-time-limit", 1e308,
                "--out", tmp_path / "out"), "command line: --das-time-limit: a run at K = 50 with a MINLP search of up "
            "to 1.2e+303 days: an estimated 1.2e+303 days of computing, above the 2 h one run may take; give --force")
    nothing_written(tmp_path)


@pytest.mark.parametrize("option, value, fragment", [
    # "error: --dpi: 0 is outside ...": no place named
    ("--dpi", 0, "command line: --dpi: 0 is outside 10-2400 dots per inch"),
    ("--format", "bmp", "command line: --format: 'bmp' is not a figure format"),
])
def test_a_figure_option_out_of_range_names_the_command_line(tmp_path, option, value, fragment):
    refused(run("solve", *ROKIN, "--train", METRO, "--time", 80, option, value, "--out", tmp_path / "out"), fragment)


def test_an_export_step_of_1e_300_s_prints_a_readable_count(tmp_path):
    """It printed a count of 302 digits ("79,999,999,999,999,994,683,...")."""
    assert run("solve", *ROKIN, "--train", METRO, "--time", 80, "--out", tmp_path / "s").exit_code == 0
    line = refused(run("export", tmp_path / "s", "--every", "1e-300s"),
                   "command line: --every: a step of 1e-300 s over the run's 80 s is 8e+301 rows, above the 1,000,000")
    assert len(line) < 300


def test_an_unknown_only_names_the_option(tmp_path):
    """It was '<study>: controllers: --only names , not among ...': the study named for the option's value."""
    study = hostile(tmp_path, "yazhemsky2017_closed_loop.yaml")
    refused(run("simulate", study, "--only", "", "--no-plot", "--no-progress"),
            "command line: --only: '': not among the controllers of", "(convex_mixed, convex_time, plan_replayed)")
    nothing_written(tmp_path)


def test_a_timetable_whose_times_leave_no_run_together_names_the_file(tmp_path):
    """Each pair of its times leaves the fastest run (the passing point at 1400 m by 118 s after a
    20 s dwell at Station), but no run keeps them all: the windowed journey NLP is infeasible, said
    as the timetable's, not as "infeasible: no run of the journey ..." naming no file."""
    path = tmp_path / "tt.yaml"
    path.write_text("name: tt\nstops:\n  - {stop: Noord, departure_s: 0}\n  - {stop: Station, latest_s: 56, dwell_s: 20}\n"
                    "  - {stop: Centrum, latest_s: 185, dwell_s: 20}\n  - {stop: Zuid, latest_s: 270}\n"
                    "windows:\n  - {position_m: 1400, earliest_s: 90, latest_s: 118, max_speed_kmh: 40}\n")
    refused(run("journey", "--track", LINE4, "--train", METRO, "--timetable", path, "--points", 100, "--no-plot",
                "--out", tmp_path / "out"), "tt.yaml: stops, windows: infeasible: no run of the journey that keeps "
            "its timing windows")
    nothing_written(tmp_path)


@pytest.mark.parametrize("flag, given, kind, fragment", [
    ("--train", AMS, "a track file", "not a train file"),
    ("--track", METRO, "a train file", "not a track file"),
])
def test_a_file_of_another_kind_is_one_line_naming_its_kind(tmp_path, flag, given, kind, fragment):
    """A track file given as the train printed seven lines (four fields missing, three unknown)."""
    other = ["--track", AMS] if flag == "--train" else ["--train", METRO]
    line = refused(run("solve", flag, given, *other, "--points", 50, "--no-plot", "--time", 80,
                       "--out", tmp_path / "out"), f"{given}: {kind} (", fragment)
    assert "missing field" not in line and "unknown field" not in line
    nothing_written(tmp_path)


def test_a_misspelt_field_is_not_taken_for_a_file_of_another_kind(tmp_path):
    """One unknown field beside the train's own stays one line naming that field."""
    train = tmp_path / "t.yaml"
    train.write_text(METRO.read_text() + "stops: []\n")
    refused(run("solve", "--train", train, "--track", AMS, "--points", 50, "--no-plot", "--time", 80,
                "--out", tmp_path / "out"), f"{train}: stops: unknown field")


def test_a_closed_loop_studys_train_field_names_the_train_file(tmp_path):
    """`STUDY train: brake_cylinders: unknown field`: the study named for its train file's field."""
    train = write_yaml(tmp_path / "extra.yaml", {**load_yaml(TRAINS / "amsterdam_metro.yaml"), "brake_cylinders": 4})
    loop = hostile(tmp_path, "metro_monte_carlo.yaml", train=str(train), draws=1,
                   controllers=[{"name": "convex", "kind": "convex"}])
    refused(run("simulate", loop, "--no-plot", "--workers", 1, "--no-progress"), f"{train}: brake_cylinders")
    nothing_written(tmp_path)


@pytest.mark.parametrize("timing, fragment", [
    (["--no-plot"], "s.yaml: running_time_s: infeasible: the timing point at 1000 m (not before 72 s) and the arrival "
                    "at Centraal (not after 80 s) leave 8 s; the fastest run between them takes 13 s"),
    (["--no-plot", "--window", "70,78"], "command line: --window: infeasible: the timing point at 1000 m (not before "
                                         "72 s) and the arrival at Centraal (not after 78 s) leave 6 s"),
])
def test_a_window_the_arrival_cannot_follow_is_refused_naming_the_timing(tmp_path, timing, fragment):
    """A window passed 13 s (the fastest run) before the stop, later than the arrival less 13 s, was
    solved (the energy NLP, then the all-out one with the window) and refused as 'running_time_s:
    infeasible: the fastest possible run takes 85.1 s': a time no run was asked for, the window not
    named. The arrival is now one of the passings ocp.problem.check_times_reachable holds together."""
    doc = load_yaml(STUDIES / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=100, output=str(tmp_path / "out"), running_time_s=80,
               windows=[{"position_m": 1000, "earliest_s": 72}])
    refused(run("solve", write_yaml(tmp_path / "s.yaml", doc), *timing), fragment)
    nothing_written(tmp_path)


def test_an_arrival_that_leaves_the_rest_after_a_window_to_crawl_is_refused(tmp_path):
    """A window passed by 70 s at 1000 m and an arrival window from 140 s: the last 106 m take at least
    70 s, over 5 times their fastest 13.1 s; solved, the run was flagged (3 m short, 3 s early)."""
    doc = load_yaml(STUDIES / "default.yaml")
    doc.update(track=str(AMS), train=str(METRO), points=100, output=str(tmp_path / "out"), running_time_s=100,
               windows=[{"position_m": 1000, "latest_s": 70}])
    refused(run("solve", write_yaml(tmp_path / "s.yaml", doc), "--window", "140,150"),
            "command line: --window: the timing point at 1000 m (passed by 70 s) and the arrival at Centraal (not "
            "before 140 s) leave at least 70 s for the last 106 m, over 5 times the fastest run's 13.1 s there: the "
            "train would crawl")
    nothing_written(tmp_path)
