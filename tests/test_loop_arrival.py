"""What a closed-loop run's arrival says: a run that arrives before its window opens is flagged as a
late one is; a train that never reaches its stop has no arrival time and no lateness; a train that
never moves off is ended after twice the latest arrival and five minutes, not after hours; the energy
statistics of a controller are over its runs that arrived."""
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.columns import with_statistic
from ecostudy.studies.closedloop import trip_limit

from .conftest import TRACKS, TRAINS, write_yaml

COMMUTER = str(TRAINS / "yazhemsky2017_commuter.yaml")


def simulate(tmp_path, study):
    r = CliRunner().invoke(app, ["simulate", str(write_yaml(tmp_path / "loop.yaml", study)), "--out",
                                 str(tmp_path / "o"), "--workers", "1", "--no-progress", "--no-plot"])
    return r, pd.read_csv(tmp_path / "o" / "runs.csv")


@pytest.mark.slow
def test_a_run_that_arrives_before_its_window_opens_is_flagged(tmp_path):
    """RSPC told to aim 25 s before the latest arrival of a window [110, 120] s arrives near 95 s:
    early by about 15 s, flagged (exit 1), where only a late arrival used to count."""
    r, runs = simulate(tmp_path, {"name": "early", "track": str(TRACKS / "yazhemsky2017_advanced_1km.yaml"),
                                  "train": COMMUTER, "window_s": [110, 120], "points": 200, "sample_time_s": 0.1,
                                  "draws": 1, "controllers": [{"name": "rspc_m25", "kind": "rspc",
                                                               "rspc": {"margin_s": 25}}]})
    run = runs.iloc[0]
    assert r.exit_code == 1, r.output
    assert run["arrival_s"] < 105 and abs(run["stop_error_m"]) < 1.0, run.to_dict()
    assert run["status"] == "flagged" and run["reason"].startswith(f"arrived {110 - run['arrival_s']:.2f} s early"), run["reason"]


def test_a_train_that_never_moves_off_is_ended_with_no_arrival(tmp_path):
    """A convex controller given 1 ms per solve never has a plan: the fallback holds the train at the
    first stop. The trip ends at 2 x 60 + 300 = 420 s (420 samples of 1 s), 100 m short, flagged; its
    arrival and lateness are empty (it did not arrive), not the clock at which it was ended."""
    track = write_yaml(tmp_path / "short.yaml", {
        "name": "short", "source": "test", "length_m": 100,
        "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 100}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}], "speed_limits": [{"position_m": 0, "speed_kmh": 60}]})
    r, runs = simulate(tmp_path, {"name": "stuck", "track": str(track), "train": COMMUTER, "window_s": [0, 60],
                                  "points": 20, "sample_time_s": 1.0, "draws": 1,
                                  "controllers": [{"name": "convex_b", "kind": "convex", "time_budget_s": 0.001}]})
    run = runs.iloc[0]
    assert trip_limit(60) == 420.0
    assert r.exit_code == 1, r.output
    assert run["stop_error_m"] == pytest.approx(-100.0) and run["failures_count"] == 420, run.to_dict()
    assert np.isnan(run["arrival_s"]) and np.isnan(run["late_s"]), run.to_dict()
    assert run["reason"].startswith("stopped 100.00 m short of the stop"), run["reason"]


def test_the_energy_statistics_are_over_the_runs_that_arrived(tmp_path):
    """On a 100 m trip the replayed plan drives four draws of a weaker, draggier train: the draw at
    half the traction stands some 11 m short (no trip made), the other three reach their stop. Its
    energy mean, spread and extremes in aggregate.csv are over those three (it was over all four,
    the short trip's traction pulling the mean down), `arrived` counts them beside `runs` and `ok`;
    a convex controller with 1 ms per solve never leaves the platform: no run arrived, its energies
    are empty (they were 0 kWh). The stop error stays over every run."""
    track = write_yaml(tmp_path / "short.yaml", {
        "name": "short", "source": "test", "length_m": 100,
        "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 100}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}], "speed_limits": [{"position_m": 0, "speed_kmh": 60}]})
    r, runs = simulate(tmp_path, {"name": "some_short", "track": str(track), "train": COMMUTER, "window_s": [0, 60],
                                  "points": 20, "sample_time_s": 1.0, "draws": 4, "seed": 7,
                                  "deviations": {"traction": {"low": 0.3, "high": 1.0},
                                                 "resistance": {"low": 1.0, "high": 2.0}},
                                  "controllers": [{"name": "replayed", "kind": "open_loop"},
                                                  {"name": "stuck", "kind": "convex", "time_budget_s": 0.001,
                                                   "sample_time_s": 5.0}]})
    assert r.exit_code == 1, r.output
    aggregate = pd.read_csv(tmp_path / "o" / "aggregate.csv").set_index("controller")
    replayed, stuck = runs[runs.controller == "replayed"], aggregate.loc["stuck"]
    came = replayed[replayed["arrival_s"].notna()]
    assert len(came) == 3 and replayed["stop_error_m"].min() < -5.0, replayed[["reason", "arrival_s"]]
    row = aggregate.loc["replayed"]
    assert (row["runs"], row["arrived"]) == (4, 3) and (stuck["runs"], stuck["arrived"]) == (4, 0), aggregate
    for column in ("traction_energy_kWh", "energy_J_per_kg"):
        for how in ("mean", "min", "max"):
            name = with_statistic(column, how)
            assert row[name] == pytest.approx(getattr(came[column], how)(), rel=1e-4), name
        # runs.csv keeps 6 digits
        assert row[with_statistic(column, "std")] == pytest.approx(came[column].std(ddof=0), rel=1e-4)
        assert row[with_statistic(column, "mean")] > replayed[column].mean() * 1.05  # the short trip left out
        assert stuck[[with_statistic(column, how) for how in ("mean", "std", "min", "max")]].isna().all(), stuck
    assert row["stop_error_min_m"] == pytest.approx(replayed["stop_error_m"].min())  # every run's
    header = next(line for line in r.output.splitlines() if "controller" in line).split()
    assert header[:4] == ["controller", "runs", "ok", "arrived"], header
