"""A network study as a study kind: each strategy a case (Farooqi 2018, Ch. 7), run by the one
study engine (:func:`ecostudy.studies.batch.run_expanded`: stored, resumable, in worker processes
or on Dask).

:func:`expand_network` checks the study's size, then plans the fleet once (all-out times, every
segment's first run; over ``pool`` when given), which travels in every case beside its key (the
key hashes the study's fields, its track and train documents and the strategy, not the fleet).
Every strategy but the independent runs starts from them: a process solves them once and keeps
them (:data:`_INDEPENDENT`); a worker or a resumed command that did not solve them solves them
again from the same fleet, which gives the same runs (the results are the same with any number of
workers, ``tests/test_workers.py``). The table is one row per strategy
(``network_substation.csv``); the other files: ``report.files.write_network_files``.
"""
import json
import threading
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from ecostudy.core.errors import InfeasibleError, InputError, problem
from ecostudy.core.grid import warn_unmodelled
from ecostudy.core.status import status_word
from ecostudy.io.documents import read_document
from ecostudy.io.loaders import load_network_study, validate
from ecostudy.io.schemas import NetworkStudyFile
from ecostudy.io.store import check_one_study
from ecostudy.io.writers import check_output_dir
from ecostudy.network import fleet as fleets
from ecostudy.network.headway import say_timetable, timetable_conflict
from ecostudy.network.strategies import DEAREST_FIRST, one_strategy, solve_independent
from ecostudy.ocp.timedomain import LegRun
from ecostudy.studies.batch import STUDY_KINDS, Expanded, StudyKind, outcome
from ecostudy.studies.cases import case_key
from ecostudy.studies.legpool import shared_pool
from ecostudy.studies.sizes import check_network_study
from ecostudy.studies.workers import kept

_INDEPENDENT: dict = {}  # the independent runs of a study and their wall time, per process
_SOLVING = threading.Lock()  # held while a thread reads or solves them


def expand_network(path, workers=1, pool=None, note=None, out=None, files=()):
    """A network study file's strategies as cases, each carrying the planned fleet (``pool``: a
    process pool for the segments' first runs; ``note(line)``: the plan in a line), into ``out``
    (default: the study's output). Before anything is solved, a study too big for a run or for the
    command is refused (unless forced) and the output folder checked (for ``files`` too: the
    command's figures)."""
    path = Path(path)
    st = load_network_study(path)
    if st.buffer is not None and st.buffer >= st.track.length:
        raise InputError(problem(path, "buffer_m", f"{st.buffer:g} m is not shorter than the line ({st.track.length:g} m): "
                                 "no train could follow another"))
    check_network_study(st, path, workers)
    output = check_output_dir(Path(out) if out else st.output, ("network_substation.csv", "results.sqlite", *files),
                              "network")
    check_one_study(output, st.name)  # before the fleet's first runs are solved
    s = validate(NetworkStudyFile, read_document(path), path)
    try:
        fl = fleets.plan(st.track, st.train, st.stops, st.running_times, st.dwell, st.offsets, st.names, st.dt,
                         st.supply, st.points, st.buffer, pool, st.supplement, check=partial(_timetable_kept, path))
    except InfeasibleError as exc:  # a running time below a segment's all-out time: the study's field, by name
        raise InfeasibleError([problem(path, "running_times_s", p) for p in exc.problems]) from None
    for leg in fl.legs[0]:  # said here, once: the legs are solved in worker processes, whose warnings never show
        warn_unmodelled(leg.case.segment, "the time-domain legs", leg.case.train)
    if note:
        segments, asked = len(st.stops) - 1, ", ".join(f"{t:.1f}" for t in fl.asked_times)
        note(f"{len(st.names)} trains, {segments} segment{'s' * (segments != 1)} ({asked} s before rounding to "
             f"{st.dt} s steps), {fl.steps} clock steps")
    inputs = {"fields": s.model_dump(mode="json", exclude={"output", "strategies"}),
              "train": st.documents[0], "track": st.documents[1]}
    base = case_key(inputs)
    cases = []
    for name in st.strategies:
        case = {"study": st.name, "inputs": base, "strategy": name, "scenario": name, "name": name,
                "labels": {"strategy": name}}
        case["key"] = case_key(case)
        case["fleet"] = fl  # after the key: the fleet follows from the inputs the key hashes
        cases.append(case)
    return Expanded(output, cases)


def _timetable_kept(path, fleet):
    """Refuse a study whose timetable alone puts a train nearer the tail of the one ahead than
    ``buffer_m`` (without it: on it), whatever the trains run (``network.headway.timetable_conflict``)."""
    found = timetable_conflict(fleet)
    if found is not None:
        raise InputError(problem(path, "trains", say_timetable(found, fleet.buffer)))


def run_network_strategy(case, pool=None):
    """One strategy of :func:`expand_network`, solved and scored; never raises. ``pool``: a process
    pool its legs share with the other strategies of the study (:mod:`ecostudy.studies.legpool`,
    which calls this in threads of one process)."""
    return outcome(case, lambda: _strategy(case, pool))


def _strategy(case, pool):
    mapper = pool.map if pool is not None else map
    with _SOLVING:  # the first thread here solves the independent runs, the others wait for them
        ind, wall = kept(_INDEPENDENT, case["inputs"], lambda: solve_independent(case["fleet"], mapper))
    result = one_strategy(case["fleet"], case["strategy"], ind, wall, pool)
    if "failed" in result:
        return "failed", result["failed"], {"wall_s": result["wall_s"]}
    status, _, reason = result["totals"]["status"].partition(": ")
    summary = {"totals": result["totals"], "trains": result["trains"], "info": result["info"],
               "steps": result["steps"].to_dict("list"),
               "runs": [[{**{k: getattr(run, k) for k in ("s", "v", "ft", "fb", "fr", "p")}, "notes": run.notes}
                         for run in train] for train in result["runs"]]}
    return status, reason or None, _plain(summary)


def _plain(data):
    """``data`` with numpy numbers and arrays as Python ones (the store keeps JSON)."""
    return json.loads(json.dumps(data, default=lambda x: x.tolist() if isinstance(x, (np.ndarray, np.generic))
                                 else str(x)))


def outcomes(cases, rows):
    """{strategy: its outcome as ``network.strategies.run_strategies`` gives it} from the stored
    rows (``runs`` as :class:`~ecostudy.ocp.timedomain.LegRun`, ``steps`` a DataFrame; a failed
    one: ``failed`` and ``wall_s``), in study order."""
    out = {}
    for case in cases:
        row = rows.get(case["key"]) or {"status": "failed", "error": "not computed yet", "summary": None}
        s = row["summary"] or {}
        if "totals" not in s:
            out[case["strategy"]] = {"failed": row["error"] or row["status"], "wall_s": s.get("wall_s")}
            continue
        runs = [[LegRun(*(np.asarray(r[k]) for k in ("s", "v", "ft", "fb", "fr", "p")), r["notes"]) for r in train]
                for train in s["runs"]]
        out[case["strategy"]] = {"runs": runs, "steps": pd.DataFrame(s["steps"]), "trains": s["trains"],
                                 "totals": s["totals"], "info": s["info"]}
    return out


def saving_reference(done):
    """(the independent runs' substation energy [kWh] the savings are measured against, or None;
    why there is none, or None): a saving against independent runs that are not ok (traction left
    unserved, the buffer broken, a failed run) would read like a result, so there is none."""
    ind = done.get("independent")
    if ind is None:
        return None, None  # not among the study's strategies: no saving column to explain
    status = ind["totals"]["status"] if "totals" in ind else "failed"
    if status_word(status) != "ok":
        return None, (f"saving_vs_independent_pct left empty: the independent run it is measured against is "
                      f"{status_word(status)} (its status says why)")
    return ind["totals"]["substation_kWh"], None


def network_table(cases, rows):
    """One row per strategy (``network_substation.csv``): the substation's energy and every total
    of the circuit, the saving against independent driving (empty, with a ``note`` and the attr
    ``saving_note``, where the independent run is not ok: :func:`saving_reference`), ``status``;
    attrs: the clock, and the strategy of least substation energy among those whose status is ok
    (every run verified, nothing flagged: a strategy that leaves traction unserved or brings trains
    within buffer_m may draw least because of it), with its saving."""
    done = outcomes(cases, rows)
    base, why = saving_reference(done)
    table = []
    for name, res in done.items():
        if "failed" in res:
            table.append({"strategy": name, "status": f"failed: {res['failed']}", "wall_s": res["wall_s"],
                          "all_verified": False})
            continue
        tot = res["totals"]
        table.append({"strategy": name, **tot,
                      "saving_vs_independent_pct": None if base is None else 100 * (1 - tot["substation_kWh"] / base),
                      **({"note": why} if why else {})})
    fl = cases[0]["fleet"]
    verified = [row for row in table if row.get("all_verified") and row.get("substation_kWh") is not None
                and row.get("status") == "ok"]
    table = pd.DataFrame(table)
    for column in ("saving_vs_independent_pct", "separation_min_m"):  # None (no reference, no two trains on the line): NaN
        if column in table:
            table[column] = pd.to_numeric(table[column])
    table.attrs.update(steps_count=fl.steps, dt_s=fl.dt, **({"saving_note": why} if why else {}))
    if verified:  # the headline: the ok strategy whose re-simulated runs draw least from the substation
        least = min(verified, key=lambda row: row["substation_kWh"])
        table.attrs.update(least_substation_strategy=least["strategy"], least_substation_kWh=least["substation_kWh"],
                           independent_substation_kWh=base, least_saving_vs_independent_pct=least["saving_vs_independent_pct"])
    return table


def _dearest_first(case):
    return DEAREST_FIRST.index(case["strategy"]) if case["strategy"] in DEAREST_FIRST else -1


def expand_network_kind(path, out=None):
    """:func:`expand_network` into ``out`` (the study kind's ``expand_into``: ``ecostudy run --kind network``)."""
    return expand_network(path, out=out)


STUDY_KINDS.register("network", StudyKind(expand_network, run_network_strategy, network_table,
                                          expand_into=expand_network_kind, table_file="network_substation.csv", table_name="substation",
                                          spread=partial(shared_pool, first=_dearest_first)),
                     doc="trains sharing a DC substation, each strategy a case (Farooqi 2018, Ch. 7)")
