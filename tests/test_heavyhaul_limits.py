"""A heavy-haul run meets a drop of the speed limit: the reference reaches the lower limit a sample
(Ts of running at it) before the drop, so a controller that tracks v_r only at its samples does not
cross the drop over the limit (Zhang & Zhuan's own run overshoots where its profile "drops
instantly"); and the arrival against the reference's running time is checked."""
import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.types import Track
from ecostudy.heavyhaul.reference import advanced_limits

from .conftest import write_yaml
from .test_heavyhaul_study import PAPER

runner = CliRunner()


def test_each_drop_moves_a_lead_of_running_at_the_lower_limit_towards_the_start():
    """Limits 20, 30, 10, 25, 15 m/s from 0, 2000, 5000, 5100, 8000 m, a lead of 20 s. Forward: the
    drop to 10 m/s moves 200 m (to 4800 m), the 25 m/s piece 500 m (to 4600 m, below the 30 before
    it), the drop to 15 m/s 300 m; rises stay. Backward (towards lower positions) the rises become
    drops: 30 -> 20 at 2000 m moves 400 m to 2400 m, 25 -> 10 at 5100 m moves 200 m to 5300 m."""
    zero = np.zeros(1)
    track = Track("t", 10000.0, {}, zero, zero, zero, zero, np.array([0.0, 2000, 5000, 5100, 8000]),
                  np.array([20.0, 30, 10, 25, 15]))
    ahead = advanced_limits(track, 20.0)
    assert ahead.limit_positions.tolist() == [0, 2000, 4600, 4800, 5100, 7700]
    assert ahead.limits.tolist() == [20, 30, 25, 10, 25, 15]
    back = advanced_limits(track, 20.0, forward=False)
    assert back.limit_positions.tolist() == [0, 2400, 5000, 5300, 8000]
    assert back.limits.tolist() == [20, 30, 10, 25, 15]
    assert advanced_limits(track, 0.0) is track


def drop_study(tmp_path, reference=None, **changes):
    """A 2 + 20 + 2 ore train on 7 km from rest to rest, 70 km/h dropping to 45 km/h at 4.5 km on a
    3 per-mille descent, Np = Nc = 1 (the shortest look ahead), K_b = 60, f = 10."""
    consist = yaml.safe_load(PAPER.read_text())
    consist["vehicles"][1]["count"] = 20
    write_yaml(tmp_path / "small.yaml", consist)
    track = {"name": "drop line", "source": "test", "length_m": 8000,
             "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 7000}],
             "gradients": [{"position_m": 0, "gradient_permille": 0}, {"position_m": 3000, "gradient_permille": -3}],
             "speed_limits": [{"position_m": 0, "speed_kmh": 70}, {"position_m": 4500, "speed_kmh": 45}]}
    write_yaml(tmp_path / "line.yaml", track)
    doc = {"name": "drop", "consist": str(tmp_path / "small.yaml"), "track": str(tmp_path / "line.yaml"),
           "from": "A", "to": "B", "reference": {"supplement_percent": 10, "points": 150, **(reference or {})},
           "brake_penalty": [60], "fence": [10], "horizons": [{"np": 1, "nc": 1}], **changes}
    write_yaml(tmp_path / "hh.yaml", doc)
    return tmp_path / "hh.yaml"


def run(tmp_path, study, name, *extra):
    result = runner.invoke(app, ["heavyhaul", str(study), "--out", str(tmp_path / name), "--no-progress", "--no-plot",
                                 *extra])
    return result, pd.read_csv(tmp_path / name / "runs.csv").iloc[0]


def test_a_limit_drop_is_crossed_at_the_lower_limit(tmp_path):
    """With the reference at 45 km/h a sample (250 m) before the drop, no car runs more than the 1
    km/h tolerance over it (0.0007 km/h measured), the train stops on the mark and arrives within the
    arrival tolerance (26.3 s, 5.0 % late: under 60 s, so ok although over 5 %), and this short train
    asks its locomotives for less than their wheels hold (0.66 of mu(v) m g at most, measured; the
    paper's plant, adhesion off): the run is ok."""
    result, row = run(tmp_path, drop_study(tmp_path), "out")
    assert result.exit_code == 0, result.output
    assert row["status"] == "ok" and row["speed_excess_kmh"] < 1.0 and abs(row["stop_error_m"]) < 1.0
    assert row["adhesion_use_max"] <= 1.01
    assert 0 < row["arrival_late_s"] < 60 and row["arrival_late_s"] == pytest.approx(row["arrival_s"] - row["reference_time_s"], abs=0.01)
    assert row["arrival_late_pct"] == pytest.approx(100 * row["arrival_late_s"] / row["reference_time_s"], abs=0.01)


@pytest.mark.slow  # about 15 s on a loaded machine
def test_a_reference_that_drops_at_the_limit_is_overrun_and_a_late_arrival_flagged(tmp_path):
    """The reference reaching 45 km/h only at the drop (``limit_lead_samples: 0``): the controller
    brakes to it at the first sample past the drop and a car crosses it some km/h over; with an
    arrival tolerance of 0 % the (late) arrival is a second reason."""
    study = drop_study(tmp_path, {"limit_lead_samples": 0}, arrival_tolerance_percent=0, arrival_tolerance_s=0)
    result, row = run(tmp_path, study, "at_drop")
    assert result.exit_code == 1, result.output
    assert row["status"] == "flagged" and row["speed_excess_kmh"] > 2.0, row["reason"]
    late, share = row["arrival_late_s"], row["arrival_late_pct"]
    assert late > 0 and row["reason"] == (
        f"arrived {late:.0f} s ({share:.1f} %) after the reference's running time (tolerance 0 % or 0 s, the larger); "
        f"a car ran {row['speed_excess_kmh']:.1f} km/h over the line's limit (tolerance 1 km/h)")
