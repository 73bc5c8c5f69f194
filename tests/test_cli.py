"""The command line: outputs, exit codes, and one clear line per bad input (exit 2, no traceback)."""
import json

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import assert_folder, STUDIES, TRACKS, TRAINS, load_yaml, write_yaml

runner = CliRunner()
METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"


def run(*args):
    return runner.invoke(app, [str(a) for a in args])


def error_lines(result):
    return [line for line in result.output.splitlines() if line.startswith("error:")]


def assert_one_line_error(result, *fragments):
    assert result.exit_code == 2, result.output
    lines = error_lines(result)
    assert len(lines) == 1, result.output
    assert "Traceback" not in result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def test_solve_study_writes_outputs(tmp_path):
    out = tmp_path / "run"
    r = run("solve", STUDIES / "yazhemsky2017_advanced.yaml", "--out", out)
    assert r.exit_code == 0, r.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["verification"]["passed"]
    assert summary["running_time_s"] == pytest.approx(84.92, abs=1e-4)
    assert (out / "speed.png").stat().st_size > 10_000
    header = (out / "profile.csv").read_text().splitlines()[0]
    assert header.startswith("position_m,time_s,speed_kmh,handle")
    assert not list(out.glob("*.tmp"))
    folder = assert_folder(out, "solve", ["profile"])
    assert folder.summary["running_time_s"] == summary["running_time_s"] and folder.cases.total == 1


def test_solve_with_options_and_supplement(tmp_path):
    r = run("solve", "--track", AMS, "--train", METRO, "--supplement", 5, "--points", 300,
            "--out", tmp_path, "--no-plot")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["running_time_s"] == pytest.approx(1.05 * s["all_out_time_s"], rel=1e-6)


def test_doctor():
    r = run("doctor")
    assert r.exit_code == 0, r.output
    assert "toy NLP" in r.output and "ok" in r.output and "ipopt" in r.output


@pytest.fixture
def train_data():
    return load_yaml(METRO)


@pytest.fixture
def track_data():
    return load_yaml(AMS)


def solve_files(tmp_path, train=None, track=None, *extra):
    train_path = write_yaml(tmp_path / "train.yaml", train) if train is not None else METRO
    track_path = write_yaml(tmp_path / "track.yaml", track) if track is not None else AMS
    return run("solve", "--track", track_path, "--train", train_path, "--time", 76, "--points", 200,
               "--out", tmp_path / "out", "--no-plot", *extra)


def test_unknown_key(tmp_path, train_data):
    train_data["colour"] = "red"
    assert_one_line_error(solve_files(tmp_path, train=train_data), "train.yaml", "colour", "unknown field")


def test_missing_field(tmp_path, track_data):
    del track_data["length_m"]
    assert_one_line_error(solve_files(tmp_path, track=track_data), "track.yaml", "length_m", "missing field")


def test_negative_mass(tmp_path, train_data):
    train_data["mass_t"] = -131.4
    assert_one_line_error(solve_files(tmp_path, train=train_data), "train.yaml", "mass_t", "greater than or equal to 1")


def test_non_increasing_positions(tmp_path, track_data):
    track_data["gradients"][2]["position_m"] = 50
    assert_one_line_error(solve_files(tmp_path, track=track_data), "track.yaml", "gradients[2].position_m",
                          "strictly increasing")


def test_non_monotone_speed_table(tmp_path, train_data):
    train_data["traction"]["table"]["speed_kmh"][3] = 40
    assert_one_line_error(solve_files(tmp_path, train=train_data), "train.yaml",
                          "traction.table.speed_kmh", "strictly increasing")


def test_running_time_below_all_out(tmp_path):
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 60, "--points", 300, "--out", tmp_path)
    assert_one_line_error(r, "infeasible: the fastest possible run takes", "asked for 60.0 s")


def test_unknown_stop(tmp_path):
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 76, "--from", "Nowhere", "--out", tmp_path)
    assert_one_line_error(r, "from", "unknown stop 'Nowhere'", "Rokin")


def test_malformed_yaml(tmp_path):
    bad = tmp_path / "train.yaml"
    bad.write_text("name: x\nmass_t: [1, 2\n")
    r = run("solve", "--track", AMS, "--train", bad, "--time", 76, "--out", tmp_path)
    assert_one_line_error(r, "train.yaml", "malformed YAML at line")


def test_malformed_json(tmp_path):
    bad = tmp_path / "train.json"
    bad.write_text('{"mass": {"value": 1000,}')
    r = run("solve", "--track", AMS, "--train", bad, "--time", 76, "--out", tmp_path)
    assert_one_line_error(r, "train.json", "malformed JSON at line")


def test_all_problems_of_a_file_are_reported(tmp_path, train_data):
    train_data["colour"] = "red"
    train_data["length_m"] = -1
    r = solve_files(tmp_path, train=train_data)
    assert r.exit_code == 2
    assert len(error_lines(r)) == 2


def test_debug_shows_the_exception(tmp_path, train_data):
    """--debug prints the traceback and keeps the exit status (2 for bad input, not Python's 1)."""
    train_data["colour"] = "red"
    r = solve_files(tmp_path, train_data, None, "--debug")
    assert r.exit_code == 2, r.output
    assert "Traceback" in r.output and "colour: unknown field" in r.output


def test_davis_in_wrong_units_warns_with_the_field(tmp_path, train_data):
    train_data["davis"]["a_N"] = 3.9759  # kN typed as N
    r = solve_files(tmp_path, train=train_data)
    assert r.exit_code == 0, r.output
    warn = [line for line in r.output.splitlines() if line.startswith("warning:")]
    assert len(warn) == 1 and "davis.a_N" in warn[0] and "check the units" in warn[0]


def test_asl_library_found_when_pyomo_is_imported_first(tmp_path):
    """A notebook may import Pyomo before ecostudy; the ASL library must still be found."""
    import os
    import subprocess
    import sys
    code = ("import pyomo.environ, pyomo.contrib.pynumero.asl\n"
            "from ecostudy.cli import app\n"
            "from typer.testing import CliRunner\n"
            "r = CliRunner().invoke(app, ['doctor'])\n"
            "print(r.output); raise SystemExit(r.exit_code)\n")
    env = {k: v for k, v in os.environ.items() if k != "PYOMO_CONFIG_DIR"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "ok" in r.stdout


def test_check_on_a_folder_that_is_not_a_result(tmp_path):
    assert_one_line_error(run("check", tmp_path), str(tmp_path), "not a result folder")


def test_check_and_export_of_a_file_or_a_missing_folder_say_so_in_words(tmp_path):
    """A file, a folder that is not there, a folder without inputs.json: the line says which, in
    words, without Python's errno text ('[Errno 20] Not a directory: ...')."""
    afile = tmp_path / "afile"
    afile.write_text("")
    for command, extra in (("check", ()), ("export", ("--every", "1s"))):
        for where, words in ((afile, "a file, not a result folder of `ecostudy solve`"),
                             (tmp_path / "missing", "no such folder"),
                             (tmp_path, "not a result folder of `ecostudy solve`: it has no inputs.json")):
            r = run(command, where, *extra)
            assert_one_line_error(r, str(where), words)
            assert "Errno" not in r.output, r.output


def window_study(tmp_path, window):
    return write_yaml(tmp_path / "study.yaml", {
        "name": "window", "track": str(AMS), "train": str(METRO), "running_time_s": 80, "points": 400,
        "windows": [window]})


def test_timing_window_is_kept_and_verified(tmp_path):
    r = run("solve", window_study(tmp_path, {"position_m": 600, "latest_s": 42, "max_speed_kmh": 72}),
            "--out", tmp_path / "o", "--no-plot")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    (w,) = s["verification"]["windows"]
    assert w["kept"] and w["simulated_time_s"] <= 42.5 and w["simulated_speed_kmh"] <= 72.5
    free = run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 400, "--out", tmp_path / "f",
               "--no-plot")
    assert free.exit_code == 0
    assert s["traction_energy_kWh"] > json.loads((tmp_path / "f" / "summary.json").read_text())["traction_energy_kWh"]


def test_impossible_timing_window(tmp_path):
    r = run("solve", window_study(tmp_path, {"position_m": 600, "latest_s": 36}), "--out", tmp_path / "o")
    assert_one_line_error(r, "infeasible: the fastest run passes 600 m from Rokin at", "(window: by 36.0 s)")


def test_window_outside_the_segment(tmp_path):
    r = run("solve", window_study(tmp_path, {"position_m": 2000, "latest_s": 36}), "--out", tmp_path / "o")
    assert_one_line_error(r, "study.yaml", "windows[0].position_m", "is not between 'Rokin' and 'Centraal'")


@pytest.mark.parametrize("args, option, fragment", [
    (("solve", "--track", AMS, "--train", METRO, "--time", "nan"), "--time", "finite"),
    (("solve", "--track", AMS, "--train", METRO, "--supplement", "inf"), "--supplement", "finite"),
    (("solve", "--track", AMS, "--train", METRO, "--supplement", "-5"), "--supplement", "at least 0"),
    (("solve", "--track", AMS, "--train", METRO, "--time", "80", "--points", "0"), "--points", "at least 10"),
    (("solve", "--track", AMS, "--train", METRO, "--time", "80", "--points", "2"), "--points", "at least 10"),
    (("compare", "--track", AMS, "--train", METRO, "--time", "-80"), "--time", "more than 0"),
    (("pareto", "--track", AMS, "--train", METRO, "--workers", "0"), "--workers", "at least 1"),
    (("pareto", "--track", AMS, "--train", METRO, "--count", "1"), "--count", "at least 2"),
    (("journey", "--track", AMS, "--train", METRO, "--supplement", "10", "--dwell", "-20"), "--dwell", "at least 0"),
    (("run", STUDIES / "metro_supplements.yaml", "--workers", "0"), "--workers", "at least 1"),
    (("check", "out", "--time", "nan"), "--time", "finite"),
])
def test_numeric_options_out_of_range_are_refused_before_any_work(args, option, fragment):
    """Before, --points 0 became 1000, --workers 0 and NaN or negative times
    reached the solver or ended in an internal error (exit 3)."""
    assert_one_line_error(run(*args), f"command line: {option}", fragment)


def test_a_track_or_train_option_naming_no_file_names_the_option(tmp_path):
    """`solve`, `pareto` and `compare --track nope.yaml` name the option as a study file names its
    field ('s.yaml: track: 'missing.yaml': file not found'): 'command line: --track: nope.yaml: file not found'."""
    for command in ("solve", "pareto", "compare"):
        r = run(command, "--track", tmp_path / "nope.yaml", "--train", METRO, "--out", tmp_path / command)
        assert_one_line_error(r, f"command line: --track: {tmp_path / 'nope.yaml'}: file not found")
    r = run("solve", "--track", AMS, "--train", tmp_path, "--out", tmp_path / "t")
    assert_one_line_error(r, f"command line: --train: {tmp_path}: a folder, not a file")


def test_a_misspelt_study_field_is_named_with_the_field_it_is_near(tmp_path):
    """'runing_time_s: unknown field' left the user to find the spelling; a near miss of a field the
    file does not give is named, as a log header's is."""
    study = write_yaml(tmp_path / "s.yaml", {"name": "s", "track": str(AMS), "train": str(METRO),
                                             "runing_time_s": 76, "points": 50})
    assert_one_line_error(run("solve", study, "--out", tmp_path / "o"),
                          f"{study}: runing_time_s: unknown field; did you mean running_time_s?")
    far = write_yaml(tmp_path / "far.yaml", {"name": "s", "track": str(AMS), "train": str(METRO),
                                             "running_time_s": 76, "colour": "red"})
    r = run("solve", far, "--out", tmp_path / "o")
    assert_one_line_error(r, f"{far}: colour: unknown field")
    assert "did you mean" not in r.output


def test_a_field_given_in_another_unit_is_one_line_naming_the_field_and_its_unit(tmp_path):
    """`mass_kg` for `mass_t` was two lines ('mass_t: missing field', 'mass_kg: unknown field'): one
    slip is one line, naming the field the file means and the unit it is in."""
    doc = load_yaml(METRO)
    doc["mass_kg"] = doc.pop("mass_t") * 1000
    train = write_yaml(tmp_path / "t.yaml", doc)
    r = run("solve", "--track", AMS, "--train", train, "--time", 80, "--out", tmp_path / "o")
    assert_one_line_error(r, f"{train}: mass_kg: unknown field; did you mean mass_t (in t, not kg)?")
    assert "missing field" not in r.output


def test_a_csv_given_as_a_track_says_the_file_is_read_as_yaml_or_json(tmp_path):
    """A track file is YAML or TTOBench JSON: a CSV given as --track (parsed as YAML, one string)
    says so, where 'expected a mapping of fields at the top level' left the user to guess why."""
    track = tmp_path / "track.csv"
    track.write_text("position_m,gradient_permille\n0,0\n500,2\n")
    r = run("solve", "--track", track, "--train", METRO, "--time", 80, "--out", tmp_path / "o")
    assert_one_line_error(r, "expected a mapping of fields at the top level (this file is read as YAML or JSON, not .csv)")
