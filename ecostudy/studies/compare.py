"""Strategies side by side on one scenario (Farooqi 2018, Tables 4.2, 6.1): a study kind, each
strategy a case (all-out, ATO optimum, eco-drive coasting, MARECO-style, DAS round, DAS phases),
run by the one study engine (:func:`ecostudy.studies.batch.run_expanded`: stored, resumable, in
worker processes or on Dask).

Every row is scored by the independent simulator (times, energies and stop errors are the
simulated ones), so optimised and heuristic strategies are measured alike. The four strategies
after the ATO optimum start from it (its running time, its handle, its run for the DAS phases
NLP): a process solves it once and keeps it (:data:`_ATO`); a worker or a resumed command that
did not solve it solves it again from the same inputs, which gives the same optimum (Ipopt is
deterministic for one NL file).
"""
import warnings
from dataclasses import replace

import numpy as np
import pandas as pd

from ecostudy.analysis.single import solve_run
from ecostudy.core.defaults import RUN_POINTS
from ecostudy.core.errors import EcostudyWarning, InfeasibleError, InputError, TooFastError, problem
from ecostudy.core.registry import Registry
from ecostudy.core.grid import make_segment
from ecostudy.core.simulate import Driven, Trace, worst_overspeed
from ecostudy.core.status import Status, at_stop, calibrated, driven_run, failed, status_word, worst
from ecostudy.core.types import Timing
from ecostudy.core.units import to_kmh
from ecostudy.das.advice import das_phases, grid_note, nearest_levels, no_scale
from ecostudy.heuristics import ecodrive
from ecostudy.io.loaders import track_from_schema, train_from_schema
from ecostudy.io.schemas import TrackFile, TrainFile
from ecostudy.ocp.problem import check_not_crawling, prepare, under_envelope
from ecostudy.studies.batch import STUDY_KINDS, Expanded, StudyKind, outcome
from ecostudy.studies.cases import case_key, load_checked_study
from ecostudy.studies.options import no_windows
from ecostudy.studies.estimate import case_size
from ecostudy.studies.sizes import check_compare
from ecostudy.studies.workers import kept

ROW = ("strategy", "running_time_s", "traction_energy_kWh", "net_energy_kWh", "stop_error_m", "overspeed_max_kmh",
       "handle_changes")
GRIP = ("adhesion_use_max",)  # a column of a train with an adhesion limit only (core.simulate.adhesion_use)
_SCENARIO = ("train", "track", "from", "to", "running_time_s", "supplement", "points")
_ATO: dict = {}  # the ATO optimum of a scenario, per process: the base of the strategies after it
# without a running time or a supplement the energy optimum chooses its own time (on the metro a
# crawl of 22 million s) and every strategy after it would be driven and judged against that
NO_TIME = ("compare needs a running time or a supplement for its base case (the strategies are driven to it and "
           "judged by it; objective 'time', a sweep or scenarios give the base case none)")


def compare_cases(train_doc, track_doc, from_stop, to_stop, timing, points=RUN_POINTS, study="compare"):
    """One case per strategy (:data:`COMPARED`) of a scenario: the train and track documents
    (schema-shaped), the stops, the timing (a running time [s] or a supplement, a fraction over the
    all-out time) and the grid; each keyed by a hash of all of them and the strategy."""
    scenario = {"study": study, "train": train_doc, "track": track_doc, "from": from_stop, "to": to_stop,
                "running_time_s": timing.running_time, "supplement": timing.supplement, "points": points}
    cases = []
    for name in COMPARED.names():
        case = {**scenario, "strategy": name, "scenario": name, "name": name, "labels": {"strategy": name}}
        case["key"] = case_key(case)
        cases.append(case)
    return cases


def check_timing(case, where, field):
    """Refuse, before any strategy is computed, a running time no strategy can keep: under the fastest
    envelope's by more than ``ocp.problem.ENVELOPE_MARGIN``, or over ``core.defaults.SLOWEST`` times
    it (a crawl, refused by ``solve`` too), and a case with neither a running time nor a supplement
    (:data:`NO_TIME`) (one line naming ``where`` and ``field``)."""
    asked = case["running_time_s"]
    if asked is None:
        if case["supplement"] is None:
            raise InputError(problem(where, field, NO_TIME))
        return
    track, train = _inputs(case)
    prepared = prepare(track, train, case["from"], case["to"], case["points"])
    if under_envelope(asked, prepared.estimate):
        raise InfeasibleError(problem(where, field, f"infeasible: the fastest possible run takes about "
                                      f"{prepared.estimate:.1f} s (asked for {asked:g} s)"))
    try:
        check_not_crawling(asked, prepared)
    except TooFastError as exc:
        raise InfeasibleError([problem(where, field, p) for p in exc.problems]) from None


def expand_compare(path):
    """A study file's base case as a comparison (``ecostudy run FILE --kind compare``): its timing,
    its grid; written beside its output (``<output>_compare``)."""
    st = load_checked_study(path, "compare")
    no_windows(st, "compare", path)
    train_doc, track_doc = st.documents
    cases = compare_cases(train_doc, track_doc, st.from_stop, st.to_stop, st.timing, st.points or RUN_POINTS, st.name)
    check_timing(cases[0], path, st.timing_field)
    return Expanded(st.output.parent / (st.output.name + "_compare"), cases)


def _inputs(case):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)  # shown once when the comparison was expanded
        train = train_from_schema(TrainFile.model_validate(case["train"]), case["study"])
    return track_from_schema(TrackFile.model_validate(case["track"])), train


def _ato(case, track, train):
    if case["running_time_s"] is None and case["supplement"] is None:  # refused by check_timing before this
        raise InputError(problem(case["study"], "running_time_s", NO_TIME))
    return kept(_ATO, case_key({k: case[k] for k in _SCENARIO}),
                lambda: solve_run(track, train, case["from"], case["to"],
                                  Timing(running_time=case["running_time_s"], supplement=case["supplement"]),
                                  points=case["points"]))


def target_time(case, ato):
    """The running time [s] the strategies are driven to and every arrival is measured against: the
    case's own, or its supplement over the all-out time the ATO optimum's solve found; never a time
    the optimum's NLP arrived at by itself."""
    if case["running_time_s"] is not None:
        return float(case["running_time_s"])
    return ato.facts.all_out_time_s * (1 + case["supplement"])


def run_strategy(case):
    """One strategy of :func:`compare_cases`, driven by the simulator; never raises."""
    return outcome(case, lambda: COMPARED.get(case["strategy"])(case, *_inputs(case)))


def _all_out(case, track, train):
    run = solve_run(track, train, case["from"], case["to"], Timing(), objective="time", points=case["points"])
    return _stored(Driven("all-out", run.handle, run.trace), train, run.segment, run.status, verified=verified(run))


def _ato_optimum(case, track, train):
    ato = _ato(case, track, train)
    return _stored(Driven("ATO optimum", ato.handle, ato.trace), train, ato.segment, ato.status,
                   target_s=target_time(case, ato), verified=verified(ato))


def _after_ato(drive):
    """A strategy driven from the ATO optimum: ``drive(case, train, prepared, ato)`` -> (its driven
    run, columns of its own, a status of its own or None), scored by the simulator against the
    target time (:func:`target_time`, the optimum's running time)."""
    def strategy(case, track, train):
        ato = _ato(case, track, train)
        target = target_time(case, ato)
        prepared = prepare(track, train, case["from"], case["to"], case["points"])
        driven, extra, own = drive(case, train, prepared, ato)
        driven = replace(driven, name=case["strategy"])  # its row named as registered
        row, overspeed = driven.row(train, prepared.segment.distance), overspeed_kmh(prepared.segment, driven)
        late = row["running_time_s"] - target if at_stop(row["stop_error_m"]) else None  # off its stop: no arrival
        status = driven_run(row["stop_error_m"], late, overspeed, row.get("adhesion_use_max"),
                            early_s=None if late is None else -late, moving_kmh=to_kmh(float(driven.trace.v[-1])))
        if own is not None:  # the same checks, and how its own NLP ended
            status = worst([status, own])
        return _stored(driven, train, prepared.segment, status, target_s=target, overspeed_max_kmh=overspeed, **extra)
    return strategy


def heuristic_strategy(rule):
    """A rule of thumb as a strategy: ``rule(prepared case, running time [s]) -> Driven``
    (``heuristics.ecodrive``), driven to the ATO optimum's running time."""
    return _after_ato(lambda case, train, prepared, ato: (rule(prepared, target_time(case, ato)), {}, None))


def _nearest_levels(case, train, prepared, ato):
    return nearest_levels(prepared.segment, train, prepared.nodes, ato.handle), {}, None


def _das_phases(case, train, prepared, ato):
    block, _, driven = das_phases(ato, case["points"])
    return driven, {"handle_changes": block["mode_changes"]}, Status.parse(block["status"])  # the advice rows minus one


# the strategies side by side, in the table's order: each ``strategy(case, track, train)`` -> (status, reason, summary)
COMPARED: Registry = Registry("compared strategy")
COMPARED.register("all-out", _all_out, doc="the fastest run")
COMPARED.register("ATO optimum", _ato_optimum, doc="the energy-optimal run")
COMPARED.register("eco-drive coasting", heuristic_strategy(ecodrive.eco_coasting), doc="coasting to the time")
COMPARED.register("MARECO-style", heuristic_strategy(ecodrive.mareco), doc="cruise and coast to the time")
COMPARED.register("DAS round (nearest level)", _after_ato(_nearest_levels), doc="the optimum on the nearest DAS level")
COMPARED.register("DAS phases", _after_ato(_das_phases), doc="the DAS phases NLP from the optimum")


def verified(run):
    """Whether the independent re-simulation passed the run (a :class:`RunResult`)."""
    return bool(run.facts.verification and run.facts.verification.passed)


def overspeed_kmh(segment, driven):
    """The largest speed over the limits of a driven run [km/h] (:func:`~ecostudy.core.simulate.worst_overspeed`)."""
    return to_kmh(worst_overspeed(segment, driven.trace))


def _stored(driven, train, segment, status, **fields):
    """(status, reason, summary) of a strategy's run: its table row (with its largest speed over the
    limits, ``overspeed_max_kmh``, measured here unless ``fields`` gives it) and its simulated trace."""
    t = driven.trace
    trace = {"t_s": t.t.tolist(), "x_m": t.x.tolist(), "v_mps": t.v.tolist(),
             **{k: float(getattr(t, k)) for k in ("traction_energy", "braking_energy", "regenerated_energy",
                                                  "stop_position", "arrival_time", "net_energy")}}
    if "overspeed_max_kmh" not in fields:
        fields["overspeed_max_kmh"] = overspeed_kmh(segment, driven)
    summary = {**driven.row(train, segment.distance), **fields,
               "handle": np.asarray(driven.handle).tolist(), "trace": trace}
    status = worst([status, calibrated(train.calibration_reason)])  # a train of a flagged calibration: every run
    return status.kind, status.reason or None, summary


def outcomes(cases, rows):
    """The strategies' simulated runs (:class:`~ecostudy.core.simulate.Driven`) from the stored rows,
    in study order (a strategy not stored, or failed, has none)."""
    driven = []
    for case in cases:
        s = (rows.get(case["key"]) or {}).get("summary")
        if s:
            t = s["trace"]
            trace = Trace(*(np.asarray(t[k]) for k in ("t_s", "x_m", "v_mps")),
                          *(t[k] for k in ("traction_energy", "braking_energy", "regenerated_energy", "stop_position",
                                           "arrival_time", "net_energy")))
            driven.append(Driven(case["strategy"], np.asarray(s["handle"]), trace))
    return driven


def segment_of(case):
    """The segment a comparison's case runs over (for its figure: the speed limits)."""
    track, train = _inputs(case)
    return make_segment(track, train, case["from"], case["to"])


def compare_table(cases, rows):
    """One row per strategy: simulated running time, arrival error against the ATO optimum's time,
    energies, saving against the all-out run, gap to the optimum, stop error, handle changes
    (DAS phases: the advice rows minus one), status; a failed strategy's reason in ``note``. Its
    attrs (``summary.json``): the title, the target running time and whether both NLPs verified."""
    table, statuses, by_name = [], [], {}
    stored = [(rows.get(case["key"]) or {}).get("summary") or {} for case in cases]
    columns = (*ROW, *GRIP) if any(GRIP[0] in s for s in stored) else ROW  # a train with an adhesion limit
    for case in cases:
        row = rows.get(case["key"]) or {"status": "missing", "error": "not computed yet"}
        s = row.get("summary")
        by_name[case["strategy"]] = s or {}
        if s and row["status"] in ("ok", "flagged"):
            table.append({k: s.get(k) for k in columns})  # a row stored before a column existed: empty there
            statuses.append(str(Status.parse(row["status"], row.get("error") or "")))
        else:
            table.append({"strategy": case["strategy"], "note": row.get("error")})
            statuses.append(str(failed(row.get("error") or row["status"])))
    table = pd.DataFrame(table, columns=[*columns, *(["note"] if any("note" in r for r in table) else [])])
    # a saving or a gap is measured against a reference run only where that run is ok: against a
    # flagged one (an optimum that failed its re-simulation) it would read like a result
    trusted = {c["strategy"]: status_word(st) == "ok" for c, st in zip(cases, statuses)}
    e_allout, e_opt = (by_name[name].get("traction_energy_kWh", np.nan) if trusted[name] else np.nan
                       for name in ("all-out", "ATO optimum"))
    optimum = by_name["ATO optimum"]
    small = no_scale(e_opt, _inputs(cases[0])[1], float(np.max(optimum["trace"]["v_mps"])),
                     "the ATO optimum's traction energy") if np.isfinite(e_opt) else ""
    if small:  # a run down a grade that needs no traction: a gap to it would read in millions of percent
        e_opt = np.nan
        table["note"] = [f"no gap to the optimum: {small}" if name == "ATO optimum" else note
                         for name, note in zip(table["strategy"], table.get("note", [None] * len(table)))]
    target = next((s["target_s"] for s in by_name.values() if "target_s" in s), np.nan)
    table.insert(4, "saving_vs_all_out_pct", 100 * (1 - table["traction_energy_kWh"] / e_allout))
    table.insert(5, "gap_to_optimum_pct", 100 * (table["traction_energy_kWh"] / e_opt - 1))
    table.insert(2, "arrival_error_s", table["running_time_s"] - target)
    # a strategy that stood short of the stop or past it did another run: no arrival, saving or gap read as a result
    off = ~at_stop(table["stop_error_m"].astype(float))
    table.loc[off, ["arrival_error_s", "saving_vs_all_out_pct", "gap_to_optimum_pct"]] = np.nan
    below = [grid_note(g, cases[0]["points"], what="this run") if status_word(st) == "ok" else ""
             for g, st in zip(table["gap_to_optimum_pct"], statuses)]
    if any(below):  # an ok run cheaper than the optimum by more than its grid's error: said, not read as better
        notes = table["note"] if "note" in table else pd.Series([None] * len(table))
        table["note"] = [b or n for b, n in zip(below, notes)]
    table["status"] = statuses
    case = cases[0]
    train_name = case["train"].get("name", "train")
    table.attrs.update(title=f"{train_name} - {case['from']} to {case['to']}, target {target:.1f} s",
                       target_running_time_s=None if np.isnan(target) else float(target),
                       ato_verified=bool(by_name["ATO optimum"].get("verified") and by_name["all-out"].get("verified")))
    return table


def compare_size(where, cases, workers=1):
    """Refuse a comparison estimated above the command's budget (unless forced)."""
    check_compare(where, *case_size(cases[0], {}))  # its grid's nodes and the train's table points, as solve's


STUDY_KINDS.register("compare", StudyKind(expand_compare, run_strategy, compare_table, compare_size,
                                          table_file="compare.csv", table_name="compare"),
                     doc="strategies side by side on a study's base case, each scored by the simulator")
