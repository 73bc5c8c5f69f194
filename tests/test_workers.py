"""A study's results do not depend on its number of worker processes, which is every core by default."""
import json
import os
import sqlite3

import pandas as pd
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.studies.workers import every_core

from .conftest import TRACKS, TRAINS, write_yaml

runner = CliRunner()
TIMED = ["wall_s"]  # wall times: the only columns that may differ from run to run


def small_study(folder):
    """Four cases of two scenarios: a worker re-solves the NLP written for an earlier case of its
    scenario (``ocp.problem.Written``), and which cases share a worker depends on the pool."""
    return write_yaml(folder / "study.yaml", {
        "name": "workers_test", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
        "train": str(TRAINS / "amsterdam_metro.yaml"), "from": "Rokin", "to": "Centraal",
        "supplement_percent": 10, "points": 200,
        "scenarios": [{"name": "loaded", "train_overrides": {"mass_t": 156.4, "effective_mass_t": 167.4}}],
        "sweep": {"supplement_percent": [4, 12]}, "output": str(folder / "out")})


def results(study, out, *workers):
    result = runner.invoke(app, ["run", str(study), "--out", str(out), "--no-progress", *workers])
    assert result.exit_code == 0, result.output
    return pd.read_csv(out / "results.csv", dtype=str, keep_default_na=False).drop(columns=TIMED)


def stored(out):
    """{key: stored summary} at full precision (results.csv rounds to 6 digits), wall times left out."""
    with sqlite3.connect(out / "results.sqlite") as db:
        rows = dict(db.execute("SELECT key, summary FROM cases").fetchall())
    out = {}
    for key, text in rows.items():
        summary = json.loads(text)
        summary.pop("stages_s")
        summary["solver"].pop("wall_s")
        out[key] = summary
    return out


def test_one_and_two_workers_give_the_same_results_bit_for_bit(tmp_path):
    study = small_study(tmp_path)
    one = results(study, tmp_path / "one", "--workers", "1")
    two = results(study, tmp_path / "two", "--workers", "2")
    assert len(one) == 4 and (one["status"] == "ok").all()
    pd.testing.assert_frame_equal(one, two)  # every number as written, to the last digit
    assert stored(tmp_path / "one") == stored(tmp_path / "two")  # and as computed


def test_a_study_uses_every_core_by_default():
    assert every_core(None) == len(os.sched_getaffinity(0)) and every_core(1) == 1
    shown = runner.invoke(app, ["run", "--help"]).output
    assert "default: every core" in shown
