"""How often a stopped study loses a case its worker had finished but whose result had not reached the
main process (docs/batch.md, "Stopping a study").

    PYTHONPATH=$PWD .venv/bin/python bench/interrupt_loss.py [--tries 10] [--within 3 50] [--seed 14]

Each try runs ``studies/metro_supplements.yaml`` (12 cases) with two worker processes through the engine
of ``ecostudy run`` (``studies.batch.execute``), each worker noting the moment it finished a case (after
the case, before its result leaves the worker), and sends SIGINT to the main process at a time drawn
uniformly from ``--within`` seconds after its start. Per try: the cases the workers finished, those
stored, those lost (finished, not stored; also counted among them: finished before the signal) and how
long the process took to end after the signal. Last line: over every stored case, the time from its
worker finishing it to the main process storing it (the window in which a signal loses a finished case
is at most this long).
"""
import argparse
import json
import os
import random
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STUDY = ROOT / "studies" / "metro_supplements.yaml"


LOG: list = []  # the child's file of finished cases (its workers are forked from it)


def noted(case):
    """``run_case``, then the moment it finished noted in the log."""
    from ecostudy.studies.batch import run_case
    result = run_case(case)
    with open(LOG[0], "a") as f:
        f.write(f"{case['key']} {time.time():.6f}\n")
    return result


def child(folder, log):
    """The interrupted process: the study's cases over two workers, each noting when it finished one."""
    from ecostudy.ocp.solver import configure
    configure()
    from ecostudy.core.interrupt import Interrupted, stopped_by_signals
    from ecostudy.io.store import Store
    from ecostudy.studies.batch import execute, expand_study

    LOG.append(log)
    store = Store(Path(folder) / "results.sqlite")
    try:
        with stopped_by_signals():
            print("finished", execute(expand_study(STUDY).cases, store, task=noted, workers=2))
    except Interrupted as exc:
        print("interrupted", exc.counts)
    finally:
        store.close()


def stored(db):
    try:
        with sqlite3.connect(db) as conn:
            return dict(conn.execute("SELECT key, finished FROM cases"))
    except sqlite3.OperationalError:  # stopped before the store made its table
        return {}


def one_try(folder, at):
    log = folder / "finished.log"
    log.touch()
    t0 = time.time()
    proc = subprocess.Popen([sys.executable, __file__, "--child", str(folder), str(log)], cwd=ROOT, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    time.sleep(max(0.0, at - (time.time() - t0)))
    signalled = time.time()
    if proc.poll() is None:
        os.kill(proc.pid, signal.SIGINT)
    out, _ = proc.communicate()
    ended = time.time()
    finished = {k: float(t) for k, t in (line.split() for line in log.read_text().splitlines())}
    rows = stored(folder / "results.sqlite")
    lost = set(finished) - set(rows)
    return {"signal_s": round(at, 1), "finished": len(finished), "stored": len(rows), "lost": len(lost),
            "lost_finished_before_signal": sum(finished[k] <= signalled for k in lost),
            "stop_s": round(ended - signalled, 2), "exit": proc.returncode, "said": out.strip().split(" ")[0]}, \
        [rows[k] - finished[k] for k in finished if k in rows]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--tries", type=int, default=10)
    parser.add_argument("--within", type=float, nargs=2, default=(3.0, 50.0))
    parser.add_argument("--seed", type=int, default=14)
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return child(*args.child)
    rng, delays = random.Random(args.seed), []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.tries):
            folder = Path(tmp) / str(i)
            folder.mkdir()
            row, seen = one_try(folder, rng.uniform(*args.within))
            delays += seen
            print(json.dumps(row), flush=True)
    delays.sort()
    if delays:
        print(f"finished to stored, {len(delays)} cases: median {delays[len(delays) // 2] * 1e3:.1f} ms, "
              f"max {delays[-1] * 1e3:.1f} ms; load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
