"""A solve folder is one run or none, and a field of it edited by hand is refused, not passed on as
ok: what `ecostudy check`, `ecostudy export` and `api.load` accept (docs/results.md, "What check
verifies"). Every folder is a real K <= 200 solve of the Amsterdam metro, Rokin -> Centraal."""
import dataclasses
import json
import re
import shutil

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy import api
from ecostudy.cli import app
from ecostudy.io.folder import write_summary

from .conftest import TRACKS, TRAINS, solve_written

TRACK, TRAIN = TRACKS / "amsterdam_rokin_centraal.yaml", TRAINS / "amsterdam_metro.yaml"
SOLVE = ["solve", "--track", str(TRACK), "--train", str(TRAIN), "--no-plot"]


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    """An 80 s run at K = 200 as `ecostudy solve` writes it (copied by each test that edits it)."""
    out = tmp_path_factory.mktemp("solved") / "run"
    r = CliRunner().invoke(app, [*SOLVE, "--time", "80", "--points", "200", "--out", str(out)])
    assert r.exit_code == 0, r.output
    return out


def _copy(solved, tmp_path):
    return shutil.copytree(solved, tmp_path / "run")


def _refused_everywhere(out, fragment):
    """check, export and api.load each refuse the folder in one line containing ``fragment``."""
    for command in ("check", "export"):
        r = CliRunner().invoke(app, [command, str(out)])
        assert r.exit_code == 2 and fragment in r.output and "Traceback" not in r.output, (command, r.output)
        assert r.output.count("\n") == 1, r.output
    with pytest.raises(api.InputError, match=re.escape(fragment)):
        api.load(out)


def _edit_column(out, column, edit):
    profile = pd.read_csv(out / "profile.csv")
    profile[column] = edit(profile[column])
    profile.to_csv(out / "profile.csv", index=False, float_format="%.6g")


@pytest.mark.parametrize("column, edit, fragment", [
    ("cumulative_energy_kWh", lambda c: c.where(c.index < len(c) - 1, 3.5),
     "profile.csv: cumulative_energy_kWh, row 201: 3.5 kWh, but the row's forces, speeds and positions give 4.88"),
    ("cumulative_energy_kWh", lambda c: c * 0.7, "profile.csv: cumulative_energy_kWh, row 3: "),
    ("power_kW", lambda c: c * 0.5, "profile.csv: power_kW, row 2: "),
])
def test_an_edited_energy_or_power_column_is_refused_by_check_export_and_load(solved, tmp_path, column, edit, fragment):
    """cumulative_energy_kWh and power_kW are what the traction forces, speeds and positions give,
    to the six digits written: halved, scaled or a last row edited, the profile is refused (check
    and export said ok, api.load ok, a report showed 4.886 kWh beside 2.443)."""
    out = _copy(solved, tmp_path)
    _edit_column(out, column, edit)
    _refused_everywhere(out, fragment)


def test_a_costate_column_with_its_signs_turned_is_refused_by_check_and_export(solved, tmp_path):
    """costate_ratio is Ipopt's psi: negated, its agreement with the regimes of the profile's forces
    falls from the 100 % summary.json records (it passed check as ok)."""
    out = _copy(solved, tmp_path)
    _edit_column(out, "costate_ratio", lambda c: -c)
    for command in ("check", "export"):
        r = CliRunner().invoke(app, [command, str(out)])
        assert r.exit_code == 2 and "profile.csv: costate_ratio: gives agreement_pct 1.5 against the regimes of the " \
            "profile's forces, but summary.json's pontryagin.agreement_pct is 100.0" in r.output, r.output


def test_a_saved_run_is_the_folder_solve_writes_and_never_mixes_two_runs(solved, tmp_path):
    """Solution.save writes inputs.json (what `ecostudy solve` writes for the same run, by the same
    writer), so check and export read it; saved over an 80 s solve folder it replaces that run
    whole; a folder of another command, a file, and a run of a train changed in code are refused
    in one line (save wrote no inputs.json, kept the 80 s inputs.json, replaced a pareto folder's
    summary, raised NotADirectoryError)."""
    track, train = api.load_track(TRACK), api.load_train(TRAIN)
    run = api.solve(track, train, running_time=80.0, points=200)
    run.save(tmp_path / "saved", plot=False)
    assert json.loads((tmp_path / "saved" / "inputs.json").read_text()) == json.loads((solved / "inputs.json").read_text())
    assert api.check_folder(tmp_path / "saved").ok and api.export_folder(tmp_path / "saved", "1s").ok
    later = api.solve(track, train, running_time=90.0, points=100)
    over = _copy(solved, tmp_path)
    later.save(over, plot=False)
    assert json.loads((over / "inputs.json").read_text())["timing"]["running_time_s"] == 90.0
    assert str(api.load(over).status) == "ok" and api.check_folder(over).ok
    write_summary(tmp_path / "front", "pareto", {"a": api.Status("ok")})
    with pytest.raises(api.InputError, match=r"front: --out: holds the results of `ecostudy pareto` \(its summary"):
        run.save(tmp_path / "front", plot=False)
    assert json.loads((tmp_path / "front" / "summary.json").read_text())["kind"] == "pareto"
    (tmp_path / "afile").write_text("mine")
    with pytest.raises(api.InputError, match="afile: the output folder is a file$"):
        run.save(tmp_path / "afile")
    heavier = api.solve(track, dataclasses.replace(train, mass=train.mass * 1.2), running_time=90.0, points=100)
    with pytest.raises(api.InputError, match="^arguments: train: built in code .*api.load_train$"):
        heavier.save(tmp_path / "heavier", plot=False)
    assert not (tmp_path / "heavier").exists()


def test_a_write_that_fails_midway_leaves_a_folder_no_reader_takes_for_a_run(solved, tmp_path):
    """A folder where an earlier run's export is to be removed stops the write of an 85 s, K = 100
    run over the 80 s one after it began: one line naming it, exit 2 (an internal error, exit 3,
    left the new inputs.json beside the old profile and summary, which api.load called ok). The
    folder is marked unfinished: api.load, check and export refuse it; solved again once the folder
    is gone, it is the new run whole."""
    out = _copy(solved, tmp_path)
    (out / "profile_every_1s.csv").mkdir()
    r = CliRunner().invoke(app, [*SOLVE, "--time", "85", "--points", "100", "--out", str(out)])
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert r.output.splitlines()[-1] == (f"error: {out / 'profile_every_1s.csv'}: cannot write or replace it (Is a "
                                         "directory): the folder is marked unfinished (api.load, check and export "
                                         "refuse it); run again once it can be written"), r.output
    _refused_everywhere(out, f"{out}: not a result folder of `ecostudy solve`: its files were being written when "
                             "the write stopped (an interrupted write?): solve again")
    (out / "profile_every_1s.csv").rmdir()
    r = CliRunner().invoke(app, [*SOLVE, "--time", "85", "--points", "100", "--out", str(out)])
    assert r.exit_code == 0 and api.load(out).status.ok, r.output
    assert json.loads((out / "inputs.json").read_text())["points"] == len(pd.read_csv(out / "profile.csv")) == 100


def _edit_summary(out, **edits):
    summary = json.loads((out / "summary.json").read_text())
    for path, value in edits.items():
        *parents, key = path.split("__")
        block = summary
        for parent in parents:
            block = block[parent]
        block[key] = value
    (out / "summary.json").write_text(json.dumps(summary))


@pytest.mark.parametrize("edits, fragment, load_too", [
    ({"verification__stop_error_m": 5.0}, "summary.json: verification.passed: True, but its errors and timing windows "
                                          "say False", True),
    ({"verification__stop_error_m": 0.5}, "summary.json: verification.stop_error_m: 0.5, but the saved profile "
                                          "re-simulated gives -0.00", False),
    ({"verification__tolerances__stop_error_m": 10.0}, "summary.json: verification.tolerances: ", True),
    ({"points": 1000}, "inputs.json: points: 200, but summary.json records 1000: an edited record?", True),
    ({"objective": "net_energy"}, "inputs.json: objective: 'energy', but summary.json records 'net_energy'", True),
    ({"pontryagin__agreement_pct": 50.0}, "summary.json's pontryagin.agreement_pct is 50.0", False),
    ({"marginal_energy_kWh_per_s": 0.27}, "summary.json: marginal_energy_kWh_per_s: 0.27: a second more saves energy",
     True),
    ({"regimes__sequence": "MA-CO-MB"}, "summary.json: regimes.sequence: not the regimes of the profile's forces "
                                        "(MA-CO-MA-CO-MB)", False),
    ({"top_speed_kmh": 60.0}, "summary.json: top_speed_kmh: 60.0, but the profile gives 67.79", True),
])
def test_an_edited_summary_field_is_refused(solved, tmp_path, edits, fragment, load_too):
    """Each field of summary.json a user reads is compared with what check computes again or what
    the files give: the verification's numbers with the re-simulation from the profile (within 1 %
    of each tolerance), the points with the profile's rows, the objective with inputs.json's, the
    Pontryagin agreement with the profile's costate_ratio, the marginal energy's sign, the regimes
    with the forces' (check, export and api.load said ok with stop_error_m 5, agreement 50 %, 1000
    points). api.load refuses what the files alone show (``load_too``)."""
    out = _copy(solved, tmp_path)
    _edit_summary(out, **edits)
    if load_too:
        _refused_everywhere(out, fragment)
        return
    for command in ("check", "export"):
        r = CliRunner().invoke(app, [command, str(out)])
        assert r.exit_code == 2 and fragment in r.output and "Traceback" not in r.output, (command, r.output)


def test_an_edited_marginal_energy_is_refused_by_check(solved, tmp_path):
    """-5 kWh/s in place of the run's -0.273: check fits the multipliers at the profile and finds
    the arrival's (within 10 %; measured within 2.8 %); an edited inputs.json objective is refused
    as an edited record."""
    out = _copy(solved, tmp_path)
    _edit_summary(out, marginal_energy_kWh_per_s=-5.0)
    r = CliRunner().invoke(app, ["check", str(out)])
    assert r.exit_code == 2 and "summary.json: marginal_energy_kWh_per_s: -5.0, but the multipliers fitted at the " \
        "profile give -0.273" in r.output, r.output
    assert not (out / "check.json").exists()
    inputs = json.loads((solved / "inputs.json").read_text())
    (out / "inputs.json").write_text(json.dumps({**inputs, "objective": "net_energy"}))
    _refused_everywhere(out, "inputs.json: objective: 'net_energy', but summary.json records 'energy': an edited record?")


def _say_ok(out):
    """The summary's own status, its counts and its list of cases not ok edited to say ok."""
    _edit_summary(out, status="ok", cases={"total": 1, "ok": 1, "flagged": 0, "failed": 0}, not_ok=[])


def test_a_status_its_parts_contradict_is_refused(solved, tmp_path):
    """A run is ok only when every part its status is made of is (io.runsummary.status_parts): a
    driver advice that stopped 2.12 m short (K = 100, 78 s, --das round) edited to ok in status,
    cases and not_ok alone passed check, export (ok on every advice row) and api.load; so did an
    all-out run Ipopt ended acceptable, and the advice's status edited to ok under a flagged run."""
    advised = tmp_path / "advised"
    r = CliRunner().invoke(app, [*SOLVE, "--time", "78", "--points", "100", "--das", "round", "--out", str(advised)])
    assert r.exit_code == 1 and "driver advice round: stopped 2.12 m short" in r.output, r.output
    flagged_copy = shutil.copytree(advised, tmp_path / "flagged")
    _say_ok(advised)
    _refused_everywhere(advised, "summary.json: status: ok, but its part das.status makes it flagged: driver advice "
                                 "round: stopped 2.12 m short of the stop (tolerance 1 m): an edited file?")
    _edit_summary(flagged_copy, das__status="ok")
    _refused_everywhere(flagged_copy, "summary.json: status: flagged: driver advice round: stopped 2.12 m short of the "
                                      "stop (tolerance 1 m), but every part of the run is ok (solver.status, "
                                      "verification, train calibration, das.status)")
    unproven = _copy(solved, tmp_path)
    _edit_summary(unproven, all_out_solver_status="acceptable")
    _refused_everywhere(unproven, "summary.json: status: ok, but its part all_out_solver_status makes it flagged: the "
                                  "all-out run: Ipopt ended acceptable, not optimal")
    counted = _copy(solved, tmp_path / "c")
    _edit_summary(counted, cases={"total": 1, "ok": 0, "flagged": 1, "failed": 0})
    _refused_everywhere(counted, "summary.json: cases: {'total': 1, 'ok': 0, 'flagged': 1, 'failed': 0}, but the "
                                 "run's status is ok")


def test_a_train_of_a_flagged_calibration_cannot_be_edited_to_ok(tmp_path):
    """The train's calibration is a part of its run's status too: check and export read the train
    file and refuse an ok the calibration does not allow (api.load, which reads no train file, cannot)."""
    train = tmp_path / "calibrated.yaml"
    train.write_text(TRAIN.read_text() + "\ncalibration: {status: flagged, reason: drift of the residuals}\n")
    out = tmp_path / "run"
    r = CliRunner().invoke(app, ["solve", "--track", str(TRACK), "--train", str(train), "--no-plot", "--time", "80",
                                 "--points", "100", "--out", str(out)])
    assert r.exit_code == 1 and "train calibrated with status flagged: drift of the residuals" in r.output, r.output
    assert CliRunner().invoke(app, ["check", str(out)]).exit_code == 1
    _say_ok(out)
    for command in ("check", "export"):
        r = CliRunner().invoke(app, [command, str(out)])
        assert r.exit_code == 2 and "summary.json: status: ok, but its part train calibration makes it flagged: train " \
            "calibrated with status flagged: drift of the residuals" in r.output, (command, r.output)


def test_an_energy_run_edited_to_say_all_out_is_refused(solved, tmp_path):
    """objective time in inputs.json and summary.json, and no timing, made the 80 s energy run pass
    check and export as the all-out run: an all-out run records its own time as the all-out time,
    and has no marginal energy and no costate check."""
    out = _copy(solved, tmp_path)
    inputs = json.loads((out / "inputs.json").read_text())
    (out / "inputs.json").write_text(json.dumps({**inputs, "objective": "time", "timing": dict.fromkeys(inputs["timing"])}))
    _edit_summary(out, objective="time")
    _refused_everywhere(out, "summary.json: all_out_time_s: None, but the all-out run (objective time) records its "
                             "own running time (80.0")
    took = json.loads((out / "summary.json").read_text())["running_time_s"]
    _edit_summary(out, all_out_time_s=took)
    _refused_everywhere(out, "summary.json: marginal_energy_kWh_per_s: a marginal energy, but a run of objective 'time' has none")
    _edit_summary(out, marginal_energy_kWh_per_s=None)
    _refused_everywhere(out, "summary.json: pontryagin: a costate check, but a run of objective 'time' has none")


def test_a_cruise_on_the_one_percent_threshold_is_one_regime_that_check_and_export_accept(tmp_path):
    """A 100 t train with 200 kN of traction cruising against 2 kN of resistance needs just the 1 %
    share that parts CR from CO (analysis/regimes.classify): a tie, which the solve's unrounded
    forces and profile.csv's six digits both label as one cruise, so the fresh folder is accepted."""
    r, out = solve_written(
        tmp_path, "name: tie\nsource: test\nmass_t: 100\neffective_mass_t: 100\nlength_m: 0\n"
        "davis: {a_N: 2000, b_N_per_mps: 0, c_N_per_mps2: 0}\ntraction: {max_force_kN: 200}\n"
        "braking: {max_force_kN: 100}\ntraction_efficiency: 0.8\n",
        "name: flat\nsource: test\nlength_m: 1000\nstops:\n  - {name: A, position_m: 0}\n"
        "  - {name: B, position_m: 1000}\ngradients:\n  - {position_m: 0, gradient_permille: 0}\n"
        "speed_limits:\n  - {position_m: 0, speed_kmh: 72}\n", "--objective", "time", "--points", "300")
    assert r.exit_code == 0, r.output
    assert json.loads((out / "summary.json").read_text())["regimes"]["sequence"] == "MA-CR-MB"
    for command in (["check", str(out)], ["export", str(out), "--every", "1s"]):
        r = CliRunner().invoke(app, command)
        assert r.exit_code == 0, (command, r.output)
