"""A study stopped by SIGTERM, SIGHUP or SIGINT sent to its main process alone (`kill PID`) or to its process
group (`timeout`, systemd, a batch scheduler; a closed terminal or SSH session): exit status 128 + the signal, one line saying what was kept, every
case that reached the main process stored, no worker left running, no temporary file, no lock
file; the same command again computes only the other cases."""
import glob
import os
import re
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from contextlib import closing

import pytest

from ecostudy.io.store import Store
from ecostudy.studies.batch import execute, run_case
from ecostudy.studies.workers import worker_pool
from ecostudy.studies.cases import expand

from .conftest import ROOT, TRACKS, TRAINS, write_yaml


def stored(db):
    """Cases in the store (read-only, once the study has put it in WAL mode), or 0."""
    if not db.with_name(db.name + "-wal").exists():
        return 0
    try:
        with closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True)) as conn:
            return conn.execute("SELECT count(*) FROM cases").fetchone()[0]
    except sqlite3.OperationalError:  # busy, or the table not there yet
        return 0


def children(pid):
    """The PIDs of a process's children, from every one of its threads."""
    kids = set()
    for path in glob.glob(f"/proc/{pid}/task/*/children"):
        try:
            kids |= {int(k) for k in open(path).read().split()}
        except OSError:  # a thread that ended meanwhile
            pass
    return kids


def running(pid):
    """Whether a process exists and is not a zombie."""
    try:
        return open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def ecostudy(args):
    """``python -m ecostudy *args`` in its own process group (a signal to it reaches it alone, not
    this test run), SIGINT not ignored (as a runner started in the background would have it)."""
    def start():
        os.setsid()
        signal.signal(signal.SIGINT, signal.SIG_DFL)
    return subprocess.Popen([sys.executable, "-m", "ecostudy", *map(str, args)], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=start)


def signalled(args, db, sig, workers=2, timeout=300, group=False):
    """Start a study, send ``sig`` to its main process (``group``: to its whole process group, as
    ``timeout``, systemd and batch schedulers do) once the store holds a case; returns (the
    finished process, its stdout and stderr, the worker PIDs seen before the signal, cases stored
    when the signal was sent)."""
    proc = ecostudy(args)
    deadline, kids, before = time.time() + timeout, set(), 0
    while time.time() < deadline and proc.poll() is None:
        kids |= children(proc.pid)
        before = stored(db)
        if before >= 1:
            break
        time.sleep(0.05)
    kids |= children(proc.pid)
    assert proc.poll() is None, proc.communicate()
    assert len(kids) >= workers, f"the workers were not seen: {kids}"
    (os.killpg if group else os.kill)(proc.pid, sig)
    out, err = proc.communicate(timeout=120)
    return proc, out, err, kids, before


def assert_stopped_cleanly(proc, err, kids, before, folder, sig, total, noun):
    """What every interrupted study must show; returns the cases stored."""
    if proc.returncode in (0, 1):
        pytest.fail("the study finished before it could be interrupted")
    assert proc.returncode == 128 + sig, err
    assert "Traceback" not in err, err
    line = re.search(rf"warning: interrupted by {signal.Signals(sig).name}: (\d+) of {total} {noun} stored "
                     r"\((\d+) of them computed now\); run the same command again to continue", err)
    assert line, err
    assert [k for k in kids if running(k)] == [], "a worker outlived the command"
    names = sorted(p.name for p in folder.iterdir())
    assert not {"results.sqlite.lock", "results.sqlite-wal"} & set(names), names
    assert not [n for n in names if n.endswith(".tmp")], names
    with closing(sqlite3.connect(folder / "results.sqlite")) as conn:
        kept = conn.execute("SELECT count(*) FROM cases").fetchone()[0]
    assert int(line.group(1)) == int(line.group(2)) == kept  # the line says what the store holds
    assert before <= kept < total
    return kept


def study(tmp_path, count, points=1000):
    return write_yaml(tmp_path / "study.yaml", {
        "name": "signalled", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
        "train": str(TRAINS / "amsterdam_metro.yaml"), "from": "Rokin", "to": "Centraal",
        "supplement_percent": 10, "points": points,
        "sweep": {"supplement_percent": list(range(2, 2 + count))}, "output": str(tmp_path / "out")})


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
@pytest.mark.parametrize("group", [False, True], ids=["main process", "process group"])
def test_sigterm_keeps_every_finished_case_and_stops_the_workers(tmp_path, group, sig):
    """SIGHUP (the terminal or SSH session closed) as SIGTERM: exit status 129 against 143."""
    out = tmp_path / "out"
    args = ["run", study(tmp_path, 10), "--workers", 2, "--no-progress"]
    proc, _, err, kids, before = signalled(args, out / "results.sqlite", sig, group=group)
    kept = assert_stopped_cleanly(proc, err, kids, before, out, sig, 10, "cases")
    assert not (out / "summary.json").exists()  # no table or summary of a part of the study
    again = ecostudy(args)
    stdout, err = again.communicate(timeout=600)
    assert again.returncode == 0, err
    assert f"10 cases: {kept} already stored, {10 - kept} computed now (0 of them failed" in stdout


@pytest.mark.slow
def test_sigint_to_the_main_process_of_a_front_keeps_every_finished_point(tmp_path):
    out = tmp_path / "front"
    args = ["pareto", "--track", TRACKS / "amsterdam_rokin_centraal.yaml", "--train", TRAINS / "amsterdam_metro.yaml",
            "--count", 10, "--points", 1000, "--workers", 2, "--no-plot", "--out", out]
    proc, _, err, kids, before = signalled(args, out / "results.sqlite", signal.SIGINT)
    kept = assert_stopped_cleanly(proc, err, kids, before, out, signal.SIGINT, 10, "points")
    again = ecostudy(args)
    stdout, err = again.communicate(timeout=600)
    assert again.returncode == 0, err
    assert f"10 points: {kept} already stored, {10 - kept} computed now (0 failed)" in stdout


HUNG_UP = """
import signal, sys, time
from ecostudy.core.interrupt import exit_status, stopped_by_signals
with stopped_by_signals():
    try:
        signal.raise_signal(signal.SIGHUP)
        time.sleep(0.5)
    except KeyboardInterrupt:
        sys.exit(exit_status())
print("kept on")
"""


@pytest.mark.parametrize("nohup", [False, True], ids=["terminal", "nohup"])
def test_sighup_stops_a_command_unless_it_was_started_with_nohup(nohup):
    """SIGHUP raises KeyboardInterrupt as SIGTERM does, exit status 129; a command started with
    ``nohup`` (SIGHUP inherited ignored) keeps it ignored and goes on."""
    def start():
        signal.signal(signal.SIGHUP, signal.SIG_IGN if nohup else signal.SIG_DFL)
    r = subprocess.run([sys.executable, "-c", HUNG_UP], cwd=ROOT, capture_output=True, text=True, timeout=60,
                       preexec_fn=start)
    assert (r.returncode, r.stdout) == ((0, "kept on\n") if nohup else (128 + signal.SIGHUP, "")), r.stderr


def test_results_that_reached_the_main_process_while_it_stored_a_case_are_stored(tmp_path):
    """SIGINT while the main process is busy with a case it took (here: its progress callback, which
    waits for the other cases to finish in the workers and their results to reach it): those results
    are stored too, not only the cases it had taken."""
    _, _, cases = expand(study(tmp_path, 3, points=30))
    store = Store(tmp_path / "results.sqlite")

    def progress(done, failed, remaining, total):
        if done == 1:
            time.sleep(10)  # the two other cases finish meanwhile (0.1 s each at K = 30)
            os.kill(os.getpid(), signal.SIGINT)
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)  # a runner started in the background ignores it
    try:
        with pytest.raises(KeyboardInterrupt) as stop:
            execute(cases, store, workers=2, progress=progress)
        assert store.finished_keys() == {c["key"] for c in cases}
        assert stop.value.counts == {"total": 3, "stored_before": 0, "computed": 3, "failed": 0}
    finally:
        signal.signal(signal.SIGINT, inherited)
        store.close()


def test_workers_left_by_an_interrupt_are_killed_not_waited_for(tmp_path):
    """The cases the workers compute when an interrupt leaves the pool are lost: the workers are
    killed, not waited for (waited for, both cases would end with their results)."""
    _, _, cases = expand(study(tmp_path, 2, points=1000))
    with pytest.raises(KeyboardInterrupt):
        with worker_pool(2) as pool:
            futures = [pool.submit(run_case, case) for case in cases]
            while not all(f.running() for f in futures):
                time.sleep(0.01)
            raise KeyboardInterrupt
    assert [f.done() and not f.cancelled() and f.exception() is None for f in futures] == [False, False]
    assert [pid for pid in pool.seen if running(pid)] == []


class _PoolThread(threading.Thread):
    """A thread of a process pool's own (its class from concurrent.futures, as the pool's manager's),
    failing as Python's failed once the workers were killed: on a pipe the shutdown had closed."""

    def run(self):
        raise OSError("handle is closed")


_PoolThread.__module__ = "concurrent.futures.process"


def test_a_pool_threads_error_while_the_command_stops_is_no_traceback(monkeypatch, caplog):
    """`run --workers 2` stopped by SIGTERM printed a pool thread's traceback (OSError: handle is closed)
    in 2 of 11 tries, exit status and stored cases right. Once a stop signal arrived, such an error is a
    debug message; before a stop, or from any other thread, it goes to the hook as ever (Python's
    prints the traceback)."""
    from ecostudy.core import interrupt
    shown = []
    monkeypatch.setattr(threading, "excepthook", lambda args: shown.append(args.exc_type.__name__))

    def ended(thread):
        thread.start()
        thread.join()

    with interrupt.stopped_by_signals():
        monkeypatch.setattr(interrupt, "RECEIVED", [signal.SIGTERM])
        with caplog.at_level("DEBUG", logger="ecostudy"):
            ended(_PoolThread())
        assert shown == [] and "a process pool's thread ended with OSError: handle is closed" in caplog.text
        ended(threading.Thread(target=lambda: 1 / 0))
        assert shown == ["ZeroDivisionError"]
        monkeypatch.setattr(interrupt, "RECEIVED", [])
        ended(_PoolThread())
        assert shown == ["ZeroDivisionError", "OSError"]


def test_two_stop_signals_a_ms_apart_end_a_front_with_its_lock_released(tmp_path):
    """A second SIGINT 1 ms after the first (GNU ``timeout -s INT`` signals the command, then its process
    group) once hung ``pareto --workers 2`` for good in 3 of 4 tries: it landed inside a lock of
    concurrent.futures, left it held, and the pool's shutdown waited for it. Now only the first stop
    signal raises and the stop is bounded: each of three tries ends with exit 130 and no lock left."""
    out = tmp_path / "front"
    args = ["pareto", "--track", TRACKS / "amsterdam_rokin_centraal.yaml", "--train", TRAINS / "amsterdam_metro.yaml",
            "--count", 4000, "--points", 100, "--workers", 2, "--no-plot", "--no-progress", "--out", out]
    for _ in range(3):
        proc = ecostudy(args)
        deadline, before = time.time() + 300, stored(out / "results.sqlite")
        while proc.poll() is None and time.time() < deadline and stored(out / "results.sqlite") <= before:
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()
        os.kill(proc.pid, signal.SIGINT)
        time.sleep(0.001)
        os.kill(proc.pid, signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            pytest.fail("two SIGINTs a ms apart: the command hung")
        assert proc.returncode == 130, err
        assert "Traceback" not in err, err
        assert not (out / "results.sqlite.lock").exists()


def caught(pid, sig):
    """Whether process ``pid`` has a handler for ``sig`` (its SigCgt mask in /proc)."""
    try:
        mask = next(line for line in open(f"/proc/{pid}/status") if line.startswith("SigCgt:"))
    except (OSError, StopIteration):
        return False
    return bool(int(mask.split()[1], 16) >> (sig - 1) & 1)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_stop_while_the_command_still_loads_is_one_line_not_a_traceback(tmp_path, sig):
    """A stop signal while the command imports its modules, at several delays from the moment its
    own handler could be set (Python's SIGINT handler set, and ecostudy's SIGTERM one or 0.15 s more):
    exit status 128 + the signal and one line, never Python's traceback of the import it cut, nor
    Typer's silent 130; a later one, while it solves, the same."""
    for delay in (0.0, 0.05, 0.1, 0.2, 0.3, 0.5):
        proc = ecostudy(["solve", ROOT / "studies" / "default.yaml", "--points", 150, "--no-plot",
                         "--out", tmp_path / "out"])
        started = time.monotonic()
        while not caught(proc.pid, signal.SIGINT) and time.monotonic() - started < 30:
            time.sleep(0.001)
        python = time.monotonic()
        while not caught(proc.pid, signal.SIGTERM) and time.monotonic() - python < 0.15:
            time.sleep(0.001)
        time.sleep(delay)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=120)
        if proc.returncode == 0:  # done before the signal (a quick machine, the longest delay)
            continue
        assert (proc.returncode, err) == (128 + sig, f"warning: interrupted by {signal.Signals(sig).name}\n"), \
            (delay, proc.returncode, err[-800:])
