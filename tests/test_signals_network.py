"""`ecostudy network --workers 2` stopped by SIGINT or SIGTERM: its strategies run in threads of the
main process, their legs in one shared pool of worker processes (:mod:`ecostudy.studies.legpool`).
The promises of tests/test_signals.py hold there too: exit status 128 + the signal, the one line
against the store, no worker left running, no lock, -wal or temporary file, the rerun computing only
the other strategies, and the table of a run that was never stopped."""
import signal

import pandas as pd
import pytest

from .conftest import STUDIES
from .test_signals import assert_stopped_cleanly, ecostudy, signalled
from .test_study_shape import NETWORK_NUMBERS, same_table

STRATEGIES = 7  # studies/network_metro_2trains.yaml


def network(out):
    return ["network", STUDIES / "network_metro_2trains.yaml", "--workers", 2, "--no-plot", "--out", out]


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """The study's table from a run that was not stopped."""
    out = tmp_path_factory.mktemp("whole") / "out"
    done = ecostudy(network(out))
    _, err = done.communicate(timeout=1800)
    assert done.returncode == 0, err
    return pd.read_csv(out / "network_substation.csv").drop(columns=["wall_s"])


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_network_study_stopped_by_a_signal_keeps_every_strategy_that_arrived(whole, tmp_path, sig):
    out = tmp_path / "out"
    proc, _, err, kids, before = signalled(network(out), out / "results.sqlite", sig, timeout=1200)
    kept = assert_stopped_cleanly(proc, err, kids, before, out, sig, STRATEGIES, "strategies")
    assert not (out / "summary.json").exists()
    again = ecostudy(network(out))
    stdout, err = again.communicate(timeout=1800)
    assert again.returncode == 0, err
    assert f"{STRATEGIES} strategies: {kept} already stored, {STRATEGIES - kept} computed now" in stdout
    assert same_table(pd.read_csv(out / "network_substation.csv").drop(columns=["wall_s"]), whole, NETWORK_NUMBERS)
