"""A network study's strategies share one pool of worker processes for their legs
(``studies.legpool``): the same results, bit for bit, as one process; a resumed study with one
strategy left still spreads its legs."""
import json
import multiprocessing
import os
import signal
import sqlite3
import time

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.studies import kinds  # noqa: F401  (registers the built-in study kinds)
from ecostudy.studies.batch import kind_named, outcome
from ecostudy.studies.legpool import shared_pool

from .conftest import TRACKS, TRAINS, write_yaml

runner = CliRunner()
TIMED = ["wall_s"]  # wall times: the only columns that may differ from run to run


def two_leg_study(folder):
    """Two metro trains 45 s apart over two segments (two legs each: a train's legs go to both
    workers), four strategies: the independent runs, a supervisor rule's rounds, the joint optimum
    (whole, in one worker) and following."""
    return write_yaml(folder / "net.yaml", {
        "name": "spread", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station", "Centrum"], "running_times_s": [56.0, 110.0], "dwell_s": 10,
        "time_step_s": 1.0, "trains": [{"name": "A", "offset_s": 0}, {"name": "B", "offset_s": 45}],
        "substation": {"position_m": 1500}, "strategies": ["independent", "triggering", "joint", "following"],
        "buffer_m": 60, "points": 300, "output": str(folder / "out")})


def table(study, out, workers):
    r = runner.invoke(app, ["network", str(study), "--out", str(out), "--no-plot", "--workers", workers])
    assert r.exit_code == 0, r.output
    return pd.read_csv(out / "network_substation.csv", dtype=str, keep_default_na=False).drop(columns=TIMED)


def stored(out):
    """{key: stored summary} at full precision, wall times left out."""
    with sqlite3.connect(out / "results.sqlite") as db:
        rows = dict(db.execute("SELECT key, summary FROM cases").fetchall())
    summaries = {key: json.loads(text) for key, text in rows.items()}
    for summary in summaries.values():
        summary["totals"].pop("wall_s")
        for timed in ("build_s", "solve_s"):  # the joint optimum's
            summary["info"].pop(timed, None)
    return summaries


@pytest.mark.slow
def test_strategies_sharing_a_pool_give_the_results_of_one_process(tmp_path):
    study = two_leg_study(tmp_path)
    one = table(study, tmp_path / "one", "1")
    two = table(study, tmp_path / "two", "2")
    assert list(one["strategy"]) == ["independent", "triggering", "joint", "following"]
    assert (one["status"] == "ok").all(), one
    pd.testing.assert_frame_equal(one, two)  # every number as written, to the last digit
    assert stored(tmp_path / "one") == stored(tmp_path / "two")  # and as computed
    # resumed with one strategy left: it runs alone, its legs still spread over both workers
    with sqlite3.connect(tmp_path / "two" / "results.sqlite") as db:
        db.execute("DELETE FROM cases WHERE key = (SELECT key FROM cases WHERE summary LIKE '%rounds_substation%')")
    again = table(study, tmp_path / "two", "2")
    pd.testing.assert_frame_equal(one, again)
    assert stored(tmp_path / "one") == stored(tmp_path / "two")


def test_the_network_kind_spreads_and_the_pool_runs_every_case_once():
    assert kind_named("network").spread is not None and kind_named("run").spread is None
    seen = list(shared_pool([3, 1, 2], 2, lambda case, pool: pool.submit(pow, case, 2).result(), first=lambda c: -c))
    assert sorted(seen) == [(1, 1), (2, 4), (3, 9)]


def test_the_pool_workers_outlive_the_case_threads():
    """A worker dies with the thread that forked it (the parent-death signal follows the thread): the
    shared pool forks its workers from its own thread, so they end at the pool's shutdown (exit code
    0), not killed when the case threads end (-SIGTERM; once while holding the task queue's lock,
    which hung the pool's shutdown)."""
    workers = []

    def task(case, pool):
        result = pool.submit(pow, case, 2).result()
        # the pool's workers by the IDs it exposes (WorkerPool.started), as this process's children (the
        # multiprocessing.Process objects whose exit codes are read once the pool has ended)
        pids = pool.started()
        workers.extend(p for p in multiprocessing.active_children() if p.pid in pids)
        return result

    assert sorted(shared_pool([1, 2, 3], 2, task)) == [(1, 1), (2, 4), (3, 9)]
    assert workers and all(w.exitcode == 0 for w in workers), [w.exitcode for w in workers]


def _leg(key):
    """A leg that kills its worker process (SIGKILL, as the out-of-memory killer sends) for the case
    'x'; the others take 0.2 s."""
    if key == "x":
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.2)
    return os.getpid()


def _case(case, pool):
    return outcome(case, lambda: ("ok", None, {"pid": pool.submit(_leg, case["key"]).result()}))


def test_a_leg_that_kills_its_worker_fails_its_own_case_and_the_others_run_again():
    """A worker killed in one case's leg broke the shared pool: every strategy with legs left failed
    with BrokenProcessPool (killed by hand on the 2-train metro study: four of seven strategies
    failed). Now the cases failed by the broken pool run again in a new one, then each alone; only
    the case whose own leg kills its worker is failed, with the reason."""
    cases = [{"key": k} for k in "abxcd"]
    seen = dict((case["key"], result) for case, result in shared_pool(cases, 2, _case))
    assert sorted(seen) == list("abcdx")
    assert seen["x"]["status"] == "failed" and "worker process died" in seen["x"]["error"], seen["x"]
    assert all(seen[k]["status"] == "ok" for k in "abcd"), seen
