"""A closed-loop run whose controller's solves gave no usable plan (the fallback drove those samples)
is flagged with the count, never ok: the run's numbers are the plant's, but not the controller's."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import TRAINS, write_yaml


@pytest.mark.slow
def test_a_run_driven_by_its_fallback_is_flagged(tmp_path):
    """A 20 km/h restriction from 850 m to the stop at 1000 m, SPPC with the terminal approach and a
    window to 115 s: five of its solves end without a plan near the stop (samples 160-166), the
    shifted plan drives them, and the run stops within 0.2 m on time: flagged for the solves."""
    track = write_yaml(tmp_path / "restriction.yaml", {
        "name": "restriction", "source": "test", "length_m": 1200,
        "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1000}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 64.8}, {"position_m": 850, "speed_kmh": 20}]})
    study = write_yaml(tmp_path / "loop.yaml", {
        "name": "restriction_loop", "track": str(track), "train": str(TRAINS / "yazhemsky2017_commuter.yaml"),
        "window_s": [0, 115], "points": 100, "sample_time_s": 0.5, "draws": 1,
        "controllers": [{"name": "sppc_term", "kind": "sppc", "terminal_reserve": 0.2}]})
    r = CliRunner().invoke(app, ["simulate", str(study), "--out", str(tmp_path / "o"), "--workers", "1",
                                 "--no-progress", "--no-plot"])
    assert r.exit_code == 1, r.output
    run = pd.read_csv(tmp_path / "o" / "runs.csv").iloc[0]
    assert run["failures_count"] > 0 and run["status"] == "flagged", run.to_dict()
    assert f"{run['failures_count']} solves in " in run["reason"] and "gave no usable plan" in run["reason"], run["reason"]
    assert abs(run["stop_error_m"]) < 1.0 and run["late_s"] < 1.0  # it stopped, on time: only the solves flag it
