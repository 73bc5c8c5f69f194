"""A --dask that is not a scheduler address is refused in one line, exit status 2, before anything
is computed or written: by every command that takes --dask, and by the functions behind them."""
import pytest
from typer.testing import CliRunner

from ecostudy import api
from ecostudy.cli import app

from .conftest import TRACKS, TRAINS

ROOT = TRACKS.parent
METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"
COMMANDS = {"run": [ROOT / "studies/default.yaml"], "pareto": ["--track", AMS, "--train", METRO],
            "compare": ["--track", AMS, "--train", METRO, "--time", 80],
            "network": [ROOT / "studies/network_metro_2trains.yaml"],
            "heavyhaul": [ROOT / "studies/heavyhaul_brake_penalty.yaml"],
            "simulate": [ROOT / "studies/yazhemsky2017_closed_loop.yaml"]}


@pytest.mark.parametrize("command", COMMANDS)
def test_a_bad_dask_address_is_refused_before_anything_is_written(command, tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(app, [command, *map(str, COMMANDS[command]), "--dask", "nope", "--out", str(out)])
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert errors == ["error: command line: --dask: expected a scheduler address tcp://host:port, got 'nope'"], \
        result.output
    assert not out.exists()


def test_pareto_folder_refuses_the_address_before_its_store(tmp_path):
    with pytest.raises(api.InputError, match="arguments: dask: expected a scheduler address"):
        api.pareto_folder(track=AMS, train=METRO, dask="nope", out=tmp_path / "out", plot=False)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", COMMANDS)
def test_an_address_nothing_answers_at_is_refused_before_anything_is_computed(command, tmp_path):
    """A well-formed address with no scheduler behind it: refused in one line before the command
    computes anything (the network study solved its fleet's first runs before Dask's client found
    the address dead)."""
    out = tmp_path / "out"
    result = CliRunner().invoke(app, [command, *map(str, COMMANDS[command]), "--dask", "tcp://127.0.0.1:1", "--out", str(out)])
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and errors[0].startswith(
        "error: command line: --dask: cannot reach the Dask scheduler at tcp://127.0.0.1:1"), result.output
    assert not out.exists()


def test_a_port_past_65535_is_no_address():
    """tcp://host:99999 matched the address pattern and was tried on another port (99999 - 65536)."""
    with pytest.raises(api.InputError, match="expected a scheduler address tcp://host:port, got 'tcp://127.0.0.1:99999'"):
        api.pareto_folder(track=AMS, train=METRO, dask="tcp://127.0.0.1:99999", plot=False)

