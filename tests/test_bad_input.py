"""Bad input never becomes an internal error or a silent wrong answer: one line naming
the file (or option) and the field, exit status 2, no traceback, nothing computed."""
import json
import os
import sqlite3

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import TRACKS, TRAINS, load_yaml, write_yaml

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"


def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def one_line(result, *fragments, code=2):
    assert result.exit_code == code, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def solve_train(tmp_path, text, name="t.yaml"):
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return run("solve", "--track", AMS, "--train", path, "--time", 80, "--points", 50, "--out", tmp_path / "o",
               "--no-plot")


# ----------------------------------------------------------------------------------- files
@pytest.mark.parametrize("edit, fragments", [
    (lambda t: t.encode().replace(b"name:", b"name: \xff", 1), ["t.yaml", "not UTF-8 text"]),
    (lambda t: t + "\nx: " + "[" * 200 + "]" * 200 + "\n", ["t.yaml", "nested more than 64 levels"]),
    (lambda t: t + "\nmass_t: 999\n", ["t.yaml: mass_t: duplicate key"]),
    (lambda t: t.replace("length_m: 90", "length_m: 0100"), ["'0100'", "octal"]),
    (lambda t: t.replace("length_m: 90", "length_m: 1:30"), ["'1:30'", "sexagesimal"]),
    (lambda t: t + "\nmax_speed_kmh: yes\n", ["'yes'", "YAML 1.1 boolean"]),
    (lambda t: t.replace("mass_t: 131.403", "mass_t: true"), ["mass_t", "not true/false"]),
    (lambda t: t.replace("mass_t: 131.403", "mass_t: .nan"), ["mass_t", "finite number"]),
    (lambda t: t.replace("mass_t: 131.403", "mass_t: .inf"), ["mass_t", "finite number"]),
    (lambda t: t.replace("mass_t: 131.403", "mass_t: 0.000001"), ["mass_t", "greater than or equal to 1"]),
    (lambda t: t.replace("traction_efficiency: 0.85", "traction_efficiency: 0.007"), ["traction_efficiency"]),
    (lambda t: t + "\ndas_handle_levels: [0.5]\n", ["das_handle_levels", "braking level"]),
    (lambda t: t + "\ndas_handle_levels: [-1, .nan, 1]\n", ["das_handle_levels[1]", "finite number"]),
    (lambda t: t + "\ndas_handle_levels: [-1, true, 1]\n", ["t.yaml: das_handle_levels[1]: expected a number or "
                                                           "text, not true/false"]),
])
def test_bad_train_files_are_one_line(tmp_path, edit, fragments):
    one_line(solve_train(tmp_path, edit(METRO.read_text())), *fragments)
    assert not (tmp_path / "o" / "summary.json").exists()


def test_duplicate_json_keys_are_refused(tmp_path):
    from .conftest import DATA
    text = (DATA / "ttobench_subway_train.json").read_text()
    path = tmp_path / "t.json"
    path.write_text(text.replace('"mass":', '"max speed": {"unit": "km/h", "value": 120}, "mass":'))
    one_line(run("solve", "--track", AMS, "--train", path, "--time", 80, "--out", tmp_path / "o"),
             "t.json: max speed: duplicate key")


# ----------------------------------------------------------------------------------- options
@pytest.mark.parametrize("options, fragments", [
    (["--window", "90,80"], ["--window", "earliest <= latest"]),
    (["--window", "nan,80"], ["--window", "finite"]),
    (["--objective", "mixed", "--weights", "-1,1"], ["--weights", ">= 0"]),
    (["--time", "100", "--weights", "1,2"], ["--weights", "--objective mixed only"]),
    (["--objective", "time", "--time", "100"], ["--objective time", "takes no --time"]),
    (["--time", "80", "--supplement", "5"], ["--time/--supplement", "give only one"]),
    (["--time", "nan"], ["--time", "finite"]),
    (["--supplement", "-5"], ["--supplement"]),
    (["--time", "80", "--points", "2"], ["--points", "at least 10"]),
])
def test_bad_options_are_refused_before_anything_is_computed(tmp_path, options, fragments):
    one_line(run("solve", "--track", AMS, "--train", METRO, *options, "--out", tmp_path / "o", "--no-plot"),
             *fragments)
    assert not (tmp_path / "o").exists()


def test_compare_refuses_two_running_times(tmp_path):
    one_line(run("compare", "--track", AMS, "--train", METRO, "--time", 80, "--supplement", 5, "--out", tmp_path),
             "--time/--supplement")


# ----------------------------------------------------------------------------------- outputs
def test_output_folders_are_checked_first_and_files_get_the_umask(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    one_line(run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--out", afile), "afile",
             "the output folder is a file")
    (tmp_path / "o" / "profile.csv").mkdir(parents=True)
    one_line(run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--out", tmp_path / "o"),
             "profile.csv", "folder where an output file goes")
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 60, "--out", tmp_path / "p",
            "--das", "round", "--no-plot")
    assert r.exit_code in (0, 1), r.output
    mask = os.umask(0)
    os.umask(mask)
    assert (os.stat(tmp_path / "p" / "summary.json").st_mode & 0o777) == 0o666 & ~mask
    assert (tmp_path / "p" / "advice.csv").exists()
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 60, "--out", tmp_path / "p",
            "--no-plot")
    assert r.exit_code == 0 and not (tmp_path / "p" / "advice.csv").exists()  # no stale advice beside it


def test_check_refuses_a_time_below_the_run_and_an_edited_input(tmp_path):
    train = tmp_path / "t.yaml"
    train.write_text(METRO.read_text())
    assert run("solve", "--track", AMS, "--train", train, "--time", 80, "--points", 100, "--out", tmp_path / "o",
               "--no-plot").exit_code == 0
    one_line(run("check", tmp_path / "o", "--time", 50), "--time", "takes 80.00 s")
    assert run("check", tmp_path / "o").exit_code == 0
    train.write_text(METRO.read_text().replace("mass_t: 131.403", "mass_t: 150"))
    one_line(run("check", tmp_path / "o"), "t.yaml", "changed since this result was solved")


# ----------------------------------------------------------------------------------- studies and stores
def study(tmp_path, **extra):
    data = {"name": "s", "track": str(AMS), "train": str(METRO), "running_time_s": 80, "points": 50,
            "output": str(tmp_path / "out"), **extra}
    return write_yaml(tmp_path / "s.yaml", data)


def test_sweeps_refuse_repeated_values_and_keep_labels_apart(tmp_path):
    one_line(run("run", study(tmp_path, sweep={"running_time_s": [80, 80]}), "--no-progress"),
             "running_time_s: a value given twice")
    one_line(run("run", study(tmp_path, sweep={"running_time_s": []}), "--no-progress"), "running_time_s")
    r = run("run", study(tmp_path, sweep={"running_time_s": [80, 85.5]}), "--no-progress")
    assert r.exit_code == 0, r.output
    import pandas as pd
    table = pd.read_csv(tmp_path / "out" / "results.csv")
    assert list(table["swept_running_time_s"]) == [80, 85.5] and "running_time_s" in table


@pytest.mark.parametrize("sweep, field", [
    ({"supplement_percent": [True, 10]}, "sweep.supplement_percent[0]"),
    ({"running_time_s": [80, False]}, "sweep.running_time_s[1]"),
    ({"points": [100, True]}, "sweep.points[1]"),
])
def test_a_sweep_refuses_true_false_where_a_number_is_meant(tmp_path, sweep, field):
    """As at the top level: ``supplement_percent: [true, 10]`` ran a case labelled supplement_pct=1
    and ``running_time_s: [true, 80]`` a 1 s case, exit status 0."""
    path = study(tmp_path, sweep=sweep)
    one_line(run("run", path, "--no-progress"), f"{path}: {field}: expected a number or text, not true/false")
    assert not (tmp_path / "out").exists()


def test_a_damaged_store_keeps_its_readable_cases_and_a_foreign_one_is_named(tmp_path):
    path = study(tmp_path, sweep={"running_time_s": [80, 85]})
    assert run("run", path, "--no-progress").exit_code == 0
    db = sqlite3.connect(tmp_path / "out" / "results.sqlite")
    db.execute("UPDATE cases SET summary = '{broken' WHERE rowid = 1")
    db.commit()
    db.close()
    r = run("run", path, "--no-progress")
    assert r.exit_code == 0 and "1 already stored, 1 computed now" in r.output and "damaged row" in r.output
    for name in ("results.sqlite-wal", "results.sqlite-shm"):
        (tmp_path / "out" / name).unlink(missing_ok=True)
    (tmp_path / "out" / "results.sqlite").write_text("not a database")
    one_line(run("run", path, "--no-progress"), "results.sqlite", "not a readable ecostudy store", "move it away")
    (tmp_path / "out" / "results.sqlite").unlink()
    db = sqlite3.connect(tmp_path / "out" / "results.sqlite")
    db.execute("CREATE TABLE cases (id INTEGER, payload TEXT)")
    db.commit()
    db.close()
    one_line(run("run", path, "--no-progress"), "results.sqlite: cases", "another program")


def test_a_store_is_locked_while_a_run_writes_it(tmp_path):
    from ecostudy.core.errors import InputError
    from ecostudy.io.store import Store
    store = Store(tmp_path / "results.sqlite")
    with pytest.raises(InputError, match="another ecostudy run is writing this store"):
        Store(tmp_path / "results.sqlite")
    store.close()
    Store(tmp_path / "results.sqlite").close()


def test_network_without_strategies_is_refused(tmp_path):
    from .conftest import STUDIES
    data = load_yaml(STUDIES / "network_metro_2trains.yaml")
    data.update(strategies=[], track=str((STUDIES / data["track"]).resolve()),
                train=str((STUDIES / data["train"]).resolve()), output=str(tmp_path / "n"))
    one_line(run("network", write_yaml(tmp_path / "n.yaml", data)), "strategies")


@pytest.mark.slow  # over 7 s: make test stays under 3 min; CI runs it
def test_runaway_sizes_and_impossible_layouts_are_refused(tmp_path):
    from .conftest import STUDIES
    track = load_yaml(AMS)
    track["gradients"] = [{"position_m": i * 0.05, "gradient_permille": (i % 3) - 1} for i in range(20001)]
    one_line(run("solve", "--track", write_yaml(tmp_path / "k.yaml", track), "--train", METRO, "--time", 80,
                 "--out", tmp_path / "o"), "k.yaml: gradients", "at most 20000")
    train = load_yaml(METRO)
    train["length_m"] = 5000
    one_line(run("solve", "--track", AMS, "--train", write_yaml(tmp_path / "t.yaml", train), "--time", 80,
                 "--out", tmp_path / "o"), "length_m: 5000 m is longer than the track")
    net = load_yaml(STUDIES / "network_metro_2trains.yaml")
    net.update(track=str((STUDIES / net["track"]).resolve()), train=str((STUDIES / net["train"]).resolve()))
    for change, fragment in (({"time_step_s": 1e-6}, "time_step_s"),
                             ({"trains": [{"name": "a", "offset_s": 0}, {"name": "b", "offset_s": 0}]},
                              "depart at the same time"),
                             ({"trains": [{"name": "a", "offset_s": 0}, {"name": "b", "offset_s": 1e7}]}, "offset_s")):
        one_line(run("network", write_yaml(tmp_path / "n.yaml", {**net, **change})), fragment)


def test_journey_and_dask_mistakes_are_input_errors(tmp_path):
    one_line(run("journey", "--track", TRACKS / "metro_line_4stops.yaml", "--train", METRO, "--time", 100,
                 "--no-plot", "--out", tmp_path / "j"), "infeasible: the total time 100.0 s is below")
    path = write_yaml(tmp_path / "s.yaml", {"name": "s", "track": str(AMS), "train": str(METRO),
                                            "running_time_s": 80, "points": 50, "output": str(tmp_path / "out")})
    one_line(run("run", path, "--dask", "not-an-address", "--no-progress"), "--dask", "tcp://host:port")


def test_speed_limits_that_look_like_metres_per_second_are_warned(tmp_path):
    track = load_yaml(TRACKS / "yazhemsky2017_5km_representative.yaml")
    track["speed_limits"] = [{"position_m": 0, "speed_kmh": 16.0}]  # 16 m/s written as km/h
    path = write_yaml(tmp_path / "k.yaml", track)
    from ecostudy.io.loaders import load_track
    with pytest.warns(UserWarning, match="speed_limits: every limit is below 25 km/h on a 5.0 km line"):
        load_track(path)


def test_an_output_folder_that_cannot_be_created_is_named_first(tmp_path):
    one_line(run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--out", "/proc/ecostudy-out"),
             "/proc/ecostudy-out", "cannot write the output folder")


def test_more_options_and_ignored_study_fields(tmp_path):
    path = study(tmp_path, windows=[{"position_m": 500, "latest_s": 40}])
    one_line(run("compare", path, "--out", tmp_path / "c"), "windows", "compare does not keep timing windows")
    one_line(run("pareto", path, "--out", tmp_path / "p"), "windows", "pareto does not keep timing windows")
    one_line(run("run", study(tmp_path), "--workers", 0, "--no-progress"), "--workers", "at least 1")
    one_line(run("journey", "--track", TRACKS / "metro_line_4stops.yaml", "--train", METRO, "--supplement", 10,
                 "--dwell", -20, "--out", tmp_path / "j"), "--dwell", "at least 0")
    one_line(run("pareto", "--track", AMS, "--train", METRO, "--points", 1000000, "--out", tmp_path / "q"),
             "--points", "at most 100000")


@pytest.mark.flagged_on_purpose
def test_a_flagged_result_says_why_it_exits_1(tmp_path):
    """On a 12-node grid the ATO optimum misses the re-simulation's tolerance: exit 1, and a line
    saying so (before, compare and journey exited 1 without a word)."""
    r = run("compare", "--track", AMS, "--train", METRO, "--time", 80, "--points", 12, "--no-plot", "--out", tmp_path)
    assert r.exit_code == 1 and "flagged: ATO optimum: re-simulation outside tolerance" in r.output, r.output


@pytest.mark.slow
def test_an_unreachable_dask_scheduler_is_named(tmp_path):
    path = study(tmp_path)
    one_line(run("run", path, "--dask", "tcp://127.0.0.1:1", "--no-progress"), "--dask",
             "cannot reach the Dask scheduler at tcp://127.0.0.1:1")


# ----------------------------------------------------------------------------------- a study and options
DEFAULT_STUDY = TRACKS.parent / "studies" / "default.yaml"


@pytest.mark.parametrize("command, options, fragment", [
    ("solve", ["--from", "Nowhere"], "--from"),
    ("solve", ["--from", ""], "--from"),
    ("solve", ["--to", "Centraal Station"], "--to"),
    ("compare", ["--from", "Nowhere"], "--from"),
    ("pareto", ["--to", "Nowhere", "--count", "2"], "--to"),
])
def test_stops_beside_a_study_file_are_refused(tmp_path, command, options, fragment):
    """A study file sets its stops and its timing for them: --from/--to beside it are refused, not ignored."""
    one_line(run(command, DEFAULT_STUDY, *options, "--points", 50, "--out", tmp_path / "o"), fragment,
             "a study file sets its stops")
    assert not (tmp_path / "o").exists()


def test_window_and_weights_beside_a_study_file_are_used(tmp_path):
    """--window and --weights override a study's timing and weights, as --time does (they were ignored)."""
    r = run("solve", DEFAULT_STUDY, "--window", "84,86", "--points", 50, "--out", tmp_path / "w", "--no-plot")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "w" / "summary.json").read_text())
    assert 84 - 1e-6 <= s["running_time_s"] <= 86 + 1e-6, s["running_time_s"]  # the study's own time is 76 s
    one_line(run("solve", DEFAULT_STUDY, "--weights", "1,2", "--points", 50, "--out", tmp_path / "x"),
             "--weights", "--objective mixed only")
    times = []
    for weights in ("1,0.01", "1,100"):  # the pair's weights move the mixed optimum across the window
        r = run("solve", DEFAULT_STUDY, "--objective", "mixed", "--weights", weights, "--window", "70,100",
                "--points", 50, "--out", tmp_path / weights, "--no-plot")
        assert r.exit_code in (0, 1), r.output
        times.append(json.loads((tmp_path / weights / "summary.json").read_text())["running_time_s"])
    assert abs(times[1] - times[0]) > 10.0, times  # 72.0 and 100.0 s
