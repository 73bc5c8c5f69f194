"""`ecostudy run --dask` stopped by SIGINT or SIGTERM keeps what a study run in local processes keeps
(tests/test_signals.py): exit status 128 + the signal, the one line against the store, no lock,
-wal or temporary file, the rerun computing only the other cases, and the table of the process path.

The scheduler and its two workers (one thread each) run as `dask scheduler` and `dask worker`
processes, not in this test process (no Dask thread left here for the tests that fork)."""
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from ecostudy.io.store import Store
from ecostudy.studies.batch import execute
from ecostudy.studies.cases import expand

from .conftest import ROOT
from .test_batch import same_results
from .test_signals import assert_stopped_cleanly, ecostudy, signalled, study

COUNT, POINTS = 8, 500


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _listening(address, seconds=120):
    host, port = address.removeprefix("tcp://").rsplit(":", 1)
    deadline = time.time() + seconds
    while True:
        try:
            socket.create_connection((host, int(port)), timeout=1).close()
            return
        except OSError:
            if time.time() > deadline:
                raise
            time.sleep(0.2)


@pytest.fixture(scope="module")
def scheduler():
    """The address of a Dask scheduler with two single-threaded workers that import this checkout."""
    pytest.importorskip("distributed", reason="Dask is in the test extra; installed by make test")
    dask = Path(sys.executable).with_name("dask")
    address = f"tcp://127.0.0.1:{_free_port()}"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    quiet = {"cwd": ROOT, "env": env, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL,
             "start_new_session": True}
    started = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", address.rsplit(":", 1)[1],
                                 "--no-dashboard"], **quiet)]
    _listening(address)
    started.append(subprocess.Popen([dask, "worker", address, "--nworkers", "2", "--nthreads", "1",
                                     "--no-dashboard"], **quiet))
    try:
        yield address
    finally:
        for proc in reversed(started):
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


@pytest.fixture(scope="module")
def in_processes(tmp_path_factory):
    """The study's table computed by two local worker processes."""
    folder = tmp_path_factory.mktemp("processes")
    done = ecostudy(["run", study(folder, COUNT, POINTS), "--workers", 2, "--no-progress"])
    _, err = done.communicate(timeout=900)
    assert done.returncode == 0, err
    return pd.read_csv(folder / "out" / "results.csv")


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_dask_study_stopped_by_a_signal_keeps_every_result_that_arrived(scheduler, in_processes, tmp_path, sig):
    out = tmp_path / "out"
    args = ["run", study(tmp_path, COUNT, POINTS), "--dask", scheduler, "--no-progress"]
    proc, _, err, kids, before = signalled(args, out / "results.sqlite", sig, workers=0)
    kept = assert_stopped_cleanly(proc, err, kids, before, out, sig, COUNT, "cases")
    assert not (out / "summary.json").exists()
    again = ecostudy(args)
    stdout, err = again.communicate(timeout=900)
    assert again.returncode == 0, err
    assert f"{COUNT} cases: {kept} already stored, {COUNT - kept} computed now (0 of them failed" in stdout
    assert same_results(pd.read_csv(out / "results.csv"), in_processes)


@pytest.mark.slow
def test_results_that_reached_the_client_while_it_stored_a_case_are_stored(scheduler, tmp_path):
    """SIGINT while the main process is busy with a case it took from the cluster (its progress
    callback waits for the other cases to finish): the results finished on the cluster meanwhile are
    fetched and stored too (as tests/test_signals.py checks for local processes)."""
    _, _, cases = expand(study(tmp_path, 3, points=30))
    store = Store(tmp_path / "results.sqlite")

    def progress(done, failed, remaining, total):
        if done == 1:
            time.sleep(20)  # the two other cases finish on the cluster meanwhile (0.1 s each at K = 30)
            os.kill(os.getpid(), signal.SIGINT)
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)  # a runner started in the background ignores it
    try:
        with pytest.raises(KeyboardInterrupt) as stop:
            execute(cases, store, dask=scheduler, progress=progress)
        assert store.finished_keys() == {c["key"] for c in cases}
        assert stop.value.counts == {"total": 3, "stored_before": 0, "computed": 3, "failed": 0}
    finally:
        signal.signal(signal.SIGINT, inherited)
        store.close()
