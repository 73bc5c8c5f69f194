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

from ecostudy.core.defaults import DAS_TIME_LIMIT_S, FRONT_POINTS
from ecostudy.core.status import OK, Status, flagged
from ecostudy.das.methods import advice_status
from ecostudy.io.runsummary import RunSummary
from ecostudy.studies.batch import STUDY_KINDS, Expanded, StudyKind, run_case
from ecostudy.studies.estimate import case_size
from ecostudy.studies.cases import case_key, load_checked_study
from ecostudy.studies.compare import segment_of
from ecostudy.studies.options import no_windows
from ecostudy.studies.pareto import (das_meta, facts_of, front_supplements, front_table, is_monotone, rises,
                                     saving_at)
from ecostudy.studies.sizes import check_front

DEFAULT_COUNT, DEFAULT_SUPPLEMENT_MAX = 20, 0.40  # a study file's front: points, largest supplement [-]
STUDY = "study "  # the start of the name of a study's own running time added beside the front (study_point)


def front_cases(train_doc, track_doc, from_stop, to_stop, count=DEFAULT_COUNT, supplement_max=DEFAULT_SUPPLEMENT_MAX,
                points=FRONT_POINTS, study="pareto", das=None, das_time_limit=DAS_TIME_LIMIT_S, timing=None):
    """One case per point of a front (:func:`~ecostudy.studies.pareto.front_supplements`): the
    all-out run, then the energy optimum at each supplement [-] over its time; the train and track
    documents (schema-shaped), the stops, the grid and the driver-advice method ``das`` of every
    point; each keyed by a hash of all of them and its supplement. A study's own ``timing`` (its
    running time [s] or supplement [-]; :class:`~ecostudy.core.types.Timing`) is one more point,
    solved like the others and labelled ``study_time`` (a supplement already on the front is that
    point, labelled)."""
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
    if timing is not None and timing.supplement is not None:
        same = [c for c in cases if c["supplement_percent"] is not None
                and abs(c["supplement_percent"] - 100 * timing.supplement) < 1e-9]
        if same:
            same[0]["labels"]["study_time"] = True  # labels are not in the key: the point stays the one stored
        else:
            cases.append(study_point(base, supplement_percent=100 * timing.supplement,
                                     name=f"{STUDY}+{100 * timing.supplement:.4g} %"))
    elif timing is not None and timing.running_time is not None:
        cases.append(study_point(base, running_time_s=timing.running_time,
                                 name=f"{STUDY}{timing.running_time:.6g} s"))
    return cases


def study_point(base, name, running_time_s=None, supplement_percent=None):
    """The case of a study's own running time [s] or supplement [%], energy-optimal like the front's."""
    case = {**base, "objective": "energy", "running_time_s": running_time_s, "supplement_percent": supplement_percent,
            "scenario": name, "name": name, "labels": {"supplement": name, "study_time": True}}
    case["key"] = case_key(case)
    return case


def is_study_time(case):
    """Whether a front's case is the study's own running time (:func:`front_cases`)."""
    return bool(case["labels"].get("study_time"))


def expand_front(path):
    """A study file's base case as a front (``ecostudy run FILE --kind pareto``): 20 points to +40 %
    on its grid and the study's own running time, written beside its output (``<output>_pareto``)."""
    st = load_checked_study(path, "pareto")
    no_windows(st, "pareto", path)
    train_doc, track_doc = st.documents
    cases = front_cases(train_doc, track_doc, st.from_stop, st.to_stop, points=st.points or FRONT_POINTS, study=st.name,
                        timing=st.timing)
    return Expanded(st.output.parent / (st.output.name + "_pareto"), cases)


def points_of(cases, rows):
    """(summary, status) of every point from the stored rows, in front order (a point not stored,
    or failed, has summary None)."""
    out = []
    for case in cases:
        row = rows.get(case["key"]) or {"status": "missing", "error": "not computed yet", "summary": None}
        out.append((row["summary"], Status.parse(row["status"], row.get("error") or "")))
    return out


def in_time_order(cases, points):
    """The indices of a front's cases by running time [s]: the all-out run first, each solved point
    at its time, a point not solved at the time it was asked (when known), else last."""
    first = points[0][0]
    t_allout = facts_of(first).running_time_s if first else np.nan

    def time_of(i):
        summary, case = points[i][0], cases[i]
        if summary:
            return facts_of(summary).running_time_s
        if case["running_time_s"] is not None:
            return case["running_time_s"]
        return t_allout * (1 + case["supplement_percent"] / 100)  # nan when the all-out run failed

    asked = [(0.0 if i == 0 else time_of(i), i) for i in range(len(cases))]
    return [i for _, i in sorted(asked, key=lambda a: (not np.isfinite(a[0]), a[0] if np.isfinite(a[0]) else 0, a[1]))]


def pareto_table(cases, rows):
    """One row per point (``pareto.csv``, :func:`~ecostudy.studies.pareto.front_table`) in order of
    running time (the index: each row's place in ``cases``), the study's own running time marked
    (``is_study_time``), with the ``das_``
    columns when the points carry driver advice; its attrs (``summary.json``): what a reader asks
    first (the savings at +5 % and +10 %, the study time's energy, monotone, all verified, all optimal)
    and ``count``, the front's points (a study's own running time added beside them not counted)."""
    points = points_of(cases, rows)
    order = in_time_order(cases, points)
    cases, points = [cases[i] for i in order], [points[i] for i in order]
    first = points[0][0]
    table = front_table(points, facts_of(first).running_time_s if first else np.nan)
    table["is_study_time"] = [is_study_time(c) for c in cases]
    case = cases[0]
    if case["das"] is not None:
        das = pd.DataFrame([(s or {}).get("das") or {} for s, _ in points], index=table.index)
        table = pd.concat([table, das], axis=1)
        table.attrs["das_method"] = case["das"]
    solved = table["running_time_s"].notna() if "running_time_s" in table else table.index < 0
    names = {"track": case["track"].get("name", "track"), "train": case["train"].get("name", "train"),
             "from": case["from"], "to": case["to"]}
    facts = {**names, "points": case["points"], "count": sum(not c["name"].startswith(STUDY) for c in cases),
             "all_out_time_s": float(table["running_time_s"].iloc[0]),
             "saving_at_5_pct_supplement_pct": saving_at(table[solved], 5.0) if solved.any() else None,
             "saving_at_10_pct_supplement_pct": saving_at(table[solved], 10.0) if solved.any() else None,
             "monotone": is_monotone(table[solved]), "rises_s": rises(table[solved]), "all_verified": bool(table["verified"].eq(True).all()),
             "all_optimal": bool((table["solver_status"] == "optimal").all())}
    if case["das"] is not None:
        facts["das"] = das_meta(table)
    facts.update(study_time_facts(table))
    table.attrs.update(facts)
    table.index = pd.Index(order)  # each row's case in the front's order (the study engine's statuses)
    return table


def study_time_facts(table):
    """The study's own running time on the front (``summary.json``; none when it gives none)."""
    rows = table[table["is_study_time"]]
    if not len(rows):
        return {}
    row = rows.iloc[0]

    def value(column):
        return None if pd.isna(row[column]) else float(row[column])
    return {"study_running_time_s": value("running_time_s"), "study_traction_energy_kWh": value("traction_energy_kWh"),
            "study_saving_vs_all_out_pct": value("saving_vs_all_out_pct"), "study_status": str(row["status"])}


def front_verdict(table):
    """The front as a whole: flagged when its energy does not fall as the running time grows."""
    where = "; ".join(f"{a:.2f} -> {b:.2f} s" for a, b in table.attrs.get("rises_s", []))
    return {} if table.attrs["monotone"] else {"front": flagged("energy does not fall as the running time grows"
                                                                + (f" (it rises {where})" if where else ""))}


class FrontPoint(NamedTuple):
    """A stored point as a figure draws it: its speed profile (``position_m``, ``speed_kmh``), its
    facts and the segment (for the speed limit)."""

    profile: dict
    facts: RunSummary
    segment: object
    status: str = "ok"     # the point's status line (pareto.csv's)
    study_time: bool = False  # the study's own running time, not a point of the front
    name: str = ""  # the case's name: all-out, +10 %, study 76 s


def profile_picks(cases, most=5):
    """Indices of the cases whose speed profiles a figure draws: up to ``most`` spread over the
    front, and the study's own running time."""
    front = [i for i, c in enumerate(cases) if not is_study_time(c)]
    spread = {front[j] for j in np.linspace(0, len(front) - 1, min(most, len(front))).round().astype(int)}
    return sorted(spread | {i for i, c in enumerate(cases) if is_study_time(c)})


def own_status(status, das=None):
    """A point's ATO run's own status: ``status`` (a :class:`Status`) less what its driver advice
    (``das``: the point's ``das_`` columns, or None) adds to it (``das.methods.advice_status``): a
    point flagged for its advice alone has an ok run."""
    return OK if das is not None and str(status) == str(advice_status(das)) else status


def front_points(cases, rows, picks):
    """The stored points at the indices ``picks`` (those solved) as :class:`FrontPoint`, in order of
    running time."""
    points, segment = points_of(cases, rows), None
    out = []
    for i in picks:
        summary, status = points[i]
        if summary and "profile" in summary:
            segment = segment or segment_of(cases[0])
            out.append(FrontPoint({k: np.asarray(v) for k, v in summary["profile"].items()},
                                  facts_of(summary), segment, str(own_status(status, summary.get("das"))),
                                  is_study_time(cases[i]), cases[i]["name"]))
    return sorted(out, key=lambda p: p.facts.running_time_s)


def pick_statuses(cases, rows, picks):
    """{name: status line} of the points at the indices ``picks``, those not solved too (a figure of
    their profiles names them, not drawn): each point's ATO run's own status (:func:`own_status`)."""
    points = points_of(cases, rows)
    return {cases[i]["name"]: str(own_status(points[i][1], (points[i][0] or {}).get("das"))) for i in picks}


def front_size(where, cases, workers=1):
    """Refuse a front estimated above the command's budget (unless forced)."""
    case = cases[0]
    nodes, tables = case_size(case, {})
    check_front(where, len(cases), nodes, workers, case["das"], case["das_time_limit_s"], tables)


STUDY_KINDS.register("pareto", StudyKind(expand_front, run_case, pareto_table, front_size, table_file="pareto.csv",
                                         table_name="pareto", verdict=front_verdict),
                     doc="energy against running time: each point of the front a case (Farooqi 2018, §7.1.1)")
