"""Hostile copies of the shipped study files of ``network``, ``simulate`` and ``heavyhaul``, and
damaged solve folders for ``export``, through the command line: one line naming the file and the
field, exit status 2, before anything is computed (no output folder, no store)."""
import json
import shutil

import pytest
import yaml
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"


def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def refused(result, *fragments):
    """Exit 2, exactly one error line holding every fragment, no traceback."""
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def hostile(tmp_path, shipped, **changes):
    """A copy of ``studies/<shipped>`` with ``changes`` (None: the field removed), its files absolute,
    its output in ``tmp_path/out``."""
    doc = load_yaml(STUDIES / shipped)
    for key in ("track", "train", "consist"):
        if key in doc:
            doc[key] = str((STUDIES / doc[key]).resolve())
    if isinstance(doc.get("reference"), dict) and "table" in doc["reference"]:
        shutil.copy(STUDIES / doc["reference"]["table"], tmp_path)
    doc["output"] = str(tmp_path / "out")
    for key, value in changes.items():
        if value is None:
            doc.pop(key, None)
        else:
            doc[key] = value
    return write_yaml(tmp_path / f"hostile_{shipped}", doc)


def nothing_written(tmp_path):
    """No output folder: not even an empty one (an infeasible running time is found after the folder was checked)."""
    assert not (tmp_path / "out").exists()


def swapped(lines, a, b):
    lines = list(lines)
    lines[a], lines[b] = lines[b], lines[a]
    return lines


def named_cell(lines, row, column, value):
    cells = lines[row].split(",")
    cells[lines[0].split(",").index(column)] = value
    return lines[:row] + [",".join(cells)] + lines[row + 1:]


def scaled_cell(lines, row, column, factor):
    value = float(lines[row].split(",")[lines[0].split(",").index(column)])
    return named_cell(lines, row, column, f"{value * factor:.6g}")


def first_cell(lines, row, value):
    return lines[:row] + [",".join([value] + lines[row].split(",")[1:])] + lines[row + 1:]


# ----------------------------------------------------------------------------------- the file itself
@pytest.mark.parametrize("command", ["network", "simulate", "heavyhaul"])
def test_a_folder_given_as_the_study_file_is_named_a_folder(tmp_path, command):
    refused(run(command, tmp_path, "--workers", 1), str(tmp_path), "a folder, not a file")


# ----------------------------------------------------------------------------------- checks across fields
@pytest.mark.parametrize("shipped, changes, fragment", [
    ("metro_monte_carlo.yaml", {"controllers": [{"name": "a", "kind": "ato"}, {"name": "a", "kind": "ato"}]},
     "controllers: names must be unique ('a' given twice)"),
    ("metro_monte_carlo.yaml", {"window_s": [76, 0]}, "window_s: must be [earliest, latest]"),
    ("metro_monte_carlo.yaml", {"window_s": [0, 5], "controllers": [{"name": "s", "kind": "sbpc", "sample_time_s": 6}]},
     "controllers[0].sample_time_s: must be shorter than the latest arrival"),
    ("network_metro_2trains.yaml", {"trains": [{"name": "T1", "offset_s": 0}, {"name": "T1", "offset_s": 120}]},
     "trains: names must be unique ('T1' given twice)"),
    ("network_metro_2trains.yaml", {"buffer_m": None}, "buffer_m: the following strategy needs it"),
    ("heavyhaul_fence.yaml", {"brake_penalty": [40, -1]}, "brake_penalty[1]: Input should be greater than or equal to 0"),
    ("heavyhaul_fence.yaml", {"fence": [10, 0]}, "fence[1]: Input should be greater than or equal to 1"),
    # a tolerance of 1e9 m switched the stop check off
    ("heavyhaul_fence.yaml", {"stop_tolerance_m": 1e9}, "stop_tolerance_m: Input should be less than or equal to 100"),
    ("heavyhaul_fence.yaml", {"speed_tolerance_kmh": 1e9}, "speed_tolerance_kmh: Input should be less than or equal to 50"),
    ("heavyhaul_fence.yaml", {"reference": {"running_time_s": 1}},
     "reference.running_time_s: infeasible: the fastest possible run takes"),
    ("network_metro_2trains.yaml", {"supplement_percent": None, "running_times_s": [10, 90, 90]},
     "running_times_s: [0] Noord -> Station: infeasible: the fastest possible run takes"),
    ("network_metro_2trains.yaml", {"strategies": ["independent", "joint", "independent"]},
     "strategies: names must be unique ('independent' given twice)"),
    ("metro_monte_carlo.yaml", {"controllers": [{"name": "s", "kind": "sbpc", "delay_samples": 3}]},
     "controllers[0]: delay_samples: the driver's reaction delay acts on the DAS levels only"),
])
def test_a_check_across_fields_names_its_field(tmp_path, shipped, changes, fragment):
    command = {"metro": "simulate", "netwo": "network", "heavy": "heavyhaul"}[shipped[:5]]
    line = refused(run(command, hostile(tmp_path, shipped, **changes), "--workers", 1, "--no-plot"), fragment)
    assert "(top level)" not in line
    nothing_written(tmp_path)


# ----------------------------------------------------------------------------------- a file named by a study, not there
@pytest.mark.parametrize("command, shipped, field, changes", [
    ("solve", "default.yaml", "track", {"track": "missing.yaml"}),
    ("solve", "default.yaml", "train", {"train": "missing.yaml"}),
    ("solve", "regional_80s.yaml", "timetable", {"timetable": "missing.yaml"}),
    ("pareto", "default.yaml", "train", {"train": "missing.yaml"}),
    ("compare", "default.yaml", "track", {"track": "missing.yaml"}),
    ("run", "regional_80s.yaml", "timetable", {"timetable": "missing.yaml"}),
    ("run", "metro_supplements.yaml", "scenarios[0].track", {"scenarios": [{"name": "x", "track": "missing.yaml"}]}),
    ("network", "network_metro_2trains.yaml", "track", {"track": "missing.yaml"}),
    ("network", "network_metro_2trains.yaml", "train", {"train": "missing.yaml"}),
    ("simulate", "metro_monte_carlo.yaml", "train", {"train": "missing.yaml"}),
    ("simulate", "metro_monte_carlo.yaml", "track", {"track": "missing.yaml"}),
    ("heavyhaul", "heavyhaul_fence.yaml", "consist", {"consist": "missing.yaml"}),
    ("heavyhaul", "heavyhaul_fence.yaml", "track", {"track": "missing.yaml"}),
    ("heavyhaul", "heavyhaul_brake_penalty_rolling.yaml", "reference.table", {"reference": {"table": "missing.csv"}}),
])
def test_a_file_named_by_a_study_that_is_not_there_names_the_field(tmp_path, command, shipped, field, changes):
    name = next(iter(changes.values()))
    name = name if isinstance(name, str) else "missing.csv" if "reference" in changes else "missing.yaml"
    path = hostile(tmp_path, shipped, **changes)
    options = {"solve": ["--no-plot"], "run": ["--workers", 1]}.get(command, ["--workers", 1, "--no-plot"])
    line = refused(run(command, path, *options),
                   f"{path}: {field}: '{name}': file not found ({tmp_path / name})")
    assert line.count("file not found") == 1
    nothing_written(tmp_path)


def test_a_folder_named_as_a_study_file_field_is_named_a_folder(tmp_path):
    (tmp_path / "tracks").mkdir()
    path = hostile(tmp_path, "network_metro_2trains.yaml", track="tracks")
    refused(run("network", path, "--workers", 1, "--no-plot"), f"{path}: track: 'tracks': a folder, not a file")


# ----------------------------------------------------------------------------------- an infeasible running time
@pytest.mark.parametrize("args", [
    ["solve", STUDIES / "default.yaml", "--time", 10, "--no-plot"],
    ["journey", "--train", METRO, "--track", TRACKS / "metro_line_4stops.yaml", "--time", 10, "--no-plot"],
])
def test_an_infeasible_running_time_leaves_no_output_folder(tmp_path, args):
    refused(run(*args, "--out", tmp_path / "out" / "nested"), "infeasible: ")
    nothing_written(tmp_path)


def test_an_infeasible_solve_names_where_its_time_was_given(tmp_path):
    """The study file's field, or the command line's option, that asked for the impossible time."""
    path = hostile(tmp_path, "default.yaml", running_time_s=10)
    refused(run("solve", path, "--no-plot"), f"{path}: running_time_s: infeasible: the fastest possible run takes")
    nothing_written(tmp_path)
    refused(run("solve", STUDIES / "default.yaml", "--supplement", 0, "--time", 10, "--no-plot", "--out", tmp_path / "out"),
            "--time")  # two timings: refused before any solve
    refused(run("solve", STUDIES / "default.yaml", "--time", 10, "--no-plot", "--out", tmp_path / "out"),
            "command line: --time: infeasible: the fastest possible run takes")


# ----------------------------------------------------------------------------------- values out of range
@pytest.mark.parametrize("shipped, changes, fragment", [
    ("network_metro_2trains.yaml", {"dwell_s": 1e9}, "dwell_s: Input should be less than or equal to 86400"),
    ("network_metro_2trains.yaml", {"supplement_percent": None, "running_times_s": [-80, 90, 90]},
     "running_times_s[0]: Input should be greater than 0"),
    ("network_metro_2trains.yaml", {"train": ""}, "train: an empty name"),
    ("network_metro_2trains.yaml", {"buffer_m": 1e12}, "buffer_m: 1e+12 m is not shorter than the line"),
    ("heavyhaul_brake_penalty_rolling.yaml", {"consist": " "}, "consist: an empty name"),
    ("heavyhaul_fence.yaml", {"brake_penalty": [1e300]}, "brake_penalty[0]: Input should be less than or equal to 10000"),
    ("heavyhaul_fence.yaml", {"weights": {"speed": 1e300}}, "weights.speed: Input should be less than or equal to 10000"),
    ("network_metro_2trains.yaml", {"substation": {"position_m": 1e9}}, "substation.position_m: 1e+09 m is off the line"),
    ("metro_monte_carlo.yaml", {"deviations": {"mass": {"low": 0.9, "high": 1e6}}},
     "deviations.mass.high: Input should be less than or equal to 10"),
    ("metro_monte_carlo.yaml", {"controllers": [{"name": "s", "kind": "sbpc", "block": 10**9, "sample_time_s": 0.38}]},
     "controllers[0].block: 1000000000 samples a move is more than the run's 200"),
    ("heavyhaul_brake_penalty_rolling.yaml", {"sample_time_s": 1e-6},
     "max_samples: 1000 samples of 1e-06 s (sample_time_s) end 0.001 s in, before the reference's"),
    ("heavyhaul_brake_penalty_rolling.yaml", {"fence": [1], "horizons": [{"np": 100, "nc": 100}]},
     "horizons: Kb=1 f=1 Np=100 Nc=100: 20,400 QP inputs (virtual cars x Nc) a sample"),
])
def test_values_no_run_can_use_are_refused_before_computing(tmp_path, shipped, changes, fragment):
    command = {"metro": "simulate", "netwo": "network", "heavy": "heavyhaul"}[shipped[:5]]
    refused(run(command, hostile(tmp_path, shipped, **changes), "--workers", 1, "--no-plot"), fragment)
    nothing_written(tmp_path)


@pytest.mark.parametrize("where, fragment", [
    ("override", "scenarios[0].train_overrides.length_m: scenario 'long': train 'Amsterdam metro (Alstom, Rokin-Centraal case)': "
                 "length_m: 1e+308 m is longer than the track 'Amsterdam metro Rokin - Centraal' (1106 m)"),
    ("scenario train", "scenarios[0].train: scenario 'long': train 'Amsterdam metro (Alstom, Rokin-Centraal case)': "
                       "length_m: 5000 m is longer than the track"),
    ("base train", "hostile_default.yaml: train: train 'Amsterdam metro (Alstom, Rokin-Centraal case)': length_m: 5000 m"),
])
def test_a_train_longer_than_its_track_is_refused_before_computing(tmp_path, where, fragment):
    """`ecostudy run`: a scenario whose train (its overrides or its file) is longer than the track is
    refused in one line naming the study file, the scenario and the field; no case is computed."""
    long_train = write_yaml(tmp_path / "long.yaml", {**load_yaml(METRO), "length_m": 5000})
    changes = {"override": {"scenarios": [{"name": "long", "train_overrides": {"length_m": 1e308}}]},
               "scenario train": {"scenarios": [{"name": "long", "train": str(long_train)}]},
               "base train": {"train": str(long_train)}}[where]
    line = refused(run("run", hostile(tmp_path, "default.yaml", **changes), "--workers", 1, "--no-progress"), fragment)
    assert "hostile_default.yaml" in line, line
    nothing_written(tmp_path)


# ----------------------------------------------------------------------------------- a heavy-haul reference table
def reference_study(tmp_path, edit):
    path = hostile(tmp_path, "heavyhaul_brake_penalty_rolling.yaml")
    table = tmp_path / "heavyhaul_rolling_reference.csv"
    table.write_text("\n".join(edit(table.read_text().splitlines())) + "\n")
    return path


@pytest.mark.parametrize("edit, fragment", [
    (lambda ls: swapped(ls, 3, 6), "heavyhaul_rolling_reference.csv: distance_m, row 5: 150 after 250: the distances "
                                   "must increase"),
    (lambda ls: first_cell(ls, 5, ls[4].split(",")[0]), "distance_m, row 6: 150 after 150"),
    (lambda ls: ls[:3] + [ls[3].split(",")[0] + ",-11"] + ls[4:], "speed_kmh, row 4: -11 is below 0"),
    (lambda ls: ls[:2] + [ls[2].split(",")[0] + ",0"] + ls[3:], "speed_kmh, row 3: 0 after 0: the speed may be 0 "
                                                                "only at single points"),
])
def test_a_reference_table_out_of_order_names_its_row(tmp_path, edit, fragment):
    refused(run("heavyhaul", reference_study(tmp_path, edit), "--workers", 1, "--no-plot"), fragment)
    nothing_written(tmp_path)


def test_a_reference_table_column_not_read_is_warned(tmp_path):
    from ecostudy.studies.heavyhaul import expand
    path = reference_study(tmp_path, lambda ls: [ls[0] + ",note"] + [line + ",x" for line in ls[1:]])
    with pytest.warns(UserWarning, match="heavyhaul_rolling_reference.csv: note: not read"):
        expand(path)


# ----------------------------------------------------------------------------------- resuming into another study's folder
@pytest.mark.parametrize("command, shipped, changes", [
    ("network", "network_metro_2trains.yaml", {}),
    ("simulate", "metro_monte_carlo.yaml", {"controllers": [{"name": "a", "kind": "ato"}], "draws": 1}),
    ("heavyhaul", "heavyhaul_brake_penalty_rolling.yaml", {}),
])
def test_an_out_folder_holding_another_study_is_refused_before_computing(tmp_path, command, shipped, changes):
    from ecostudy.io.store import Store
    other = tmp_path / "other"
    store = Store(other / "results.sqlite")
    store.put({"key": "k", "study": "someone_else", "scenario": "s", "labels": {}}, {"status": "ok", "summary": {}})
    store.close()
    refused(run(command, hostile(tmp_path, shipped, **changes), "--workers", 1, "--no-plot", "--out", other),
            str(other), "--out: holds the results of another study ('someone_else')")
    store = Store(other / "results.sqlite")
    assert store.finished_keys() == {"k"} and not (other / "summary.json").exists()
    store.close()


def test_an_out_folder_holding_another_commands_results_is_refused_before_computing(tmp_path):
    """A solve's folder given to compare, pareto or run: refused in one line (their
    tables and summary.json would be written beside the solve's and read as one); the folder unchanged;
    the same command again is not refused."""
    out = tmp_path / "solved"
    assert run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 30, "--no-plot",
               "--out", out).exit_code == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    study = STUDIES / "default.yaml"
    for command, kind in ((["compare", study], "compare"), (["pareto", study, "--count", 3], "pareto"),
                          (["run", study], "run")):
        refused(run(*command, "--no-plot" if kind != "run" else "--no-progress", "--out", out),
                str(out), "--out: holds the results of `ecostudy solve` (its summary.json), "
                f"not of `ecostudy {kind}`")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 30, "--no-plot",
               "--out", out).exit_code == 0


# ----------------------------------------------------------------------------------- export
@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    out = tmp_path_factory.mktemp("saved") / "run"
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 30, "--das", "round", "--no-plot",
            "--out", out)
    assert r.exit_code in (0, 1) and (out / "advice.csv").is_file(), r.output
    return out


def damaged(saved, tmp_path, name, edit):
    folder = tmp_path / "copy"
    shutil.copytree(saved, folder)
    lines = (folder / name).read_text().splitlines()
    (folder / name).write_text("\n".join(edit(lines)) + "\n")
    return folder


@pytest.mark.parametrize("every, fragments", [
    ("0.0000000001s", ["--every", "a step of 1e-10 s over the run", "rows, above the 1,000,000 exported"]),
    ("0.00000001m", ["--every", "rows, above the 1,000,000 exported"]),
])
def test_export_refuses_a_step_too_small_with_its_row_count(saved, every, fragments):
    refused(run("export", saved, "--every", every), *fragments)


@pytest.mark.parametrize("name, edit, fragments", [
    ("profile.csv", lambda ls: swapped(ls, 4, 11), ["profile.csv: position_m, row 6", "the rows must increase"]),
    ("advice.csv", lambda ls: first_cell(ls, 1, "here"), ["advice.csv: start_position_m, row 2", "'here'"]),
    ("advice.csv", lambda ls: first_cell(ls, 2, "nan"), ["advice.csv: start_position_m, row 3", "'nan'"]),
    # the advised mode went to on-board systems as written, whatever its handle said
    ("advice.csv", lambda ls: named_cell(ls, 1, "mode", "full service braking"),
     ["advice.csv: mode, row 2", "'full service braking' is not the mode of handle 1 ('full traction')"]),
    ("advice.csv", lambda ls: named_cell(ls, 2, "mode", "traction 80 %"), ["advice.csv: mode, row 3", "handle 0.5"]),
    # a negative speed was exported; a summary that is no mapping was blamed on inputs.json
    ("profile.csv", lambda ls: named_cell(ls, 5, "speed_kmh", "-5"), ["profile.csv: speed_kmh, row 6", "-5 is below 0"]),
    ("profile.csv", lambda ls: named_cell(ls, 3, "braking_force_kN", "-20"), ["braking_force_kN, row 4", "below 0"]),
    ("summary.json", lambda ls: ["[1, 2]"], ["summary.json: not a result folder", "expected a mapping"]),
    # a speed or a time edited after the solve was exported under the saved run's status
    ("profile.csv", lambda ls: scaled_cell(ls, 15, "speed_kmh", 1.05), ["profile.csv: position_m, time_s, speed_kmh, rows 15-16",
                                                                        "an edited profile"]),
    ("profile.csv", lambda ls: scaled_cell(ls, 15, "time_s", 1.001), ["profile.csv: position_m, time_s, speed_kmh, rows 15-16"]),
])
def test_export_refuses_a_damaged_folder_in_one_line(saved, tmp_path, name, edit, fragments):
    folder = damaged(saved, tmp_path, name, edit)
    refused(run("export", folder), *fragments)
    assert not list(folder.glob("profile_every_*"))


def exported_exit(saved):
    """The export's exit status: 0 for a run that is ok, else 1 (the coarse grid's rounded advice
    may be flagged)."""
    return 0 if json.loads((saved / "summary.json").read_text())["status"] == "ok" else 1


def test_export_of_an_intact_folder_still_writes(saved):
    r = run("export", saved, "--every", "10m")
    assert r.exit_code == exported_exit(saved) and (saved / "profile_every_10m.csv").is_file(), r.output
    rows = yaml.safe_load((saved / "profile_every_10m.json").read_text())["rows"]
    assert len(rows) > 10


def test_export_reads_a_step_in_exponent_notation(saved):
    """'2.5e1m' is the 25 m step it says, written under the step's own name."""
    r = run("export", saved, "--every", "2.5e1m")
    assert r.exit_code == exported_exit(saved) and (saved / "profile_every_25m.csv").is_file(), r.output
    rows = yaml.safe_load((saved / "profile_every_25m.json").read_text())["rows"]
    assert len(rows) > 10 and abs(rows[1]["position_m"] - rows[0]["position_m"] - 25.0) < 1e-9


# ----------------------------------------------------------------------------------- the output folder, first
def _never(*args, **kwargs):
    raise AssertionError("computed before the output folder was checked")


@pytest.mark.parametrize("command, shipped, long_step", [
    (["heavyhaul"], "heavyhaul_brake_penalty.yaml", ("ecostudy.studies.heavyhaul", "_reference")),
    (["run", "--kind", "heavyhaul"], "heavyhaul_brake_penalty.yaml", ("ecostudy.studies.heavyhaul", "_reference")),
    (["simulate"], "yazhemsky2017_closed_loop.yaml", ("ecostudy.studies.closedloop", "all_out_time")),
    (["run", "--kind", "simulate"], "yazhemsky2017_closed_loop.yaml", ("ecostudy.studies.closedloop", "all_out_time")),
    (["network"], "network_metro_2trains.yaml", ("ecostudy.network.fleet", "plan")),
    (["run", "--kind", "network"], "network_metro_2trains.yaml", ("ecostudy.network.fleet", "plan")),
])
def test_an_output_folder_that_is_a_file_is_refused_before_the_study_computes(tmp_path, monkeypatch, command, shipped,
                                                                              long_step):
    """The reference run, the all-out run or the fleet's first runs (seconds to minutes) were solved
    before a --out that is a file was refused; the long step here raises if it is reached."""
    import importlib
    monkeypatch.setattr(importlib.import_module(long_step[0]), long_step[1], _never)
    afile = tmp_path / "afile"
    afile.write_text("x")
    refused(run(*command, STUDIES / shipped, "--out", afile, "--workers", 1), "afile", "the output folder is a file")


def test_every_network_segment_no_run_keeps_is_named(tmp_path):
    """Three segments too fast: only the first was named, without its index (fix, run, fix...)."""
    result = run("network", hostile(tmp_path, "network_metro_2trains.yaml", supplement_percent=None,
                                    running_times_s=[30, 60, 40]), "--workers", 1, "--no-plot")
    lines = [x for x in result.output.splitlines() if x.startswith("error:")]
    assert result.exit_code == 2 and len(lines) == 3, result.output
    for k, pair in enumerate(("Noord -> Station", "Station -> Centrum", "Centrum -> Zuid")):
        assert f"running_times_s: [{k}] {pair}: infeasible: the fastest possible run takes" in lines[k], lines
    nothing_written(tmp_path)
