"""Closed-loop and heavy-haul studies use every core by default, and their results do not depend on
the number of worker processes, bit for bit: only what is measured differs (wall and per-step solve
times, the runs over their real-time budget that count them, a process's peak memory).

Which runs share a worker depends on the pool; a worker keeps what it solved for an earlier run
(the closed-loop start, the heavy-haul QP's structure), so a result that leaked from one run into
the next would show here."""
import json
import sqlite3

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import write_yaml
from .test_heavyhaul_study import study as heavy_study
from .test_simulate import study as loop_study

runner = CliRunner()
# measured, not computed: wall and solve times, solves over their budget, peak memory
LOOP_TIMED = {"wall_s", "solve_mean_ms", "solve_p95_ms", "solve_max_ms", "over_budget_count", "solve_ms",
              "solve_mean_mean_ms", "solve_p95_max_ms", "solve_max_max_ms", "over_budget_count_sum"}
HEAVY_TIMED = {"wall_s", "solve_mean_ms", "solve_p95_ms", "solve_max_ms", "over_budget_count", "peak_memory_MB"}


def table(path, timed):
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    return frame.drop(columns=[c for c in frame if c in timed])


def stored(out, timed):
    """{key: (status, reason, summary)} as computed (full precision), measured numbers left out."""
    with sqlite3.connect(out / "results.sqlite") as db:
        rows = db.execute("SELECT key, status, error, summary FROM cases").fetchall()

    def computed(summary):
        summary = json.loads(summary)
        steps = summary.get("steps") or {}
        return {k: v for k, v in {**summary, "steps": {k: v for k, v in steps.items() if k not in timed}}.items()
                if k not in timed}
    return {key: (status, error, computed(summary)) for key, status, error, summary in rows}


def ran(command, path, out, *workers):
    result = runner.invoke(app, [command, str(path), "--out", str(out), "--no-progress", "--no-plot", *workers])
    assert result.exit_code in (0, 1), result.output  # 1: a run flagged (the replayed plan overruns the stop)
    return result


def test_a_closed_loop_study_gives_the_same_results_with_one_and_two_workers(tmp_path):
    """Two controllers x two draws (a convex controller with an estimator, a replayed plan)."""
    path = loop_study(tmp_path)
    ran("simulate", path, tmp_path / "one", "--workers", "1")
    ran("simulate", path, tmp_path / "two", "--workers", "2")
    one, two = tmp_path / "one", tmp_path / "two"
    runs = table(one / "runs.csv", LOOP_TIMED)
    assert len(runs) == 4
    # the convex runs ok (every plan Solved), the replayed plan flagged for its stop
    assert dict(zip(runs["controller"], runs["status"])) == {"convex": "ok", "replayed": "flagged"}, runs["reason"]
    pd.testing.assert_frame_equal(runs, table(two / "runs.csv", LOOP_TIMED))  # to the last digit written
    pd.testing.assert_frame_equal(table(one / "aggregate.csv", LOOP_TIMED), table(two / "aggregate.csv", LOOP_TIMED))
    for steps in sorted((one / "steps").glob("*.csv")):
        pd.testing.assert_frame_equal(table(steps, LOOP_TIMED), table(two / "steps" / steps.name, LOOP_TIMED))
    assert stored(one, LOOP_TIMED) == stored(two, LOOP_TIMED)  # and as computed


@pytest.mark.slow  # 29 s on the busy shared machine (two references, four runs)
def test_a_heavy_haul_study_gives_the_same_results_with_one_and_two_workers(tmp_path):
    """Two K_b on a 2 km line (its reference solved once, when the study is expanded)."""
    line = write_yaml(tmp_path / "short.yaml", {
        "name": "2 km heavy-haul line", "source": "test", "length_m": 3000,
        "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 2000}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}, {"position_m": 800, "gradient_permille": 5},
                      {"position_m": 1400, "gradient_permille": -5}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 50}]})
    path = heavy_study(tmp_path, track=str(line), reference={"supplement_percent": 10, "points": 60})
    ran("heavyhaul", path, tmp_path / "one", "--workers", "1")
    ran("heavyhaul", path, tmp_path / "two", "--workers", "2")
    runs = table(tmp_path / "one" / "runs.csv", HEAVY_TIMED)
    assert len(runs) == 2 and (runs["arrived"] == "True").all()
    pd.testing.assert_frame_equal(runs, table(tmp_path / "two" / "runs.csv", HEAVY_TIMED))
    assert stored(tmp_path / "one", HEAVY_TIMED) == stored(tmp_path / "two", HEAVY_TIMED)


def test_simulate_and_heavyhaul_use_every_core_by_default_and_say_how_to_time_steps_on_a_quiet_machine():
    for command in ("simulate", "heavyhaul"):
        shown = " ".join(runner.invoke(app, [command, "--help"], terminal_width=200).output.split())
        assert "default: every core" in shown and "--workers 1" in shown, shown
