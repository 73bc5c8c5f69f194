"""Embedded result store: one SQLite file per study output folder.

Each finished case is one row, written in its own transaction by the one process that collects
results, so an interrupted run (Ctrl-C, kill -9) keeps every case finished before it and never a
half-written one. Rows are keyed by the case hash (:func:`ecostudy.study.case_key`).
"""
import json
import sqlite3
import time
from pathlib import Path

SCHEMA = """
CREATE TABLE IF NOT EXISTS cases (
    key TEXT PRIMARY KEY,
    study TEXT, scenario TEXT, labels TEXT,
    status TEXT NOT NULL,          -- ok | flagged | infeasible | failed
    error TEXT, summary TEXT,
    seconds REAL, finished REAL
)"""


class Store:
    def __init__(self, path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.conn = sqlite3.connect(self.path)
        self.conn.execute("PRAGMA journal_mode=WAL")
        self.conn.execute(SCHEMA)
        self.conn.commit()

    def finished_keys(self, retry_failed=False):
        """Keys with a stored result (without failed ones when they are to be retried)."""
        query = "SELECT key FROM cases" + (" WHERE status != 'failed'" if retry_failed else "")
        return {row[0] for row in self.conn.execute(query)}

    def put(self, case, result):
        """Store one case's result atomically (replacing an earlier failure)."""
        with self.conn:
            self.conn.execute(
                "INSERT OR REPLACE INTO cases VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (case["key"], case["study"], case["scenario"], json.dumps(case["labels"]), result["status"],
                 result.get("error"), json.dumps(result.get("summary")), result.get("seconds"), time.time()))

    def get(self, keys):
        """{key: row dict} for the given keys."""
        out = {}
        for key in keys:
            row = self.conn.execute("SELECT key, scenario, labels, status, error, summary, seconds FROM cases "
                                    "WHERE key = ?", (key,)).fetchone()
            if row:
                out[key] = {"key": row[0], "scenario": row[1], "labels": json.loads(row[2]), "status": row[3],
                            "error": row[4], "summary": json.loads(row[5]) if row[5] else None, "seconds": row[6]}
        return out

    def close(self):
        self.conn.close()
