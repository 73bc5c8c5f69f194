"""A closed-loop run whose controller's solves gave no usable plan (the fallback drove those samples)
is flagged with the count, never ok: the run's numbers are the plant's, but not the controller's."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.studies.closedloop import expand, run_loop_case

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml


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
    assert f"{run['failures_count']} solves gave no usable plan in " in run["reason"], run["reason"]
    assert abs(run["stop_error_m"]) < 1.0 and run["late_s"] < 1.0  # it stopped, on time: only the solves flag it


def test_an_rspc_sample_without_an_admissible_sequence_is_not_said_to_be_out_of_time(tmp_path):
    """Draw 62 of metro_monte_carlo.yaml's RSPC: on one of its 199 samples no mode sequence was
    admissible and the fallback braked in full; it stops 0.14 m short, on time. Flagged for that
    sample, as it was, but the reason said the solve gave no plan "in time": RSPC has no solver and
    the study no time_budget_s."""
    doc = load_yaml(STUDIES / "metro_monte_carlo.yaml")
    doc.update(track=str(TRACKS / "amsterdam_rokin_centraal.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"),
               draws=63, controllers=[c for c in doc["controllers"] if c["name"] == "rspc"])
    case = next(c for c in expand(write_yaml(tmp_path / "mc.yaml", doc), tmp_path / "o")[2] if c["labels"]["draw"] == 62)
    run = run_loop_case(case)
    status, reason, summary = run["status"], run["error"], run["summary"]
    assert summary["failures_count"] == 1 and summary["over_time_budget_count"] == 0, summary["failures_count"]
    assert status == "flagged" and abs(summary["stop_error_m"]) < 1.0 and not summary["late_s"], summary
    assert reason == "1 solve gave no usable plan in 199 samples (the fallback drove them)", reason
