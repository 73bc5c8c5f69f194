"""A solved run at fixed steps of time or distance (`ecostudy export`), for on-board systems."""
import json
import re

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.analysis.export import at_positions, at_times, fixed_step
from ecostudy.analysis.saved import RECORDED
from ecostudy.analysis.tables import handles, tabulate
from ecostudy.cli import app
from ecostudy.core.kinematics import interval_power
from ecostudy.core.types import Trajectory
from ecostudy.io.loaders import load_train
from ecostudy.io.results import load_result

from .conftest import STUDIES, TRACKS, TRAINS, write_yaml


def uniform_acceleration(a=0.5, length=100.0, nodes=7):
    """A train accelerating at ``a`` from rest over ``length`` metres, on an uneven grid."""
    s = length * np.linspace(0.0, 1.0, nodes) ** 1.5
    v = np.sqrt(2 * a * s)
    dt = 2 * np.diff(s) / (v[:-1] + v[1:])
    return Trajectory(s, v, dt, np.ones(nodes - 1), np.zeros(nodes - 1))


def test_between_nodes_the_run_has_the_transcription_s_constant_acceleration():
    traj = uniform_acceleration()
    t = np.linspace(0.0, traj.time[-1], 37)
    s, v, _ = at_times(traj, t)
    np.testing.assert_allclose(s, 0.25 * t ** 2, atol=1e-9)   # s = a t^2 / 2
    np.testing.assert_allclose(v, 0.5 * t, atol=1e-9)
    x = np.linspace(0.0, 100.0, 41)
    tx, vx, _ = at_positions(traj, x)
    np.testing.assert_allclose(tx, np.sqrt(x / 0.25), atol=1e-9)
    np.testing.assert_allclose(vx, np.sqrt(x), atol=1e-9)


def test_fixed_steps_end_at_the_arrival_and_hold_each_interval_s_handle():
    traj = uniform_acceleration()
    handle = np.linspace(0.1, 0.6, len(traj.dt))
    table = fixed_step(traj, handle, time_step_s=3.0)
    assert table["time_s"].iloc[-1] == pytest.approx(traj.time[-1]) and table["position_m"].iloc[-1] == 100.0
    assert np.all(np.diff(table["time_s"]) <= 3.0 + 1e-12) and table["handle"].iloc[-1] == 0.0
    k = np.searchsorted(traj.time, table["time_s"].iloc[1], side="right") - 1
    assert table["handle"].iloc[1] == handle[k]
    with pytest.raises(ValueError):
        fixed_step(traj, handle)


def test_export_command_on_a_solved_run_with_driver_advice(tmp_path):
    runner = CliRunner()
    out = tmp_path / "run"
    assert runner.invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "500", "--das", "round",
                               "--no-plot", "--out", str(out)]).exit_code == 0
    profile = pd.read_csv(out / "profile.csv")
    for every, column, step in (("1s", "time_s", 1.0), ("10m", "position_m", 10.0)):
        r = runner.invoke(app, ["export", str(out), "--every", every])
        assert r.exit_code == 0, r.output
        table = pd.read_csv(out / f"profile_every_{every}.csv")
        assert table[column].iloc[1] == pytest.approx(step)
        assert table["time_s"].iloc[-1] == pytest.approx(profile["time_s"].iloc[-1], abs=1e-4)
        assert table["position_m"].iloc[-1] == pytest.approx(profile["position_m"].iloc[-1])
        # speeds between the profile's own nodes, and the advised mode in force at each row
        assert table["speed_kmh"].max() <= profile["speed_kmh"].max() + 1e-6
        assert set(table["advice_mode"]) <= set(pd.read_csv(out / "advice.csv")["mode"])
        data = json.loads((out / f"profile_every_{every}.json").read_text())
        assert len(data["rows"]) == len(table) and data["units"]["speed_kmh"] == "km/h"
    bad = runner.invoke(app, ["export", str(out), "--every", "fast"])
    assert bad.exit_code == 2 and "--every" in bad.output and "Traceback" not in bad.output
    # a step that skips a phase of the run (the braking into the stop, a short traction) says so: an
    # on-board system reading it never sees that phase (it said `ok`)
    phases = json.loads((out / "summary.json").read_text())["regimes"]["runs"]
    advice = pd.read_csv(out / "advice.csv")  # the advised modes are phases a driver sees too
    ends = [*advice["start_position_m"].iloc[1:], pd.read_csv(out / "profile.csv")["position_m"].iloc[-1]]
    phases += [{"regime": f"advice {m}", "start_m": a, "end_m": b}
               for m, a, b in zip(advice["mode"], advice["start_position_m"], ends) if b > a]
    coarse = runner.invoke(app, ["export", str(out), "--every", "400m"])
    rows = pd.read_csv(out / "profile_every_400m.csv")["position_m"]
    missed = [r for r in phases if not ((rows >= r["start_m"]) & (rows < r["end_m"])).any()]
    assert missed and coarse.exit_code == 0, coarse.output  # the run is ok; the export warns
    assert f"warning: the export every 400m has no row in {len(missed)} of the run's {len(phases)} phases " \
        f"({missed[0]['regime']} " in coarse.output and "a finer step shows them" in coarse.output, coarse.output
    data = json.loads((out / "profile_every_400m.json").read_text())
    assert data["units"]["position_m"].startswith("m from the departure stop") and len(data["phases_without_a_row"]) \
        == len(missed)
    assert any(m["regime"].startswith("advice ") for m in missed), missed  # an advised mode between two rows
    # a summary saying ok over a solve Ipopt did not prove optimal is an edited file (check said ok)
    summary = json.loads((out / "summary.json").read_text())
    (out / "summary.json").write_text(json.dumps({**summary, "solver": {**summary["solver"], "status": "maxIterations"}}))
    edited = runner.invoke(app, ["check", str(out)])
    assert edited.exit_code == 2 and "status: ok, but its part solver.status makes it flagged: Ipopt ended " \
        "maxIterations, not optimal" in edited.output, edited.output


@pytest.mark.flagged_on_purpose
def test_export_of_a_flagged_run_carries_its_status(tmp_path):
    """K = 10: the run solves but its re-simulation stops 3 m short (flagged). Its export is written,
    says the run's status in the JSON and on the screen, and exits 1, as the solve did; an ok run's
    export says ok and exits 0."""
    runner = CliRunner()
    out = tmp_path / "coarse"
    solved = runner.invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "10", "--no-plot",
                                 "--out", str(out)])
    assert solved.exit_code == 1, solved.output
    r = runner.invoke(app, ["export", str(out), "--every", "1s"])
    data = json.loads((out / "profile_every_1s.json").read_text())
    assert data["run"]["status"].startswith("flagged: re-simulation outside tolerance"), data["run"]
    assert (out / "profile_every_1s.csv").is_file()
    assert r.exit_code == 1 and "flagged: re-simulation outside tolerance" in r.output, r.output
    fine = tmp_path / "fine"
    assert runner.invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "200", "--no-plot",
                               "--out", str(fine)]).exit_code == 0
    r = runner.invoke(app, ["export", str(fine), "--every", "10m"])
    assert r.exit_code == 0, r.output
    assert json.loads((fine / "profile_every_10m.json").read_text())["run"]["status"] == "ok"


@pytest.mark.parametrize("steps", [{"time_s": 1e9}, {"distance_m": 1e9}])
def test_a_step_longer_than_the_run_keeps_the_departure_and_the_arrival(steps):
    traj = uniform_acceleration()  # 20 s and 100 m: a step a million times longer still starts at rest
    table = fixed_step(traj, np.ones(len(traj.dt)), time_step_s=steps.get("time_s"),
                       distance_step_m=steps.get("distance_m"))
    assert table["time_s"].tolist() == [0.0, pytest.approx(traj.time[-1])]
    assert table["position_m"].tolist() == [0.0, 100.0]


@pytest.mark.parametrize("edit, field", [({"status": "weird"}, "status"),
                                         ({"verification": {"passed": False}}, "verification.passed")])
def test_an_edited_summary_is_refused_in_one_line(tmp_path, edit, field):
    """A summary.json whose status is not a status, or says ok over a failed re-simulation (which
    the solve flags), is one line naming the file and the field, exit 2, not an export that says ok."""
    runner = CliRunner()
    out = tmp_path / "run"
    assert runner.invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "200", "--no-plot",
                               "--out", str(out)]).exit_code == 0
    summary = json.loads((out / "summary.json").read_text())
    summary.update({k: {**summary[k], **v} if isinstance(v, dict) else v for k, v in edit.items()})
    (out / "summary.json").write_text(json.dumps(summary))
    for command in ("export", "check"):
        r = runner.invoke(app, [command, str(out)])
        assert r.exit_code == 2 and f"summary.json: {field}: " in r.output and "Traceback" not in r.output, r.output


@pytest.mark.flagged_on_purpose
def test_a_summary_edited_to_ok_over_a_run_short_of_its_stop_is_refused(tmp_path):
    """K = 10: the run stops 3 m short of Centraal (flagged). Its summary.json rewritten to say ok,
    with a passed re-simulation consistent with itself (every error 0), is not taken on its word:
    export and check re-simulate the saved profile against the unchanged track and train, and a
    verification whose numbers are not that re-simulation's is an edited file (exit 2)."""
    runner = CliRunner()
    out = tmp_path / "coarse"
    assert runner.invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "10", "--no-plot",
                               "--out", str(out)]).exit_code == 1
    said = runner.invoke(app, ["export", str(out)]).output  # flagged for its re-simulation: said once, not twice
    assert said.count("outside tolerance (arrival +0.40") == 1, said
    summary = json.loads((out / "summary.json").read_text())
    zero = {k: 0.0 for k in ("arrival_time_error_s", "stop_error_m", "energy_error_pct", "net_energy_error_pct")}
    summary.update(status="ok", not_ok=[], cases={"total": 1, "ok": 1, "flagged": 0, "failed": 0},
                   verification={**summary["verification"], **zero, "passed": True,
                                 "simulated_running_time_s": summary["running_time_s"]})
    (out / "summary.json").write_text(json.dumps(summary))
    for command in ("export", "check"):
        r = runner.invoke(app, [command, str(out)])
        assert r.exit_code == 2 and "summary.json: verification.arrival_time_error_s: 0.0, but the saved profile " \
            "re-simulated gives 0.40" in r.output and "Traceback" not in r.output, r.output


@pytest.mark.parametrize("name, factor", [("traction_energy_kWh", 0.95), ("running_time_s", 0.99),
                                          ("net_energy_kWh", 1.1), ("distance_m", 1.5)])
def test_a_summary_whose_totals_are_not_its_profile_s_is_refused(tmp_path, name, factor):
    """A recorded total that the profile's own run does not give (an energy edited down, a time
    edited to the timetable's) is one line naming summary.json and the field, exit 2."""
    runner = CliRunner()
    out = tmp_path / "run"
    assert runner.invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "200", "--no-plot",
                               "--out", str(out)]).exit_code == 0
    summary = json.loads((out / "summary.json").read_text())
    summary[name] *= factor
    (out / "summary.json").write_text(json.dumps(summary))
    for command in ("export", "check"):
        r = runner.invoke(app, [command, str(out)])
        assert r.exit_code == 2 and f"summary.json: {name}: " in r.output and "edited" in r.output, r.output
        assert "Traceback" not in r.output


def test_a_run_s_timing_windows_are_recorded_and_kept_when_judged_again(tmp_path):
    """The timing windows a run was solved for are in inputs.json and checked again: kept, the
    run exports ok; a window asked tighter than the run passes it (latest 30 s at 600 m, passed
    near 42 s) is a missed timing point, flagged."""
    study = write_yaml(tmp_path / "study.yaml", {"name": "w", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
                                                 "train": str(TRAINS / "amsterdam_metro.yaml"),
                                                 "running_time_s": 80, "points": 200,
                                                 "windows": [{"position_m": 600, "latest_s": 42, "max_speed_kmh": 72}]})
    runner = CliRunner()
    out = tmp_path / "o"
    assert runner.invoke(app, ["solve", str(study), "--no-plot", "--out", str(out)]).exit_code == 0
    inputs = json.loads((out / "inputs.json").read_text())
    assert inputs["windows"] == [{"distance_m": 600.0, "earliest_s": None, "latest_s": 42.0, "min_speed_kmh": None,
                                  "max_speed_kmh": pytest.approx(72.0)}]
    r = runner.invoke(app, ["export", str(out)])
    assert r.exit_code == 0 and "the run exported: ok" in r.output, r.output
    inputs["windows"][0]["latest_s"] = 30.0
    (out / "inputs.json").write_text(json.dumps(inputs))
    r = runner.invoke(app, ["export", str(out)])
    assert r.exit_code == 1 and "the timing point at 600 m is missed" in r.output, r.output


def test_a_run_solved_again_into_its_folder_leaves_no_check_or_export_of_the_run_before(tmp_path):
    """check.json and profile_every_* belong to the run they read: solving into the folder again
    (80 s, then 78 s) removes them with that run's other files, so no 80 s export sits beside a 78 s
    profile; checked and exported again, they are the new run's."""
    runner = CliRunner()
    out = tmp_path / "run"
    base = ["solve", "--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"), "--train",
            str(TRAINS / "amsterdam_metro.yaml"), "--points", "200", "--no-plot", "--out", str(out)]
    assert runner.invoke(app, [*base, "--time", "80"]).exit_code == 0
    for command in (["export", str(out), "--every", "1s"], ["export", str(out), "--every", "10m"], ["check", str(out)]):
        assert runner.invoke(app, command).exit_code == 0
    assert {p.name for p in out.iterdir()} >= {"check.json", "profile_every_1s.csv", "profile_every_10m.json"}
    assert runner.invoke(app, [*base, "--time", "78"]).exit_code == 0
    left = {p.name for p in out.iterdir()}
    assert not left & {"check.json", "profile_every_1s.csv", "profile_every_1s.json", "profile_every_10m.csv",
                       "profile_every_10m.json"}, left
    assert runner.invoke(app, ["check", str(out)]).exit_code == 0
    assert json.loads((out / "check.json").read_text())["profile_running_time_s"] == pytest.approx(78.0, abs=1e-4)


def _solved(tmp_path, *extra):
    out = tmp_path / "run"
    assert CliRunner().invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "200", "--no-plot",
                                    "--out", str(out), *extra]).exit_code == 0
    return out


def _edit_profile(out, row, column, value):
    profile = pd.read_csv(out / "profile.csv")
    profile.loc[row, column] = value
    if column == "speed_kmh":  # the clock and the power kept consistent with the edited speeds, as a careful edit would
        v, x = profile["speed_kmh"].to_numpy() / 3.6, profile["position_m"].to_numpy()
        profile["time_s"] = np.concatenate([[0.0], np.cumsum(2 * np.diff(x) / (v[:-1] + v[1:]))])
        _consistent_power(profile)
    profile.to_csv(out / "profile.csv", index=False, float_format="%.6g")


def _consistent_summary(out, **fields):
    """summary.json with ``fields``, its simulated arrival moved with its running time (the errors kept)."""
    summary = json.loads((out / "summary.json").read_text())
    summary.update(fields)
    block = summary["verification"]
    block["simulated_running_time_s"] = summary["running_time_s"] + block["arrival_time_error_s"]
    (out / "summary.json").write_text(json.dumps(summary))


def _consistent_power(profile):
    """``power_kW`` recomputed from the (edited) speeds and forces, as the solve writes it."""
    v = profile["speed_kmh"].to_numpy() / 3.6
    profile["power_kW"] = np.append(interval_power(profile["traction_force_kN"].to_numpy()[:-1], v), np.nan)


@pytest.mark.parametrize("edit, fragment", [
    (("handle", 7.0), "profile.csv: handle, row 12: 7, but the row's forces give"),
    (("inputs", {"from": "Nowhere"}), "inputs.json: from: 'Nowhere' is not a stop of"),
    (("inputs", {"to": "Rokin"}), "inputs.json: to: 'Rokin' is the stop the run departs from"),
    (("folder", "check.json"), "check.json: is a folder where an output file goes"),
])
def test_a_saved_run_edited_by_hand_is_refused_by_check_and_export(tmp_path, edit, fragment):
    out = _solved(tmp_path)
    kind, what = edit
    if kind == "handle":
        _edit_profile(out, 10, "handle", what)
    elif kind == "inputs":  # the summary's stops edited alike, as a careful edit would (else: an edited record)
        for name in ("inputs.json", "summary.json"):
            record = json.loads((out / name).read_text())
            (out / name).write_text(json.dumps({**record, **what}))
    else:
        (out / what).mkdir()
    commands = (["check", str(out)],) if kind == "folder" else (["check", str(out)], ["export", str(out)])
    for command in commands:
        r = CliRunner().invoke(app, command)
        assert r.exit_code == 2 and fragment in r.output and "Traceback" not in r.output, r.output


def test_a_speed_edited_with_its_clock_and_summary_is_refused_by_the_equation_of_motion(tmp_path):
    """A speed of 100 km/h written at 553 m (its clock and the summary's top speed made to agree):
    the forces either side cannot take the train there on the grid's equation of motion."""
    out = _solved(tmp_path)
    _edit_profile(out, 100, "speed_kmh", 100.0)
    profile = pd.read_csv(out / "profile.csv")
    _consistent_summary(out, top_speed_kmh=100.0, running_time_s=float(profile["time_s"].iloc[-1]))
    for command in ("check", "export"):
        r = CliRunner().invoke(app, [command, str(out)])
        assert r.exit_code == 2 and re.search(r"profile.csv: speed_kmh, rows 10[12]-10[23]: the run's equation of "
                                              "motion misses by", r.output), r.output


def test_every_speed_edited_by_two_percent_with_a_consistent_clock_and_summary_is_refused(tmp_path):
    """Every speed 2 % higher, the clock and every total of summary.json recomputed from the edited
    profile as the tool computes them: the re-simulation of the forces stays inside its 2 km/h and
    0.5 s (the edit passed `check` as ok); the equation of motion misses by thousands of newtons
    where its digits allow tens."""
    out = _solved(tmp_path)
    profile = pd.read_csv(out / "profile.csv")
    profile["speed_kmh"] *= 1.02
    v, x = profile["speed_kmh"].to_numpy() / 3.6, profile["position_m"].to_numpy()
    profile["time_s"] = np.concatenate([[0.0], np.cumsum(2 * np.diff(x) / (v[:-1] + v[1:]))])
    _consistent_power(profile)
    profile.to_csv(out / "profile.csv", index=False, float_format="%.6g")
    _consistent_summary(out, top_speed_kmh=float(profile["speed_kmh"].max()),
                        running_time_s=float(profile["time_s"].iloc[-1]))
    saved = load_result(out)
    train = load_train(saved.inputs["train"])
    _, v, dt, ft, fb = saved.trajectory
    profile.loc[:len(ft) - 1, "handle"] = handles(train, v, ft, fb)  # the handles of the edited speeds
    profile.to_csv(out / "profile.csv", index=False, float_format="%.6g")
    _, totals = tabulate(train, saved.trajectory.nodes, v, dt, ft, fb)
    _consistent_summary(out, **{k: float(totals[k]) for k in RECORDED})
    r = CliRunner().invoke(app, ["check", str(out)])
    assert r.exit_code == 2 and "the run's equation of motion misses by" in r.output, r.output


def test_a_run_with_timing_windows_is_checked_on_its_own_grid(tmp_path):
    """The grid of a run with a timing point has a node there: check prepares the run with its
    windows (it refused the unedited folder as "positions that differ from the grid")."""
    study = write_yaml(tmp_path / "study.yaml", {"name": "w", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
                                                 "train": str(TRAINS / "amsterdam_metro.yaml"), "running_time_s": 80,
                                                 "points": 200, "windows": [{"position_m": 600, "latest_s": 42}]})
    out = tmp_path / "o"
    assert CliRunner().invoke(app, ["solve", str(study), "--no-plot", "--out", str(out)]).exit_code == 0
    r = CliRunner().invoke(app, ["check", str(out)])
    assert r.exit_code == 0 and "check: ok" in r.output, r.output


@pytest.mark.parametrize("given, recorded, asked, said", [
    (["--window", "100,110"], {"running_time_s": None, "supplement_percent": None, "window_s": [100.0, 110.0]},
     {"window_s": [90, 105]}, "arrives 5.00 s after the window 90-105 s asked"),
    (["--time", "110"], {"running_time_s": 110.0, "supplement_percent": None, "window_s": None},
     {"running_time_s": 120}, "arrives 10.00 s before 120 s asked")])
def test_the_timing_asked_is_kept_and_judged_again(tmp_path, given, recorded, asked, said):
    """inputs.json keeps what the run was asked (objective, running time, supplement or window), so a
    folder says what it answers; check judges the saved run's time against it: a record saying
    another time than the profile's run keeps is flagged, exit 1."""
    out = tmp_path / "o"
    assert CliRunner().invoke(app, ["solve", str(STUDIES / "default.yaml"), "--points", "200", "--no-plot",
                                    "--out", str(out), *given]).exit_code == 0
    inputs = json.loads((out / "inputs.json").read_text())
    assert inputs["timing"] == recorded and inputs["objective"] == "energy", inputs
    assert inputs["study"] == str((STUDIES / "default.yaml").resolve()), inputs
    assert CliRunner().invoke(app, ["check", str(out)]).exit_code == 0
    (out / "inputs.json").write_text(json.dumps({**inputs, "timing": {**recorded, **asked}}))
    r = CliRunner().invoke(app, ["check", str(out)])
    assert r.exit_code == 1 and said in r.output, r.output
