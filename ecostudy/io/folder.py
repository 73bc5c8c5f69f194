"""Every output folder's ``summary.json``, and any output folder read back as a typed result.

Every command that writes an output folder writes ``summary.json`` there through
:func:`write_summary`: which command wrote it (``kind``), with which ecostudy, the folder's status
in the one vocabulary (:mod:`ecostudy.core.status`: the worst of its cases, with their reasons),
the count of cases by status, the tables it wrote (name -> CSV file) and the other files, beside
the command's own fields. :func:`load` reads any such folder back as a :class:`StudyResult`.
"""
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

import pandas as pd

from ecostudy import __version__
from ecostudy.core.errors import InputError, problem
from ecostudy.core.status import Status, worst
from ecostudy.core.types import Track, Train
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.results import check_unchanged, load_result
from ecostudy.io.runsummary import RunSummary
from ecostudy.io.writers import REPORT, SUMMARY, write_json
LAYOUT = 1  # the version of summary.json's common fields; a reader refuses a newer one

# the fields write_summary owns; a command's own fields may not reuse them
COMMON = ("kind", "ecostudy_version", "summary_layout", "status", "cases", "not_ok", "tables", "files")


@dataclass(frozen=True)
class Counts:
    """How many cases of a folder are in each status (``summary.json`` field ``cases``)."""

    total: int = 0
    ok: int = 0
    flagged: int = 0
    failed: int = 0

    @property
    def not_ok(self) -> int:
        return self.flagged + self.failed

    def __str__(self) -> str:
        return f"{self.total} case{'s' * (self.total != 1)}: {self.ok} ok, {self.flagged} flagged, {self.failed} failed"

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Counts":
        return cls(**{k: int(data.get(k, 0)) for k in ("total", "ok", "flagged", "failed")})


@dataclass(frozen=True)
class NotOk:
    """A case that is not ok, with its status (``summary.json`` field ``not_ok``)."""

    case: str
    status: Status


@dataclass
class StudyResult:
    """An output folder of any command, read back by :func:`load`.

    ``kind`` is the command that wrote it (``solve``, ``pareto``, ``compare``, ``journey``,
    ``run``, ``network``, ``simulate``, ``heavyhaul``, ...); ``status`` the folder's status (the
    worst of its cases); ``cases`` the count of cases by status (:class:`Counts`); ``not_ok`` each
    case not ok with its status; ``tables`` every table the folder lists, as DataFrames with the
    CSV's columns (units in the column names); ``summary`` the whole ``summary.json`` (the typed
    run of a ``solve`` folder: :meth:`run`); ``inputs`` a ``solve`` folder's ``inputs.json`` (the
    track and train files it was solved with and their SHA-256, its stops, grid, timing, objective,
    weights; ``{}`` for other folders), whose track and train :meth:`track` and :meth:`train` read.
    """

    kind: str
    status: Status
    cases: Counts
    tables: dict[str, pd.DataFrame]
    summary: dict[str, Any]
    folder: Path
    files: list[str] = field(default_factory=list)
    not_ok: tuple[NotOk, ...] = ()
    inputs: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status.ok

    @property
    def reason(self) -> str:
        """Why the folder is not ok: the reasons of its worst cases ('' when it is ok)."""
        return self.status.reason

    def head(self) -> str:
        """The folder in a few words: the command, where, its tables (its repr adds the status and the cases)."""
        tables = ", ".join(f"{name} ({len(frame)} rows)" for name, frame in self.tables.items()) or "none"
        return f"{self.kind} folder {self.folder}, tables: {tables}"

    def __repr__(self) -> str:  # a line, not the tables and the whole summary
        return f"{type(self).__name__}({self.head()}; {self.cases}; {self.status})"

    @property
    def table(self) -> pd.DataFrame:
        """The folder's main table (the first it lists)."""
        if not self.tables:
            raise KeyError(f"{self.folder}: the {self.kind} folder lists no table")
        return next(iter(self.tables.values()))

    def run(self) -> RunSummary:
        """The typed run of a ``solve`` folder (or of any folder whose summary is one run's)."""
        if "traction_energy_kWh" not in self.summary or "solver" not in self.summary:
            raise InputError(problem(self.folder / SUMMARY, "kind", f"a {self.kind} folder, not one run's"))
        return RunSummary.from_dict(self.summary)

    def track(self) -> Track:
        """The track a ``solve`` folder's run was solved with: the file its ``inputs.json`` names, read
        as :func:`~ecostudy.io.loaders.load_track` reads it; refused if gone or changed since the solve."""
        return load_track(self._solved_with("track"))

    def train(self) -> Train:
        """The train a ``solve`` folder's run was solved with: the file its ``inputs.json`` names, read
        as :func:`~ecostudy.io.loaders.load_train` reads it; refused if gone or changed since the solve."""
        return load_train(self._solved_with("train"))

    def _solved_with(self, name: str) -> str:
        """The ``name`` file (track, train) of ``inputs``, refused as ``ecostudy check`` refuses it
        (:func:`~ecostudy.io.results.check_unchanged`): gone, or changed since the solve."""
        if name not in self.inputs:
            raise InputError(problem(self.folder / SUMMARY, "kind", f"a {self.kind} folder, not one run's: it "
                                     f"records no {name} file (a solve folder's inputs.json does)"))
        check_unchanged(self.inputs, self.folder, (name,))
        return str(self.inputs[name])


HEADLINE = 5  # the cases named in a folder's status; summary.json's not_ok lists every one


def headline(named: Mapping[str, Status], listed: str = "not_ok lists each") -> Status:
    """The status of a folder of named cases: the worst, each reason after the name of its case when
    there are several ('flagged: convex, draw 3: stopped 3.05 m beyond ...; rspc, draw 7: ...'),
    the first :data:`HEADLINE` of them, then how many more and where they are ``listed``."""
    whole = worst(named.values())
    if len(named) < 2 or whole.ok:
        return whole
    reasons = [f"{name}: {s.reason}" if s.reason else name for name, s in named.items() if s.kind == whole.kind]
    more = f"; and {len(reasons) - HEADLINE} more ({listed})" if len(reasons) > HEADLINE else ""
    return Status(whole.kind, "; ".join(reasons[:HEADLINE]) + more)


def write_summary(out_dir: Path | str, kind: str, statuses: Mapping[str, Status] | Iterable[Status],
                  tables: Mapping[str, str] | None = None, files: Iterable[str] = (),
                  **fields: Any) -> Path:
    """Write ``summary.json`` into ``out_dir`` (atomically): the common fields, then ``fields``.

    ``statuses``: every case's status, by case name where there are names (the ones not ok are
    listed with their reasons); ``tables``: table name -> CSV file in the folder.
    """
    clash = sorted(set(fields) & set(COMMON))
    if clash:
        raise ValueError(f"summary.json fields {clash} are common fields of write_summary")
    named = dict(statuses) if isinstance(statuses, Mapping) else {str(i): s for i, s in enumerate(statuses)}
    counts = {"total": len(named), "ok": 0, "flagged": 0, "failed": 0}
    for s in named.values():
        counts[s.kind] += 1
    data = {"kind": kind, "ecostudy_version": __version__, "summary_layout": LAYOUT,
            "status": str(headline(named) if isinstance(statuses, Mapping) else worst(named.values())),
            "cases": counts,
            "not_ok": [{"case": name, "status": str(s)} for name, s in named.items() if not s.ok],
            "tables": dict(tables or {}), "files": sorted(set(files) | {SUMMARY, REPORT} | set((tables or {}).values())),
            **fields}
    path = Path(out_dir) / SUMMARY
    write_json(path, data)
    return path


def files_listed(out_dir: Path | str) -> set[str]:
    """The files the folder's ``summary.json`` lists (none without one, or when it cannot be read)."""
    try:
        data = json.loads((Path(out_dir) / SUMMARY).read_text())
    except (OSError, ValueError):
        return set()
    files = data.get("files") if isinstance(data, dict) else None
    return {f for f in files if isinstance(f, str)} if isinstance(files, list) else set()


def mark_stopped(out_dir: Path | str, reason: str, counts: Mapping[str, int] | None = None, **fields: Any) -> None:
    """An earlier run's ``summary.json`` in ``out_dir`` replaced (atomically) by the stopped run's
    own, ``failed: <reason>``, for a run of the study that stopped before it ended: the earlier one
    spoke for a finished study. Of the earlier one only its ``kind`` and ``files`` (but the report)
    stay, so the next run that ends still removes what it does not write; ``cases`` are ``counts``
    (the cases of the study stopped, by the status of those stored: the total counts those not
    computed, in no status), no table is listed, and ``fields`` are the stopped run's own (its
    ``study``, ``computed_now``, ``stored_before``). The earlier ``report.html`` (the same status)
    is removed. Nothing where there is no readable one."""
    path = Path(out_dir) / SUMMARY
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return
    if not isinstance(data, dict):
        return
    files = [f for f in data.get("files") or [] if f != REPORT] if isinstance(data.get("files"), list) else data.get("files")
    write_json(path, {"kind": data.get("kind"), "ecostudy_version": __version__, "summary_layout": LAYOUT,
                      "status": f"failed: {reason}", "cases": dict(counts or {}), "not_ok": [], "tables": {},
                      "files": files, **fields})
    (Path(out_dir) / REPORT).unlink(missing_ok=True)


# the kinds of file a study kind writes into an output folder (figures in each format of
# ``--format``): only such a file an earlier summary.json listed is removed (a user's own file named
# in a hand-edited summary.json stays; no study kind writes YAML, so a study or train file the user
# keeps in the folder is never one)
WRITTEN_SUFFIXES = (".csv", ".png", ".svg", ".pdf", ".json", ".html", ".sqlite")


def remove_unlisted(out_dir: Path | str, earlier: Iterable[str]) -> list[str]:
    """Remove the files of ``earlier`` (what the folder's ``summary.json`` listed before this run
    wrote its own, :func:`files_listed`) that it does not list now: an earlier run's files this
    run did not write, so a folder never mixes the files of two runs. Returns their names."""
    out_dir, now = Path(out_dir), files_listed(out_dir)
    gone = sorted(name for name in set(earlier) - now if Path(name).name == name and Path(name).suffix in WRITTEN_SUFFIXES
                  and (out_dir / name).is_file())
    for name in gone:
        (out_dir / name).unlink(missing_ok=True)
    return gone


def load(folder: Path | str) -> StudyResult:
    """Any output folder of ecostudy as a :class:`StudyResult`; a folder that is not one is one
    clear line naming it (exit status 2). A solve folder's files are read as ``ecostudy check``
    reads them (:func:`~ecostudy.io.results.load_result`), without its re-simulation: a profile it
    refuses is refused here too."""
    folder = Path(folder)
    path = folder / SUMMARY
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise InputError(problem(path, "", f"not an ecostudy output folder ({exc.strerror})"))
    except ValueError as exc:
        raise InputError(problem(path, "", f"not readable JSON ({exc})"))
    if not isinstance(data, dict) or "kind" not in data or "status" not in data:
        raise InputError(problem(path, "kind", "missing: written by an older ecostudy or another program"))
    if int(data.get("summary_layout", 0)) > LAYOUT:
        raise InputError(problem(path, "summary_layout", f"{data['summary_layout']} is newer than this ecostudy "
                                 f"reads ({LAYOUT}); update ecostudy"))
    # a solve folder's files read as check and export read them: refused where they disagree (a profile with
    # text in a number column, cut short, edited: by name); its inputs.json kept
    inputs = load_result(folder).inputs if data["kind"] == "solve" else {}
    tables = {}
    for name, file in (data.get("tables") or {}).items():
        try:
            tables[name] = pd.read_csv(folder / file)
        except (OSError, ValueError) as exc:
            raise InputError(problem(folder / file, "", f"the {name} table of this folder cannot be read ({exc})"))
    not_ok = tuple(NotOk(str(c["case"]), Status.parse(c["status"])) for c in data.get("not_ok") or ())
    status, cases = Status.parse(data["status"]), Counts.from_dict(data.get("cases") or {})
    judged = _rejudged(folder) if data["kind"] == "solve" and status.ok else None
    if judged is not None:  # `ecostudy check` re-simulated the run since and found it not ok
        status, not_ok = judged, (*not_ok, NotOk("the run, re-judged by check.json", judged))
        cases = Counts(1, 0, int(judged.kind == "flagged"), int(judged.kind != "flagged"))  # a solve: one run
        # (not the summary's counts less one: a summary edited to ok may still count its run flagged)
    return StudyResult(kind=str(data["kind"]), status=status, cases=cases, tables=tables, summary=data, folder=folder,
                       files=list(data.get("files", [])), not_ok=not_ok, inputs=inputs)


def _rejudged(folder: Path) -> Status | None:
    """The run's status as the folder's check.json judged it (``run_status``: its profile re-simulated
    against its track and train) where that is not ok, else None (no check, or an unreadable one)."""
    try:
        run = Status.parse(str(json.loads((folder / "check.json").read_text())["run_status"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return None if run.ok else run
