"""A closed-loop study killed with SIGKILL mid-way loses no finished draw: every run stored before
the kill is kept as it was (not computed again) and the rerun computes only the rest."""
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from .conftest import ROOT, TRACKS, TRAINS, write_yaml

DRAWS = 20


def _stored(path):
    """{key: finished} of the runs in the store (none while it does not exist yet)."""
    if not path.exists():
        return {}
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=1.0) as db:
            return dict(db.execute("select key, finished from cases"))
    except sqlite3.OperationalError:  # the table not created yet, or the writer holds it
        return {}


@pytest.mark.slow
def test_a_study_killed_mid_way_keeps_every_finished_draw_and_the_rerun_computes_the_rest(tmp_path):
    study = tmp_path / "kill.yaml"
    write_yaml(study, {"name": "kill", "track": str(TRACKS / "yazhemsky2017_advanced_1km.yaml"),
                       "train": str(TRAINS / "yazhemsky2017_commuter.yaml"), "window_s": [0, 200], "points": 40,
                       "sample_time_s": 0.5, "draws": DRAWS, "seed": 3,
                       "controllers": [{"name": "convex", "kind": "convex"}],
                       "deviations": {"mass": {"low": 0.95, "high": 1.05}}})
    out = tmp_path / "out"
    store = out / "results.sqlite"
    command = [str(Path(sys.executable).parent / "ecostudy"), "simulate", str(study), "--out", str(out), "--no-progress",
               "--no-plot"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    child = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
    deadline = time.monotonic() + 600
    while not _stored(store) and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    os.killpg(child.pid, signal.SIGKILL)  # the study and any worker it started
    child.wait()
    before = _stored(store)
    assert 0 < len(before) < DRAWS, f"the kill did not land mid-study ({len(before)} of {DRAWS} stored)"
    again = subprocess.run(command, env=env, capture_output=True, text=True, timeout=1800)
    assert again.returncode in (0, 1), again.stderr
    after = _stored(store)
    assert len(after) == DRAWS
    assert {key: after[key] for key in before} == before  # the finished draws kept, not computed again
    assert f"{len(before)} already stored, {DRAWS - len(before)} computed now" in again.stdout + again.stderr
    runs = (out / "runs.csv").read_text().splitlines()
    assert len(runs) == DRAWS + 1 and not any(",missing," in row for row in runs)
