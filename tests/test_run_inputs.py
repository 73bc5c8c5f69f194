"""Study files, timetables, tracks and output folders that `solve` and `run` once read otherwise
than written: a scenario named like the study's own case, a scenario's timing a sweep replaced, a
timetable's intermediate stops and windows, a restriction behind a train leaving an intermediate
stop, a run down a grade that needs no traction, a folder of someone else's files, a crawl asked
for, fields no case uses, an option no search reads. Each is refused in one line naming the file and field, warned of by
name, or computed as written (real loads and solves)."""
import errno
import json

import pytest
from typer.testing import CliRunner

from ecostudy.api.outcome import one_line
from ecostudy.cli import app
from ecostudy.core.defaults import DAS_TIME_LIMIT_S
from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.core.grid import make_segment
from ecostudy.core.units import KMH
from ecostudy.io import schemas
from ecostudy.io.loaders import load_train, track_from_dict
from ecostudy.io.timetable import segment_timing
from ecostudy.studies.cases import expand
from ecostudy.studies.options import das_limit

from .conftest import ROOT, STUDIES, TRACKS, TRAINS, load_yaml, write_yaml

METRO, ROKIN = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"
LINE = TRACKS / "metro_line_4stops.yaml"


def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def study(tmp_path, **fields):
    doc = {**load_yaml(STUDIES / "default.yaml"), "track": str(ROKIN), "train": str(METRO), "points": 100,
           "output": str(tmp_path / "out"), **fields}
    return write_yaml(tmp_path / "s.yaml", doc)


def test_a_scenario_named_base_is_refused(tmp_path):
    """`run` adds the study's own case as `base`: a scenario of that name made two rows of one name,
    one of them summarised (an infeasible case read `ok`, exit 0)."""
    result = run("run", study(tmp_path, scenarios=[{"name": "base", "running_time_s": 90}]), "--no-plot")
    assert result.exit_code == 2 and "scenarios[0].name: 'base' is the study's own case" in result.output, result.output


@pytest.mark.parametrize("scenario, sweep, said", [
    ({"running_time_s": 90}, {"running_time_s": [80, 85]}, "scenarios[0].running_time_s: the sweep's running_time_s"),
    ({"supplement_percent": 5}, {"running_time_s": [80]}, "scenarios[0].supplement_percent: the sweep's running_time_s"),
    ({"points": 200}, {"points": [100, 150]}, "scenarios[0].points: the sweep's points")])
def test_a_scenario_value_the_sweep_would_replace_is_refused(tmp_path, scenario, sweep, said):
    """The scenario's own 90 s was never computed: its rows ran the swept 80 and 85 s, beside the
    base case's identical rows, no word said."""
    result = run("run", study(tmp_path, scenarios=[{"name": "rt", **scenario}], sweep=sweep), "--no-plot")
    assert result.exit_code == 2 and said in result.output and "give it in one place" in result.output, result.output


def timetable(tmp_path, **fields):
    return write_yaml(tmp_path / "tt.yaml", {"name": "tt", **fields})


def test_a_timetable_with_stops_on_the_way_is_refused_for_one_run(tmp_path):
    """Noord -> Zuid with Station and Centrum timetabled on the way: one run through them, their
    55 s of dwell counted as running, `ok` (the train passed Station at 45 km/h)."""
    tt = timetable(tmp_path, stops=load_yaml(STUDIES / "timetables" / "metro_line.yaml")["stops"])
    path = study(tmp_path, track=str(LINE), timetable=str(tt), running_time_s=None, **{"from": "Noord", "to": "Zuid"})
    result = run("solve", path, "--no-plot")
    assert result.exit_code == 2, result.output
    assert f"{tt}: stops[1]: 'Station' is a stop between 'Noord' and 'Zuid' (2 in all): one run does not stop on " \
        "the way" in result.output, result.output


def test_a_timetables_arrival_window_and_windows_on_the_way_are_the_runs():
    """The arrival window is the run's window; a window on the way keeps its times since the
    departure (the timetable's are since the journey's start)."""
    tt = schemas.TimetableFile(name="tt", stops=[{"stop": "A", "departure_s": 10}, {"stop": "B", "earliest_s": 80,
                                                                                   "latest_s": 95}],
                               windows=[{"position_m": 400, "latest_s": 50}])
    timing, windows = segment_timing(tt, "A", "B", "tt.yaml")
    assert timing.window == (70, 85) and timing.running_time is None
    assert windows[0].latest_s == 40 and windows[0].position_m == 400
    departing = schemas.TimetableFile(name="tt", stops=[{"stop": "A", "departure_earliest_s": 0, "departure_latest_s": 5},
                                                        {"stop": "B", "arrival_s": 80}])
    with pytest.raises(InputError, match="stops\\[0\\]: a departure window at 'A': one run departs at a fixed time"):
        segment_timing(departing, "A", "B", "tt.yaml")


def test_a_timetables_window_is_kept_by_solve_and_refused_by_run(tmp_path):
    """The timetable's window at 400 m by 20 s: solve took the timetable's times and dropped the
    window (`ok`, passing 400 m at 38.8 s; inputs.json `windows: []`). Now solve keeps it (and says
    no run does, naming the timetable's field), run refuses it as it refuses a study's windows."""
    tt = timetable(tmp_path, stops=[{"stop": "Rokin", "departure_s": 0}, {"stop": "Centraal", "arrival_s": 80}],
                   windows=[{"position_m": 400, "latest_s": 20}])
    path = study(tmp_path, timetable=str(tt), running_time_s=None)
    solved = run("solve", path, "--no-plot")
    assert solved.exit_code == 2 and f"{tt}: windows[0].latest_s: infeasible: the fastest run passes 400 m" \
        in solved.output, solved.output
    ran = run("run", path, "--no-plot")
    assert ran.exit_code == 2 and f"{tt}: windows: `ecostudy run` does not keep timing windows" in ran.output, ran.output


def test_a_restriction_behind_an_intermediate_stop_holds_until_the_tail_leaves_it():
    """A 90 m metro leaving B (600 m) with 30 km/h from 520 to 580 m behind it: the head's limit was
    80 km/h from the start (the limit before the start taken as the start's), and the run reached
    37 km/h with its tail in the 30 km/h zone, `ok`."""
    track = track_from_dict({"name": "behind", "source": "test", "length_m": 1106, "stops": [
        {"name": "A", "position_m": 0}, {"name": "B", "position_m": 600}, {"name": "C", "position_m": 1106}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 80}, {"position_m": 520, "speed_kmh": 30},
                         {"position_m": 580, "speed_kmh": 80}]})
    train = load_train(METRO)
    limit = make_segment(track, train, "B", "C").limit
    assert list(limit.starts) == pytest.approx([0.0, 580 + train.length - 600])
    assert list(limit.values / KMH) == pytest.approx([30.0, 80.0])
    back = make_segment(track, train, "C", "A").limit  # the other way: from the track's end, nothing behind
    assert back(0.0) / KMH == pytest.approx(80.0) and back(1106 - 550) / KMH == pytest.approx(30.0)


def test_a_run_down_a_grade_without_traction_is_verified(tmp_path):
    """Down 40 per mille most of the way the optimum needs no traction: its energy errors were a
    share of a traction of 0 (-100 %, +5517 %) and a good run was flagged."""
    track = write_yaml(tmp_path / "down.yaml", {
        "name": "down", "source": "test", "length_m": 1500, "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1500}],
        "gradients": [{"position_m": 0, "gradient_permille": -40}, {"position_m": 1200, "gradient_permille": 0}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 80}]})
    result = run("solve", "--track", track, "--train", METRO, "--supplement", 40, "--points", 300, "--no-plot",
                 "--out", tmp_path / "o")
    assert result.exit_code == 0 and "traction energy       0.000 kWh" in result.output, result.output
    assert "verification      passed" in result.output


def test_a_folder_of_files_no_ecostudy_command_wrote_is_not_overwritten(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "results.csv").write_text("my,precious\n")
    result = run("run", study(tmp_path), "--no-plot", "--out", tmp_path / "mine")
    assert result.exit_code == 2 and "holds results.csv that no ecostudy command wrote" in result.output, result.output
    assert (tmp_path / "mine" / "results.csv").read_text() == "my,precious\n"


def test_a_full_disk_is_said_as_such():
    text, code = one_line(OSError(errno.ENOSPC, "No space left on device", "out/s/report.html"))
    assert code == 3 and text.startswith("out/s/report.html: cannot write: No space left on device") and \
        "internal error" not in text


def test_a_crawl_is_refused_and_unused_fields_are_named(tmp_path):
    crawl = run("solve", "--track", ROKIN, "--train", METRO, "--objective", "mixed", "--weights", "0,1", "--no-plot",
                "--out", tmp_path / "o")
    assert crawl.exit_code == 2 and "--weights: a time weight of 0 with no running time" in crawl.output, crawl.output
    path = study(tmp_path, weights={"time": 5, "energy": 0.1}, das_time_limit_s=5)
    with pytest.warns(EcostudyWarning) as caught:
        expand(path)
    said = [str(w.message) for w in caught]
    assert f"{path}: weights: read but not used: no case has objective mixed" in said, said
    assert f"{path}: das_time_limit_s: read but not used: no case has das: minlp" in said, said


def test_mixed_weights_no_run_can_be_ok_with_are_refused_and_a_crawl_is_capped(tmp_path):
    """An energy weight of 0 left the running time alone without the all-out run's regularisation:
    71.73 s with traction and braking at once, flagged at -31 % energy error; a study's weights
    {time: 0, energy: 0} were accepted where --weights 0,0 is refused; --weights 1e-9,1 solved a run
    of 97860 s (27 h) flagged 1057 m short. The energy weight of 0 and the pair of zeros are refused
    before computing; the time the weights choose is capped at 5 times the fastest envelope's, and a
    run at the cap is flagged."""
    out = ("--no-plot", "--points", 100, "--out", tmp_path / "o")
    r = run("solve", "--track", ROKIN, "--train", METRO, "--objective", "mixed", "--weights", "1,0", *out)
    assert r.exit_code == 2 and r.output.startswith("error: command line: --weights: an energy weight of 0 leaves the "
                                                    "running time alone to minimise"), r.output
    zeros = study(tmp_path, objective="mixed", weights={"time": 0, "energy": 0}, running_time_s=None, window_s=[70, 100])
    for command in ("solve", "run"):
        r = run(command, zeros, "--no-plot")
        assert r.exit_code == 2 and f"{zeros}: weights: must be two weights >= 0, not both 0" in r.output, \
            (command, r.output)
    energy0 = study(tmp_path, objective="mixed", weights={"time": 1, "energy": 0}, running_time_s=None, window_s=[70, 100])
    for command in ("solve", "run"):
        r = run(command, energy0, "--no-plot")
        assert r.exit_code == 2 and f"{energy0}: weights.energy: an energy weight of 0" in r.output, (command, r.output)
    assert not (tmp_path / "o").exists() and not (tmp_path / "out").exists()
    # an energy weight the NLP cannot tell from 0 (1e-6: 71.73 s, 12.346 kWh, flagged at -12 % energy
    # error; 1e-4: the same time, 10.859 kWh, ok): refused before computing, by the train's and line's scale
    r = run("solve", "--track", ROKIN, "--train", METRO, "--objective", "mixed", "--weights", "1,1e-6", *out)
    assert r.exit_code == 2 and r.output.startswith("error: command line: --weights: an energy weight 1e-06 times the "
                                                    "time weight is below the 4.3e-05 that prices energy"), r.output
    tiny = study(tmp_path, objective="mixed", weights={"time": 1, "energy": 1e-6}, running_time_s=None, window_s=[70, 100])
    r = run("solve", tiny, "--no-plot")
    assert r.exit_code == 2 and f"{tiny}: weights.energy: an energy weight 1e-06 times" in r.output, r.output
    assert not (tmp_path / "o").exists() and not (tmp_path / "out").exists()
    r = run("solve", "--track", ROKIN, "--train", METRO, "--objective", "mixed", "--weights", "1e-9,1", *out)
    assert r.exit_code == 1 and "flagged: Rokin-Centraal: the mixed objective's weights take the running time to its " \
        "cap, 358.1 s (5 times the fastest possible run's, kinematic envelope): the train would crawl" in r.output, r.output
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["running_time_s"] == pytest.approx(summary["time_cap_s"], rel=1e-6) and summary["verification"]["passed"]
    r = run("solve", "--track", ROKIN, "--train", METRO, "--objective", "mixed", *out)  # weights 1,1: under the cap
    assert r.exit_code == 0 and json.loads((tmp_path / "o" / "summary.json").read_text())["running_time_s"] < 120, r.output


def test_a_climb_the_train_cannot_make_names_the_track(tmp_path):
    track = write_yaml(tmp_path / "steep.yaml", {
        "name": "steep", "source": "test", "length_m": 1106, "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1106}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}, {"position_m": 300, "gradient_permille": 100},
                      {"position_m": 700, "gradient_permille": 0}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 80}]})
    heavy = write_yaml(tmp_path / "heavy.yaml", {**load_yaml(METRO), "mass_t": 300, "effective_mass_t": 320})
    result = run("solve", "--track", track, "--train", heavy, "--supplement", 10, "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 2 and f"{track}: gradients: infeasible: the train cannot climb" in result.output, \
        result.output


def test_a_train_too_weak_to_start_on_a_flat_track_names_the_trains_traction(tmp_path):
    """2 kN of traction against 3 kN of running resistance on a flat track: the line adds nothing,
    so the train file's traction is named, not the track's gradients."""
    track = write_yaml(tmp_path / "flat.yaml", {
        "name": "flat", "source": "test", "length_m": 1000, "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1000}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}], "speed_limits": [{"position_m": 0, "speed_kmh": 72}]})
    tiny = write_yaml(tmp_path / "tiny.yaml", {
        "name": "tiny", "source": "test", "mass_t": 100, "rotating_mass_factor": 0.1, "length_m": 0,
        "davis": {"a_N": 3000, "b_N_per_mps": 0, "c_N_per_mps2": 0}, "traction": {"max_force_kN": 2},
        "braking": {"max_force_kN": 100}, "traction_efficiency": 0.8})
    result = run("solve", "--track", track, "--train", tiny, "--objective", "time", "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 2 and result.output.startswith(
        f"error: {tiny}: traction: infeasible: the train cannot overcome its running resistance"), result.output


def test_a_published_train_too_weak_to_start_is_named_by_its_own_field(tmp_path):
    """TTOBench's Beijing subway train with 1 kN of traction: its file's 'max traction force' is named
    (the YAML's 'traction' is no field of that file)."""
    doc = json.loads((ROOT / "tests/data/ttobench_subway_train.json").read_text())
    doc["max traction force"]["value"] = 1.0
    weak = tmp_path / "weak.json"
    weak.write_text(json.dumps(doc))
    result = run("solve", "--track", ROKIN, "--train", weak, "--supplement", 10, "-K", 60, "--no-plot",
                 "--out", tmp_path / "o")
    assert result.exit_code == 2 and result.output.startswith(
        f"error: {weak}: max traction force: infeasible: the train cannot overcome its running resistance"), result.output


def test_a_das_time_limit_no_search_reads_is_named(tmp_path):
    """`--das-time-limit` bounds the MINLP search only; given with `--das phases` (or no advice) it
    was dropped without a word (the command line's default could not tell it was given)."""
    with pytest.warns(EcostudyWarning, match="--das-time-limit: bounds the minlp search only: unused with --das phases"):
        assert das_limit("phases", 5) == 5.0
    assert das_limit("minlp", None) == DAS_TIME_LIMIT_S and das_limit(None, None) == DAS_TIME_LIMIT_S
    result = run("solve", STUDIES / "default.yaml", "--das-time-limit", 5, "--points", 100, "--no-plot",
                 "--out", tmp_path / "o")
    assert "warning: command line: --das-time-limit: bounds the minlp search only: unused with no --das" \
        in result.output, result.output


def test_a_default_output_folder_stays_one_folder_under_out():
    """A stop named '/../../../escaped' wrote outside out/; a '/' in a name made nested folders."""
    from ecostudy.io.writers import default_output

    assert default_output("/../../../escaped_Centraal") == default_output("escaped_Centraal")
    for name in ("/../../../escaped_Centraal", "track_<b>Rökin</b>_&_Co", "..", "a b/c"):
        folder = default_output(name)
        assert folder.parent.name == "out" and len(folder.parts) == 2 and folder.name not in ("", ".", ".."), folder


def test_mixed_weights_decide_by_their_ratio_however_small_both_are(tmp_path):
    """Weights 1e-12,1e-12 weigh as 1,1 do: the objective scaled up with them (it was 1e-12 of O(1):
    177.99 s, re-simulated energy -87 %, flagged)."""
    runs = []
    for w in ("1,1", "1e-12,1e-12"):
        ran = CliRunner().invoke(app, ["solve", "--track", str(ROKIN), "--train", str(METRO), "-K", "100", "--objective",
                                       "mixed", "--weights", w, "--no-plot", "--out", str(tmp_path / w)])
        assert ran.exit_code == 0, ran.output
        runs.append(json.loads((tmp_path / w / "summary.json").read_text()))
    assert runs[1]["status"] == "ok" and runs[1]["running_time_s"] == pytest.approx(runs[0]["running_time_s"], rel=1e-6)
