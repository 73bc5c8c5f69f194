"""`ecostudy simulate`: controllers x Monte Carlo draws of the plant's deviations, resumable, one
table per run and one per controller, plots; bad study input in one line."""
import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.io.loaders import load_train
from ecostudy.studies.closedloop import expand

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml

runner = CliRunner()


def study(tmp_path, **changes):
    doc = {"name": "mc", "track": str(TRACKS / "yazhemsky2017_advanced_1km.yaml"),
           "train": str(TRAINS / "yazhemsky2017_commuter.yaml"), "window_s": [0, 200], "points": 80,
           "sample_time_s": 0.5, "draws": 2, "seed": 7,
           # solving taken as instantaneous: at 2 Hz one sample of delay (0.5 s, the default) costs up
           # to 1.2 m at the stop on these draws; the delayed loop: tests/test_fallback.py
           "controllers": [{"name": "convex", "kind": "convex", "estimator": True, "compute_delay": 0},
                           {"name": "replayed", "kind": "open_loop"}],
           "deviations": {"mass": {"low": 1.05, "high": 1.15}},
           "noise": {"acceleration_mps2": 0.05, "speed_mps": 0.01, "position_m": 0.01}, **changes}
    path = tmp_path / "mc.yaml"
    write_yaml(path, doc)
    return path


def aggregate_of(out):
    return pd.read_csv(out / "aggregate.csv").set_index("controller").loc[["convex"]]


def test_a_monte_carlo_study_runs_resumes_and_says_what_feedback_buys(tmp_path):
    out = tmp_path / "out"
    first = runner.invoke(app, ["simulate", str(study(tmp_path)), "--out", str(out), "--no-progress"])
    runs = pd.read_csv(out / "runs.csv")
    assert len(runs) == 4 and set(runs["controller"]) == {"convex", "replayed"}
    convex, replayed = runs[runs.controller == "convex"], runs[runs.controller == "replayed"]
    # heavier trains: the replayed plan overruns the stop, the closed loop with the estimator stops
    # K = 80, 2 Hz; every plan Clarabel proved optimal (Solved): the closed-loop runs are ok
    assert (convex["stop_error_m"].abs() < 1.0).all()
    assert (convex["status"] == "ok").all(), convex["reason"].tolist()
    assert (convex["unproven_solves_count"] == 0).all() and (aggregate_of(out)["unproven_solves_count_sum"] == 0).all()
    assert (replayed["stop_error_m"] > 1.0).all() and (replayed["status"] == "flagged").all()
    assert first.exit_code == 1 and "m beyond the stop (tolerance 1 m)" in first.output  # flagged runs are named, exit 1
    assert convex["mass_estimate"].sub(convex["true_mass_factor"]).abs().max() < 0.02
    aggregate = pd.read_csv(out / "aggregate.csv")
    assert list(aggregate["controller"]) == ["convex", "replayed"] and list(aggregate["runs"]) == [2, 2]
    assert (out / "bands.png").stat().st_size > 0 and (out / "mass_estimates.png").exists()
    again = runner.invoke(app, ["simulate", str(study(tmp_path, draws=3)), "--out", str(out), "--no-progress",
                                "--no-plot"])
    assert "4 already stored, 2 computed now" in again.output, again.output
    assert len(pd.read_csv(out / "runs.csv")) == 6


def test_bad_closed_loop_studies_get_one_line(tmp_path):
    late = runner.invoke(app, ["simulate", str(study(tmp_path, window_s=[0, 30])), "--no-progress"])
    assert late.exit_code == 2 and "window_s" in late.output and "all-out time" in late.output
    long = runner.invoke(app, ["simulate", str(study(tmp_path, sample_time_s=250)), "--no-progress"])
    assert long.exit_code == 2 and "sample_time_s" in long.output
    zero = runner.invoke(app, ["simulate", str(study(tmp_path, points=0)), "--no-progress"])
    assert zero.exit_code == 2 and "points" in zero.output


def test_the_shipped_closed_loop_study_is_valid():
    assert load_yaml(STUDIES / "yazhemsky2017_closed_loop.yaml")["controllers"]


@pytest.mark.slow
def test_sbpc_with_a_driver_on_das_levels_runs_in_a_study(tmp_path):
    path = study(tmp_path, track=str(TRACKS / "amsterdam_rokin_centraal.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"),
                 window_s=[0, 76], points=200, sample_time_s=1.52, draws=1, deviations={}, noise={},
                 controllers=[{"name": "sbpc", "kind": "sbpc", "block": 4, "variant": "two_step", "das_levels": True,
                               "delay_samples": 1}])
    result = runner.invoke(app, ["simulate", str(path), "--out", str(tmp_path / "o"), "--no-progress", "--no-plot"])
    runs = pd.read_csv(tmp_path / "o" / "runs.csv")
    assert runs.loc[0, "status"] in ("ok", "flagged"), result.output
    assert runs.loc[0, "terminal_gamma_m"] >= 0 and abs(runs.loc[0, "stop_error_m"]) < 30.0


def test_rspc_runs_at_its_own_sample_time_and_only_runs_what_it_is_asked(tmp_path):
    """A controller's sample_time_s overrides the study's (Farooqi 2018's controllers at 0.38 s beside
    a 10 Hz one in one study); --only computes one controller's runs and the rest stay 'missing': the
    folder is not the study's whole answer, so its summary is flagged naming them (exit 1; it said
    'ok' before); the next run without --only computes them."""
    path = study(tmp_path, track=str(TRACKS / "amsterdam_rokin_centraal.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"),
                 window_s=[0, 76], points=200, sample_time_s=0.2, draws=2,
                 deviations={"mass": {"low": 0.95, "high": 1.05}, "braking": {"low": 0.95, "high": 1.05}},
                 controllers=[{"name": "rspc", "kind": "rspc", "sample_time_s": 0.38},
                              {"name": "replayed", "kind": "ato"}])
    out = tmp_path / "o"
    first = runner.invoke(app, ["simulate", str(path), "--out", str(out), "--no-progress", "--only", "rspc"])
    assert first.exit_code == 1, first.output
    assert "not run yet: 2 runs of replayed" in first.output
    assert "2 runs: 0 already stored, 2 computed now (0 failed); not ok: 0" in first.output, first.output  # the 2 not run said apart
    left = json.loads((out / "summary.json").read_text())
    assert left["status"].startswith("flagged") and "not computed yet" in left["status"], left["status"]
    assert left["cases"] == {"total": 4, "ok": 2, "flagged": 2, "failed": 0}, left["cases"]
    assert "every case computed" not in (out / "report.html").read_text()
    runs = pd.read_csv(out / "runs.csv")
    rspc = runs[runs.controller == "rspc"]
    assert list(runs[runs.controller == "replayed"]["status"]) == ["missing", "missing"]
    assert (rspc["status"] == "ok").all(), rspc[["status", "reason"]]
    cases = expand(path)[2]
    assert {c["labels"]["controller"]: c["sample_time"] for c in cases} == {"rspc": 0.38, "replayed": 0.2}
    assert (rspc["arrival_s"] <= 76.0).all() and (rspc["stop_error_m"].abs() < 0.5).all()
    assert (rspc["solve_max_ms"] > 0.0).all()  # each sample's enumeration timed (no bound: the machines are shared)
    second = runner.invoke(app, ["simulate", str(path), "--out", str(out), "--no-progress", "--no-plot"])
    assert "2 already stored, 2 computed now" in second.output, second.output
    from .conftest import assert_folder
    every_ok = (pd.read_csv(out / "runs.csv")["status"] == "ok").all()
    folder = assert_folder(out, "simulate", ["runs", "aggregate"], rows=4, status="ok" if every_ok else "flagged")
    assert folder.cases.total == 4 and folder.summary["missing_runs"] == 0
    # J/kg per unit of each draw's static mass, as `solve` prints it (it was the effective mass: 7.7 % low)
    runs = pd.read_csv(out / "runs.csv")
    static = load_train(TRAINS / "amsterdam_metro.yaml").static_mass * runs["true_mass_factor"]
    assert np.allclose(runs["energy_J_per_kg"] * static, runs["traction_energy_kWh"] * 3.6e6, rtol=1e-4)
    assert (second.exit_code == 0) == folder.ok
    unknown = runner.invoke(app, ["simulate", str(path), "--out", str(out), "--no-progress", "--only", "sppc"])
    assert unknown.exit_code == 2 and "--only" in unknown.output and "sppc" in unknown.output
    zero = runner.invoke(app, ["simulate", str(study(tmp_path, controllers=[
        {"name": "r", "kind": "rspc", "rspc": {"horizon": 0}}])), "--no-progress"])
    assert zero.exit_code == 2 and "horizon" in zero.output


def test_a_case_key_does_not_change_when_a_default_is_written_out_and_reserves_are_checked(tmp_path):
    """Cases store the controller as written, so writing a default out (or a field added to the
    schema later with its default) keeps every stored run; brake_reserve is refused where the
    controller has none."""
    plain = expand(study(tmp_path))[2]
    spelled = expand(study(tmp_path, controllers=[
        {"name": "convex", "kind": "convex", "estimator": True, "scheme": "midpoint", "das_levels": False,
         "compute_delay": 0},
        {"name": "replayed", "kind": "open_loop", "settings": {"time": 1.0}}]))[2]
    assert [c["key"] for c in plain] == [c["key"] for c in spelled]
    bad = runner.invoke(app, ["simulate", str(study(tmp_path, controllers=[
        {"name": "c", "kind": "convex", "brake_reserve": 0.2}])), "--no-progress"])
    assert bad.exit_code == 2 and "brake_reserve" in bad.output and "brake_level_mps2" in bad.output
    bad = runner.invoke(app, ["simulate", str(study(tmp_path, controllers=[
        {"name": "c", "kind": "rspc", "transcription": "condensed"}])), "--no-progress"])
    assert bad.exit_code == 2 and "transcription is an SBPC setting" in bad.output


def test_the_metro_monte_carlo_study_has_every_controller_at_its_own_sample_time():
    study, _, cases = expand(STUDIES / "metro_monte_carlo.yaml")
    kinds = {c.kind for c in study.controllers}
    assert kinds == {"convex", "open_loop", "ato", "sbpc", "sppc", "rspc"} and len(cases) == 100 * len(study.controllers)
    times = {c["labels"]["controller"]: c["sample_time"] for c in cases}
    assert times["convex"] == 0.1 and times["sbpc_multi"] == times["sppc"] == times["rspc"] == 0.38
    draw = [c["truth"] for c in cases if c["labels"]["draw"] == 7]
    assert all(t == draw[0] for t in draw)  # every controller meets the same plant


def test_a_replay_of_an_ato_run_ipopt_did_not_prove_optimal_is_flagged_saying_so(tmp_path, monkeypatch):
    """The ``ato`` controller replays the energy-optimal run; solved with a tolerance Ipopt cannot
    reach (tol 1e-20 on every space NLP) that run ends ``acceptable``, and the replay's run is
    flagged naming it, whatever it stops and arrives like. Solved as usual it is not."""
    from ecostudy.ocp.solver import IPOPT
    from ecostudy.studies import controllers
    from ecostudy.studies.closedloop import run_loop_case
    path = study(tmp_path, track=str(TRACKS / "amsterdam_rokin_centraal.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"),
                 window_s=[0, 76], points=100, sample_time_s=1.0, draws=1, deviations={}, noise={},
                 controllers=[{"name": "replayed", "kind": "ato"}])
    (case,) = expand(path)[2]
    reason = "the ATO run: Ipopt ended acceptable, not optimal"
    monkeypatch.setattr(controllers, "_ATO_RUNS", {})  # solved here, and forgotten after
    usual = run_loop_case(case)
    assert reason not in (usual["error"] or ""), usual["error"]
    monkeypatch.setattr(controllers, "_ATO_RUNS", {})
    monkeypatch.setitem(IPOPT["space"], "tol", 1e-20)
    replay = run_loop_case(case)
    assert replay["status"] == "flagged" and replay["error"].endswith(reason), replay
