"""What a command of :mod:`ecostudy.api` returns: the output folder it wrote, read back as a
:class:`~ecostudy.io.folder.StudyResult`, with the report the command line prints; and the helpers
that turn tables into that report.
"""
import errno
import json
import os
from dataclasses import dataclass, fields
from functools import partial
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import pandas as pd

from ecostudy.api.arguments import spelled
from ecostudy.core.errors import EcostudyError
from ecostudy.core.status import Judged, Status, status_word
from ecostudy.core.units import number
from ecostudy.io.folder import StudyResult
from ecostudy.io.folder import load as load_result
from ecostudy.io.writers import name_too_long
from ecostudy.report.console import counted
from ecostudy.report.cells import is_missing
from ecostudy.report.html import fragment, is_number


@dataclass(repr=False)  # StudyResult's line, not the printed text
class Report(StudyResult):
    """An output folder a command wrote (every field of :class:`StudyResult`) and ``text``: the
    lines the command line prints, ending with the folder and its files."""

    text: str = ""

    def _repr_html_(self) -> str:  # a notebook cell: the line, the status, the cases not ok or the main table
        bad = pd.DataFrame([{"case": c.case, "status": str(c.status)} for c in self.not_ok])
        return fragment(f"{type(self).__name__}({self.head()}; {self.cases})", str(self.status),
                        frame=bad if len(bad) else self.table if self.tables else None)

    def problems(self, shown: int = 20) -> list[str]:
        """'status: cases: reason' of the cases not ok, each status and reason once with the cases it
        applies to (:func:`together`; the first ``shown`` lines, then how many more cases)."""
        groups: dict[tuple[str, str], list[str]] = {}
        for c in self.not_ok:
            groups.setdefault((c.status.kind, c.status.reason), []).append(c.case)
        items = list(groups.items())
        left = sum(len(cases) for _, cases in items[shown:])
        return ([f"{kind}: {together(cases)}: {reason}" for (kind, reason), cases in items[:shown]]
                + ([f"... and {left} more cases not ok (summary.json, report.html)"] if left else []))


def together(cases: Sequence[str]) -> str:
    """Case names as one: names 'a=1, b=2' that differ in one 'key=value' (or 'key value') only as
    'a=1, 5, 9 (b=2)' ('run 0, 1'), else joined by '; '."""
    split = [c.split(", ") for c in cases]
    if len(cases) > 1 and len({len(s) for s in split}) == 1:
        differ = [i for i in range(len(split[0])) if len({s[i] for s in split}) > 1]
        fields = [s[differ[0]] for s in split] if len(differ) == 1 else []
        sep = "=" if all("=" in f for f in fields) else " "
        pairs = [f.partition("=") if sep == "=" else f.rpartition(" ") for f in fields]
        if pairs and all(p[0] and p[1] for p in pairs) and len({p[0] for p in pairs}) == 1:
            rest = ", ".join(f for j, f in enumerate(split[0]) if j != differ[0])
            return f"{pairs[0][0]}{sep}{', '.join(p[2] for p in pairs)}" + (f" ({rest})" if rest else "")
    return "; ".join(cases)


@dataclass(repr=False)
class Note(Judged):
    """What a command that writes beside an existing folder returns (``check``, ``export``,
    ``doctor``): its ``status`` (with ``reason`` and ``ok``, as every result), the ``text``
    printed, and the command's data."""

    verdict: Status
    text: str
    data: Any = None

    @property
    def status(self) -> Status:
        """``check``: ok at 95 % agreement or more for a run that is ok, else flagged saying which;
        ``export``: the status of the run exported; ``doctor``: whether the toy NLP came out right."""
        return self.verdict

    def __repr__(self) -> str:  # what the command prints, not its data (a whole table for export)
        return f"Note({self.status})\n{self.text}"


@spelled
def load(folder: Path | str) -> Report:
    """Any output folder of ecostudy read back (:func:`ecostudy.io.folder.load`): a :class:`Report`
    whose ``text`` is empty (no command printed it here)."""
    return reported(folder, ())


def reported(folder: Path | str, lines: Iterable[str]) -> Report:
    """``folder`` read back (:func:`~ecostudy.io.folder.load`) with the printed ``lines``."""
    result = load_result(folder)
    return Report(**{f.name: getattr(result, f.name) for f in fields(StudyResult)}, text="\n".join(lines))


def shown(frame: pd.DataFrame, columns: Sequence[str] | Mapping[str, str | None] | None = None,
          places: str = ".3f", reasons: bool = False, blank: bool = False) -> str:
    """``frame``'s ``columns`` (those it has; all without ``columns``) as a plain text table, each
    number by ``places`` or, ``columns`` given as {name: format}, by its column's format (None:
    ``places``); :func:`~ecostudy.core.units.number`: no '-0.000'. A ``status`` column shows its
    kind alone (``failed``, not ``failed: <reason>``: one long reason would widen every row), the
    reasons being printed under the table (:meth:`Report.problems`), unless ``reasons``; ``blank``:
    a missing value (a failed point's) an empty cell, as report.html shows it, not 'NaN'."""
    specs = {c: s for c, s in columns.items() if s} if isinstance(columns, Mapping) else {}
    if columns is not None:
        frame = frame[[c for c in columns if c in frame]]
    frame = frame.assign(**{c: pd.to_numeric(frame[c]) for c in frame.columns if frame[c].dtype == object
                            and frame[c].map(lambda v: is_missing(v) or is_number(v)).all()})  # None printed as NaN, as its column's others
    if not reasons and "status" in frame:
        frame = frame.assign(status=frame["status"].map(lambda s: status_word(s) if isinstance(s, str) else s))
    return frame.to_string(index=False, float_format=lambda x: number(x, places), na_rep="" if blank else "NaN",
                           formatters={c: partial(number, spec=s) for c, s in specs.items() if c in frame})


def listed(out_dir: Path | str, names: Sequence[str] = ()) -> str:
    """``DIR/ (a, b)``: the files this run left in ``out_dir``: its tables and files as its
    ``summary.json`` lists them, else those of ``names`` that exist (a figure skipped with
    ``--no-plot`` is not listed)."""
    try:
        summary = json.loads((Path(out_dir) / "summary.json").read_text())
        names = list(dict.fromkeys([*summary["tables"].values(), *summary["files"]]))
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return f"{out_dir}/ ({', '.join(n for n in names if (Path(out_dir) / n).is_file())})"


def counts_line(counts: dict[str, int], noun: str) -> str:
    """The one-line summary of a resumable study's counts (``studies.batch.execute``)."""
    return (f"{counted(counts['total'], noun)}: {counts['stored_before']} already stored, {counts['computed']} computed now "
            f"({counts['failed']} failed); not ok: {counts['not_ok']}" + beside(counts) + not_reused(counts))


def beside(counts: dict[str, int]) -> str:
    """``; beside them N runs, M not ok`` for the runs a command made beside its cases (``more``)."""
    n = counts.get("beside", 0)
    return f"; beside them {n} run{'s' if n != 1 else ''}, {counts['beside_not_ok']} not ok" if n else ""


def not_reused(counts: dict[str, int]) -> str:
    """``; N results in the store not reused (...)`` when the store holds results of no case of the
    study (``studies.batch.stored_rows``'s ``stored_other``), else nothing."""
    n = counts.get("stored_other", 0)
    return (f"; {n} result{'s' if n != 1 else ''} in the store not reused (stored for other inputs or by other "
            "code)") if n else ""


# the operating system's refusals while writing: no space, quota, read-only, permission, input/output
SYSTEM_ERRORS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EIO, errno.EFBIG}


def one_line(exc: Exception, debug: bool = False) -> tuple[str, int]:
    """What a user reads of a failure and the exit status: an ecostudy error's own lines and its
    ``exit_code``, else 'internal error: ...' and 3."""
    if isinstance(exc, EcostudyError):
        return str(exc), exc.exit_code
    if isinstance(exc, OSError) and exc.errno == errno.ENAMETOOLONG and exc.filename:  # a path given: bad input
        return name_too_long(os.fsdecode(exc.filename)), 2
    if isinstance(exc, OSError) and exc.errno in SYSTEM_ERRORS:  # the machine's, not the code's: said as such
        where = f"{exc.filename}: " if exc.filename else ""
        return (f"{where}cannot write: {exc.strerror} (the output folder may hold part of this run's files: run "
                "the command again when it can be written)"), 3
    return (f"internal error: {type(exc).__name__}: {exc}" + ("" if debug else " (rerun with --debug for the "
                                                                "traceback)"), 3)
