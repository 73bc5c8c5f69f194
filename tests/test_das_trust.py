"""Driver advice read as it is: a cruise row of the tool's own advice.csv read back, no gap to an
ATO run that is not ok (or that minimised time, or beside advice that missed its stop), the energy
beside a net-energy gap the net energy, the advice's status always printed, and a train's own
braking level the phases' braking mode (real solves)."""
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.io.loaders import load_train
from ecostudy.ocp.phases import all_modes

from .conftest import STUDIES, TRAINS, load_yaml, write_yaml


def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_advice_with_a_cruise_is_read_back_by_check_and_export(tmp_path):
    """solve writes a cruise row with a target speed and no handle; check and export refused that
    row as an edited file (`handle ... 'nan', '54.0': a handle is a number from -1 to 1`, exit 2)."""
    out = tmp_path / "yaz"
    solved = run("solve", STUDIES / "yazhemsky2017_advanced.yaml", "--das", "phases", "--no-plot", "--out", out)
    assert solved.exit_code == 0, solved.output
    assert "cruise at" in (out / "advice.csv").read_text()
    for args in (("export", out, "--every", "1s"), ("check", out)):
        result = run(*args)
        assert result.exit_code == 0 and "error" not in result.output, result.output


@pytest.mark.flagged_on_purpose  # the ATO run at K = 10 fails its re-simulation
def test_no_gap_against_an_ato_run_that_is_not_ok(tmp_path):
    """K = 10: the ATO run's re-simulation fails (flagged); the advice's -18 % read like a result."""
    result = run("solve", STUDIES / "default.yaml", "--points", 10, "--das", "phases", "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 1, result.output
    assert "(no gap: the ATO run is not ok)" in result.output and "% against ATO" not in result.output, result.output


def test_a_net_energy_gap_stands_beside_the_net_energy(tmp_path):
    """The net-energy study printed the advice's traction kWh (4 % below the ATO's) beside its net
    gap (+20.8 %); the status line was printed only where a marginal energy exists."""
    result = run("solve", STUDIES / "regional_80s.yaml", "--das", "phases", "--no-plot", "--out", tmp_path / "o")
    line = next(x for x in result.output.splitlines() if "driver advice" in x)
    assert "kWh net (" in line and "% against ATO)" in line, line
    window = run("solve", STUDIES / "default.yaml", "--window", "74,80", "--points", 300, "--das", "round", "--no-plot",
                 "--out", tmp_path / "w")
    lines = window.output.splitlines()
    i = next(k for k, x in enumerate(lines) if "driver advice" in x)
    assert lines[i + 1].strip().startswith(("ok", "flagged")), lines[i:i + 2]


def test_the_phases_brake_at_the_trains_own_strongest_level(tmp_path):
    """A train whose advice may brake at half its service braking: phases and minlp advised full
    service braking (-1), a level the train's DAS does not offer."""
    doc = {**load_yaml(TRAINS / "amsterdam_metro.yaml"), "das_handle_levels": [-0.5, 0, 0.5, 1]}
    train = load_train(write_yaml(tmp_path / "half.yaml", doc))
    brakes = [m for m in all_modes(train) if m.kind == "brake"]
    assert [m.level for m in brakes] == [-0.5]
    assert [m.level for m in all_modes(load_train(TRAINS / "amsterdam_metro.yaml")) if m.kind == "brake"] == [-1.0]


@pytest.mark.parametrize("objective", ["time"])
def test_no_gap_against_the_all_out_run(tmp_path, objective):
    result = run("solve", STUDIES / "default.yaml", "--objective", objective, "--points", 300, "--das", "phases",
                 "--no-plot", "--out", tmp_path / "o")
    assert "(no gap: the ATO run minimised time, not energy)" in result.output, result.output
