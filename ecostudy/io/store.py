"""Embedded result store: one SQLite file per study output folder.

Each finished case is one row, written in its own transaction by the one process that collects
results, so an interrupted run (Ctrl-C, kill -9) keeps every case finished before it and never a
half-written one. Rows are keyed by the case hash (:func:`ecostudy.study.case_key`).
"""
import fcntl
import json
import os
import sqlite3
import time
import warnings
from contextlib import closing, contextmanager
from os import PathLike
from pathlib import Path
from typing import IO, Any, Iterable, Iterator, Mapping

from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.status import Status
from ecostudy.io.writers import remove_temporary

SCHEMA = """
CREATE TABLE IF NOT EXISTS cases (
    key TEXT PRIMARY KEY,
    study TEXT, scenario TEXT, labels TEXT,
    status TEXT NOT NULL,          -- ok | flagged | infeasible | failed
    error TEXT, summary TEXT,
    seconds REAL, finished REAL
)"""


COLUMNS = ["key", "study", "scenario", "labels", "status", "error", "summary", "seconds", "finished"]
HELD: list[IO[str]] = []  # the lock files this process holds (a forked worker closes its copies: release_inherited)
KEPT: list[dict[str, IO[str]]] = []  # within whole_command: the stores' locks kept to its end, by lock file


@contextmanager
def whole_command() -> Iterator[None]:
    """Within this block (a command, from its first file to its report.html; as a decorator, a call)
    a store once opened stays locked when it is closed, until the block ends: a second command on
    the same folder is refused (one line, exit status 2) while this one writes its tables and
    figures, instead of starting and removing this one's temporary files as its store opens."""
    if KEPT:  # nested: the outermost block lets go
        yield
        return
    KEPT.append({})
    try:
        yield
    finally:
        for path, lock in KEPT.pop().items():
            _release(Path(path), lock)


def release_inherited() -> None:
    """In a forked worker: close its copies of the parent's lock files. A lock belongs to the open
    file, which a fork shares; with the copies closed it goes with the parent, so the store of a run
    killed with kill -9 is free at once, not only once its last worker has died too."""
    while HELD:
        HELD.pop().close()


class Store:
    """The store of one output folder, locked for the one process that writes it; a file that is
    not such a store (corrupt, truncated, foreign) is refused by name with how to recover."""

    def __init__(self, path: str | PathLike[str]) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.lock_path = self.path.with_name(self.path.name + ".lock")
        kept = KEPT[-1] if KEPT else {}
        key = os.path.abspath(self.lock_path)
        if key in kept:  # opened before in this command, still locked: its temporary files may be in flight
            self.lock = kept[key]
        else:
            self.lock = _locked(self.lock_path, self.path)
            remove_temporary(self.path.parent)  # what a run killed in this folder left: this one alone writes it now
            if KEPT:
                kept[key] = self.lock
        try:
            self.conn = sqlite3.connect(self.path)
            self.conn.execute("PRAGMA journal_mode=WAL")
            self.conn.execute(SCHEMA)
            self.conn.commit()
            columns = [row[1] for row in self.conn.execute("PRAGMA table_info(cases)")]
        except sqlite3.DatabaseError as exc:
            self._unlock()
            raise InputError(problem(self.path, "", f"not a readable ecostudy store ({exc}): move it away to start "
                                     "afresh (its finished cases are then computed again)"))
        if columns != COLUMNS:
            self.close()
            raise InputError(problem(self.path, "cases", "a table of another program or version (columns "
                                     f"{', '.join(columns)}): move the file away to start afresh"))

    def keys(self) -> set[str]:
        """Every stored key, whatever its status."""
        return {row[0] for row in self.conn.execute("SELECT key FROM cases")}

    def finished_keys(self, retry_failed: bool = False) -> set[str]:
        """Keys with a stored result (without failed ones when they are to be retried)."""
        query = "SELECT key FROM cases" + (" WHERE status != 'failed'" if retry_failed else "")
        keys = {row[0] for row in self.conn.execute(query)}
        return set(self.get(keys))  # a damaged row is dropped there: its case is computed again

    def put(self, case: Mapping[str, Any], result: Mapping[str, Any]) -> None:
        """Store one case's result atomically (replacing an earlier failure)."""
        with self.conn:
            self.conn.execute(
                "INSERT OR REPLACE INTO cases VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (case["key"], case["study"], case["scenario"], json.dumps(case["labels"]), result["status"],
                 result.get("error"), json.dumps(result.get("summary")), result.get("seconds"), time.time()))

    def get(self, keys: Iterable[str]) -> dict[str, dict[str, Any]]:
        """{key: row dict} for the given keys."""
        out: dict[str, dict[str, Any]] = {}
        for key in keys:
            row = self.conn.execute("SELECT key, scenario, labels, status, error, summary, seconds FROM cases "
                                    "WHERE key = ?", (key,)).fetchone()
            if not row:
                continue
            try:
                out[key] = {"key": row[0], "scenario": row[1], "labels": json.loads(row[2]), "status": row[3],
                            "error": row[4], "summary": json.loads(row[5]) if row[5] else None, "seconds": row[6]}
            except (TypeError, ValueError):  # one damaged row: that case is computed again, the others kept
                warnings.warn(problem(self.path, f"case {key}", "damaged row: the case is computed again"),
                              EcostudyWarning, stacklevel=2)
                self.conn.execute("DELETE FROM cases WHERE key = ?", (key,))
                self.conn.commit()
        return out

    def close(self) -> None:
        """Close the database and remove the lock file (while still holding it: a run that opened the
        old file before the removal sees it gone and takes the new one, :func:`_locked`); within
        :func:`whole_command`, the lock at the block's end."""
        self.conn.close()
        self._unlock()

    def _unlock(self) -> None:
        if not any(self.lock is lock for kept in KEPT for lock in kept.values()):  # else: at the command's end
            _release(self.lock_path, self.lock)


def _release(lock_path: Path, lock: IO[str]) -> None:
    """Remove the lock file while still holding it, then let go of it."""
    try:
        if os.stat(lock_path).st_ino == os.fstat(lock.fileno()).st_ino:
            lock_path.unlink()
    except FileNotFoundError:
        pass
    if lock in HELD:
        HELD.remove(lock)
    lock.close()


def _locked(lock_path: Path, store_path: Path, attempts: int = 5) -> IO[str]:
    """The lock file opened and locked for this process alone; refused when another run holds it.
    A lock taken on a file that a finishing run removed meanwhile is let go and taken again."""
    for _ in range(attempts):
        lock = open(lock_path, "a")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            raise InputError(problem(store_path, "", "another ecostudy run is writing this store: wait for it to "
                                     "finish, or give another --out"))
        try:
            if os.stat(lock_path).st_ino == os.fstat(lock.fileno()).st_ino:
                HELD.append(lock)
                return lock
        except FileNotFoundError:
            pass
        lock.close()  # the file was removed by a run that just finished: take the new one
    raise InputError(problem(store_path, "", "its lock file keeps changing: another ecostudy run is starting or "
                             "finishing on this folder; try again"))


def check_one_study(folder: str | PathLike[str], name: str) -> None:
    """Refuse an output folder whose store holds the cases of another study than ``name`` (the
    tables, figures and summary.json of one would be written over the other's), before anything
    is computed, the folder unchanged; a store that cannot be read is left to :class:`Store`'s own
    refusal."""
    path = Path(folder) / "results.sqlite"
    if not path.is_file():
        return
    # read-only; without a -wal file beside it (a store closed cleanly) as immutable, which makes
    # none: a read-only connection to a store in WAL mode leaves its -wal and -shm files behind
    immutable = "" if path.with_name(path.name + "-wal").exists() else "&immutable=1"
    try:
        with closing(sqlite3.connect(f"file:{path}?mode=ro{immutable}", uri=True)) as db:
            others = sorted({row[0] for row in db.execute("SELECT DISTINCT study FROM cases")} - {name})
    except sqlite3.DatabaseError:
        return
    if others:
        raise InputError(problem(folder, "--out", f"holds the results of another study ({', '.join(map(repr, others))}), "
                                 f"not of '{name}': give another --out"))


def stored_counts(path: str | Path, keys: list[str]) -> dict[str, int]:
    """{total: how many ``keys`` (a study's cases), ok, flagged, failed: those stored at ``path`` in
    each} (a case not stored counts in the total only)."""
    store = Store(path)
    try:
        kinds = [Status.parse(str(row["status"])).kind for row in store.get(keys).values()]
    finally:
        store.close()
    return {"total": len(keys), **{k: kinds.count(k) for k in ("ok", "flagged", "failed")}}
