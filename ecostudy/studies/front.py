"""A Pareto front as a study kind: each point of the epsilon-constraint front (Farooqi 2018,
§7.1.1, Table 7.1) a case, run by the one study engine (:func:`ecostudy.studies.batch.run_expanded`:
stored in ``results.sqlite`` as it finishes, resumable, in worker processes or on Dask).

A point is a case of the ``run`` kind (:func:`ecostudy.studies.batch.run_case`): the all-out run
(objective ``time``), then energy-optimal runs at supplements over its time. Every point is solved
cold, from its own capped-speed start, so that it is the same whichever process solves it and
whatever was stored before; a process writes the model once and re-solves it with the bound of
the running time changed (:class:`ecostudy.ocp.problem.Written`), and solves the all-out run once
(the supplements' base). Measured against the warm-started chains of
:func:`ecostudy.studies.pareto.sweep` on the shipped trips: energies within 2.7e-6 of the chained
ones, 1.15-1.53 times the CPU time on one core (docs/pareto.md).
"""
from typing import NamedTuple

import numpy as np
import pandas as pd

from ecostudy.core.defaults import FRONT_POINTS
from ecostudy.core.status import Status, flagged
from ecostudy.io.runsummary import RunSummary
from ecostudy.studies.batch import STUDY_KINDS, Expanded, StudyKind, run_case
from ecostudy.studies.cases import case_key, load_checked_study
from ecostudy.studies.compare import segment_of
from ecostudy.studies.options import no_windows
from ecostudy.studies.pareto import das_meta, facts_of, front_supplements, front_table, is_monotone, saving_at
from ecostudy.studies.sizes import check_front

DEFAULT_COUNT, DEFAULT_SUPPLEMENT_MAX = 20, 0.40  # a study file's front: points, largest supplement [-]


def front_cases(train_doc, track_doc, from_stop, to_stop, count=DEFAULT_COUNT, supplement_max=DEFAULT_SUPPLEMENT_MAX,
                points=FRONT_POINTS, study="pareto", das=None, das_time_limit=60.0):
    """One case per point of a front (:func:`~ecostudy.studies.pareto.front_supplements`): the
    all-out run, then the energy optimum at each supplement [-] over its time; the train and track
    documents (schema-shaped), the stops, the grid and the driver-advice method ``das`` of every
    point; each keyed by a hash of all of them and its supplement."""
    base = {"study": study, "train": train_doc, "track": track_doc, "from": from_stop, "to": to_stop,
            "running_time_s": None, "window_s": None, "weights": [1.0, 1.0], "points": points,
            "profile": True, "das": das, "das_time_limit_s": das_time_limit}
    cases = []
    for s in front_supplements(count, supplement_max):
        name = "all-out" if s == 0 else f"+{100 * s:.4g} %"
        case = {**base, "objective": "time" if s == 0 else "energy", "supplement_percent": None if s == 0 else 100 * s,
                "scenario": name, "name": name, "labels": {"supplement": name}}
        case["key"] = case_key(case)
        cases.append(case)
    return cases


def expand_front(path):
    """A study file's base case as a front (``ecostudy run FILE --kind pareto``): 20 points to +40 %
    on its grid, written beside its output (``<output>_pareto``)."""
    st = load_checked_study(path, "pareto")
    no_windows(st, "pareto", path)
    train_doc, track_doc = st.documents
    cases = front_cases(train_doc, track_doc, st.from_stop, st.to_stop, points=st.points or FRONT_POINTS, study=st.name)
    return Expanded(st.output.parent / (st.output.name + "_pareto"), cases)


def points_of(cases, rows):
    """(summary, status) of every point from the stored rows, in front order (a point not stored,
    or failed, has summary None)."""
    out = []
    for case in cases:
        row = rows.get(case["key"]) or {"status": "missing", "error": "not computed yet", "summary": None}
        out.append((row["summary"], Status.parse(row["status"], row.get("error") or "")))
    return out


def pareto_table(cases, rows):
    """One row per point (``pareto.csv``, :func:`~ecostudy.studies.pareto.front_table`), with the
    ``das_`` columns when the points carry driver advice; its attrs (``summary.json``): what a
    reader asks first (the savings at +5 % and +10 %, monotone, all verified, all optimal)."""
    points = points_of(cases, rows)
    first = points[0][0]
    table = front_table(points, facts_of(first).running_time_s if first else np.nan)
    case = cases[0]
    if case["das"] is not None:
        das = pd.DataFrame([(s or {}).get("das") or {} for s, _ in points], index=table.index)
        table = pd.concat([table, das], axis=1)
        table.attrs["das_method"] = case["das"]
    solved = table["running_time_s"].notna() if "running_time_s" in table else table.index < 0
    names = {"track": case["track"].get("name", "track"), "train": case["train"].get("name", "train"),
             "from": case["from"], "to": case["to"]}
    facts = {**names, "points": case["points"], "count": len(cases),
             "all_out_time_s": float(table["running_time_s"].iloc[0]),
             "saving_at_5_pct_supplement_pct": saving_at(table[solved], 5.0) if solved.any() else None,
             "saving_at_10_pct_supplement_pct": saving_at(table[solved], 10.0) if solved.any() else None,
             "monotone": is_monotone(table[solved]), "all_verified": bool(table["verified"].eq(True).all()),
             "all_optimal": bool((table["solver_status"] == "optimal").all())}
    if case["das"] is not None:
        facts["das"] = das_meta(table)
    table.attrs.update(facts)
    return table


def front_verdict(table):
    """The front as a whole: flagged when its energy does not fall as the running time grows."""
    return {} if table.attrs["monotone"] else {"front": flagged("energy does not fall as the running time grows")}


class FrontPoint(NamedTuple):
    """A stored point as a figure draws it: its speed profile (``position_m``, ``speed_kmh``), its
    facts and the segment (for the speed limit)."""

    profile: dict
    facts: RunSummary
    segment: object


def front_points(cases, rows, picks):
    """The stored points at the indices ``picks`` (those solved) as :class:`FrontPoint`."""
    points, segment = points_of(cases, rows), None
    out = []
    for i in picks:
        summary = points[i][0]
        if summary and "profile" in summary:
            segment = segment or segment_of(cases[0])
            out.append(FrontPoint({k: np.asarray(v) for k, v in summary["profile"].items()},
                                  facts_of(summary), segment))
    return out


def front_size(where, cases, workers=1):
    """Refuse a front estimated above the command's budget (unless forced)."""
    case = cases[0]
    check_front(where, len(cases), case["points"], workers, case["das"], case["das_time_limit_s"])


STUDY_KINDS.register("pareto", StudyKind(expand_front, run_case, pareto_table, front_size, table_file="pareto.csv",
                                         table_name="pareto", verdict=front_verdict),
                     doc="energy against running time: each point of the front a case (Farooqi 2018, §7.1.1)")
