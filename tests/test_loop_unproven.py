"""A closed-loop run that drove plans its solver did not prove optimal (usable, e.g. Clarabel
``AlmostSolved``) is flagged with their count and how the solver ended them, never ok; so is a run
of ``open_loop`` whose one convex plan ended so. Provoked by Clarabel's feasibility tolerance set
below what it can reach (1e-20): it then stops at its reduced accuracy, ``AlmostSolved``."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.studies import controllers

from .conftest import TRACKS, TRAINS, write_yaml


@pytest.fixture
def unreachable_tolerance(monkeypatch):
    real = controllers.convex_program

    def tight(*args, **kwargs):
        program = real(*args, **kwargs)
        program.settings.tol_feas = program.refined.tol_feas = 1e-20
        return program
    monkeypatch.setattr(controllers, "convex_program", tight)


def _runs(tmp_path, kind):
    study = write_yaml(tmp_path / "loop.yaml", {
        "name": "unproven", "track": str(TRACKS / "yazhemsky2017_flat_1km.yaml"),
        "train": str(TRAINS / "yazhemsky2017_commuter.yaml"), "window_s": [0, 200], "points": 60,
        "sample_time_s": 0.5, "draws": 1, "controllers": [{"name": "c", "kind": kind}]})
    r = CliRunner().invoke(app, ["simulate", str(study), "--out", str(tmp_path / "o"), "--workers", "1",
                                 "--no-progress", "--no-plot"])
    return r, pd.read_csv(tmp_path / "o" / "runs.csv").iloc[0]


def test_a_run_driven_on_almost_solved_plans_is_flagged_with_their_count(tmp_path, unreachable_tolerance):
    r, run = _runs(tmp_path, "convex")
    assert r.exit_code == 1, r.output
    n = run["unproven_solves_count"]
    assert n > 0 and run["unproven_solver_status"] == "AlmostSolved" and run["failures_count"] == 0, run.to_dict()
    assert f"{n} solve{'s' if n != 1 else ''} in " in run["reason"] and "ended AlmostSolved (driven, not proven optimal)" in run["reason"]
    steps = pd.read_csv(tmp_path / "o" / "steps" / "c_draw0.csv")
    assert (steps["status"] == "AlmostSolved").sum() == n  # steps.csv says which samples
    assert pd.read_csv(tmp_path / "o" / "aggregate.csv")["unproven_solves_count_sum"].iloc[0] == n


def test_an_open_loop_replay_of_an_almost_solved_plan_is_flagged(tmp_path, unreachable_tolerance):
    r, run = _runs(tmp_path, "open_loop")
    assert r.exit_code == 1, r.output
    assert "the open-loop plan: Clarabel ended AlmostSolved, not optimal" in run["reason"], run.to_dict()

