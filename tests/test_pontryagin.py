"""The Pontryagin regime check (thesis 000 eq. 2.17) on optimal runs of every shipped case."""
import numpy as np
import pytest

from ecostudy.inputs import Timing, load_track, load_train
from ecostudy.run import solve_run

from .conftest import TRACKS, TRAINS

CASES = [("amsterdam_metro", "amsterdam_rokin_centraal", "Rokin", "Centraal", 76.0),
         ("regional_alstom", "regional_808m", "Origin", "Destination", 80.0),
         ("thesis001_commuter", "thesis001_flat_1km", "A", "B", 77.99),
         ("thesis001_commuter", "thesis001_advanced_1km", "A", "B", 84.92)]


@pytest.mark.parametrize("train, track, a, b, time", CASES, ids=[c[1] for c in CASES])
def test_optimal_runs_obey_the_switching_conditions(train, track, a, b, time):
    r = solve_run(load_track(TRACKS / f"{track}.yaml"), load_train(TRAINS / f"{train}.yaml"), a, b,
                  Timing(running_time=time), points=500)
    check = r.summary["pontryagin"]
    assert check["agreement_pct"] >= 95.0, check["disagreements"]


def test_costate_ratio_per_regime_on_the_flat_trip():
    """MA where psi > 1, CR where psi = 1, CO in (0, 1), MB where psi < 0 (lambda / v of eq. 2.17)."""
    r = solve_run(load_track(TRACKS / "thesis001_flat_1km.yaml"), load_train(TRAINS / "thesis001_commuter.yaml"),
                  "A", "B", Timing(running_time=95.0), points=300)
    psi = r.profile["costate_ratio"].to_numpy()[:-1]
    for run in r.summary["regimes"]["runs"]:
        sel = (r.nodes[:-1] >= run["start_m"]) & (r.nodes[:-1] < run["end_m"])
        inner = psi[sel][1:-1]  # the run's first and last interval may hold a switch
        if inner.size == 0:
            continue
        if run["regime"] == "MA":
            assert np.all(inner >= 1 - 1e-6)
        elif run["regime"] == "CR":
            assert np.allclose(inner, 1, atol=1e-4)
        elif run["regime"] == "CO":
            assert np.all((inner > -1e-6) & (inner < 1 + 1e-6))
        elif run["regime"] == "MB":
            assert np.all(inner <= 1e-6)


def test_all_out_and_net_energy_runs_carry_no_energy_costate():
    r = solve_run(load_track(TRACKS / "regional_808m.yaml"), load_train(TRAINS / "regional_alstom.yaml"),
                  "Origin", "Destination", Timing(), objective="time", points=200)
    assert r.summary["pontryagin"] is None


def test_check_command_passes_an_optimum_and_rejects_a_poor_profile(tmp_path):
    """`ecostudy check`: the optimum agrees; the all-out run offered as the energy-optimal run for
    a slack running time is reported inconsistent, with positions (exit 1)."""
    import json

    from typer.testing import CliRunner

    from ecostudy.cli import app
    runner = CliRunner()
    args = ["--track", str(TRACKS / "regional_808m.yaml"), "--train", str(TRAINS / "regional_alstom.yaml"),
            "--points", "300", "--no-plot"]
    assert runner.invoke(app, ["solve", *args, "--time", "75", "--out", str(tmp_path / "opt")]).exit_code == 0
    ok = runner.invoke(app, ["check", str(tmp_path / "opt")])
    assert ok.exit_code == 0, ok.output
    assert json.loads((tmp_path / "opt" / "check.json").read_text())["agreement_pct"] >= 95
    assert runner.invoke(app, ["solve", *args, "--objective", "time", "--out", str(tmp_path / "ao")]).exit_code == 0
    own = runner.invoke(app, ["check", str(tmp_path / "ao")])  # the all-out run IS optimal for its own time
    assert own.exit_code == 0, own.output
    t_ao = json.loads((tmp_path / "ao" / "summary.json").read_text())["running_time_s"]
    poor = runner.invoke(app, ["check", str(tmp_path / "ao"), "--time", f"{1.1 * t_ao:.2f}"])
    assert poor.exit_code == 1, poor.output
    report = json.loads((tmp_path / "ao" / "check.json").read_text())
    assert report["agreement_pct"] < 50
    assert report["disagreements"] and "inconsistent: MA at 0-" in poor.output
