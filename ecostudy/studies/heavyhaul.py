"""Heavy-haul studies (``ecostudy heavyhaul``, ``ecostudy run FILE --kind heavyhaul``): Zhang &
Zhuan's braking-penalised receding-horizon controller on the full cascade plant, one case per
(K_b, f, Np, Nc), a registered study kind run by the one study engine
(:func:`ecostudy.studies.batch.run_expanded`: stored, resumable, processes or Dask). The reference
speed is solved once, when the study is expanded, and travels in every case (cases are
self-contained and keyed by a hash of their inputs).

Per run, the columns of Zhang & Zhuan's Tables III-IV: the tracking error |mean speed - v_r| (mean,
std), the in-train forces (max over the integrator's points, also over the braking samples, mean and
std of |f_in| over couplers and samples), the energies int |u v| dt of the wagons and in total; what
:mod:`ecostudy.heavyhaul.metrics` reads (arrival, stop error, limits, eq. 4's terms at the optimum,
the energy balance); and the QP's size as solved, its solve time per step (mean, p95, max), the steps
over Ts and the process's peak memory. A run that missed anything is ``flagged`` with every reason.
"""
import resource
import warnings
from functools import partial
from itertools import product
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from ecostudy.core.errors import EcostudyWarning, InfeasibleError, InputError, problem
from ecostudy.core.grid import Segment, make_segment
from ecostudy.core.units import KMH, KN, KWH
from ecostudy.core.status import OK, cells, part, unproven_columns, unproven_solves
from ecostudy.heavyhaul.airbrake import application_time, brake_lag
from ecostudy.heavyhaul.checks import (braking_asked, end_off, reference_problems, ruling_grade, samples_to_start,
                                       starting_coupler_force, unmodelled_tunnels)
from ecostudy.heavyhaul.condensed import ClarabelSolver, CondensedHorizon
from ecostudy.heavyhaul.linear import fence, locomotive_groups
from ecostudy.heavyhaul.loop import reduced_state, run
from ecostudy.heavyhaul.metrics import Tolerances, closing_metrics, in_train_metrics, reasons, run_metrics
from ecostudy.heavyhaul.observer import KalmanObserver
from ecostudy.heavyhaul.plant import CascadePlant
from ecostudy.heavyhaul.reference import Reference, optimal_reference, single_mass, table_reference
from ecostudy.heavyhaul.qp import ConicHorizon
from ecostudy.heavyhaul.rhc import RecedingHorizon, Scales
from ecostudy.io import schemas
from ecostudy.io.documents import named_file
from ecostudy.io.heavyhaulfile import HeavyhaulFile
from ecostudy.io.loaders import (check_fits, chosen_stops, consist_from_document, read_document, read_track,
                                 track_from_schema, validate)
from ecostudy.io.tables import number_columns
from ecostudy.io.writers import check_output_dir, default_output
from ecostudy.studies.batch import STUDY_KINDS, Draw, Expanded, StudyKind, outcome, run_expanded
from ecostudy.studies.cases import case_key
from ecostudy.studies.sizes import check_heavyhaul_study


def _reference(s, path, consist, track, from_stop, to_stop):
    """(the study's reference, its status): a user's table is ``ok``; the single-mass optimum is its
    run's (Ipopt proved it optimal, its re-simulation agrees), named ``the reference run``."""
    r = s.reference
    if r.table is not None:
        where = named_file(path, "reference.table", r.table)
        table = number_columns(where, ("distance_m", "speed_kmh"))  # text, NaN, a missing column: one line
        extra = [c for c in pd.read_csv(where, nrows=0).columns if c not in ("distance_m", "speed_kmh")]
        if extra:
            warnings.warn(problem(where, ", ".join(map(str, extra)), "not read: a reference table is distance_m and "
                                  "speed_kmh"), EcostudyWarning, stacklevel=2)
        return table_reference(table["distance_m"], table["speed_kmh"], where), OK  # a bad row: one line naming it
    supplement = None if r.supplement_percent is None else r.supplement_percent / 100
    lead = r.limit_lead_samples * s.sample_time_s + (application_time(consist) if s.air_brake else 0.0)  # the pipe's lateness
    try:
        reference, run = optimal_reference(consist, track, from_stop, to_stop, r.running_time_s, supplement, r.points,
                                           r.service_deceleration_mps2, lead, brake_lag(consist) if s.air_brake else 0.0)
    except InfeasibleError as exc:  # the single mass cannot run so fast: the study's field, by name
        field = "reference.running_time_s" if r.running_time_s is not None else "reference.supplement_percent"
        raise InfeasibleError([problem(path, field, f"infeasible: {p.removeprefix('infeasible: ')}") for p in exc.problems])
    return reference, part("the reference run", run.status)


def _utmost_braking(consist):
    """The deceleration of every brake at its full force (dynamic and pneumatic) over the train's mass [m/s^2]."""
    train = single_mass(consist, 1.0)
    return train.braking.max_force / train.mass


def expand(path, out=None):
    """(study, output folder, reference, cases); inputs and the bad-input checks run here, once, the
    output folder (``out``, else the study's own) checked before the reference run is solved."""
    path = Path(path)
    s = validate(HeavyhaulFile, read_document(path), path)
    for fields, why in s.unused():
        warnings.warn(problem(path, ", ".join(fields), why), EcostudyWarning, stacklevel=2)
    output = Path(s.output) if s.output else default_output(s.name)  # relative: to the working directory
    check_output_dir(out or output, ("runs.csv", "results.sqlite"), "heavyhaul")
    consist_path = named_file(path, "consist", s.consist)
    consist_doc = read_document(consist_path)
    consist = consist_from_document(consist_doc, consist_path)
    missing = [problem(path, name, f"the consist '{s.consist}' gives no {name} data") for name in ("air_brake", "draft_gear", "notches")
               if getattr(s, name) and getattr(consist, name) is None]
    if missing:
        raise InputError(missing)
    track_path = named_file(path, "track", s.track)
    track_doc, track = read_track(track_path)  # a bad field: in its file, as it names it
    check_fits(consist_path, single_mass(consist, 1.0), track, "vehicles")
    from_stop, to_stop = chosen_stops(track, s.from_stop, s.to_stop, path)
    track, tunnels = unmodelled_tunnels(track, from_stop, to_stop)  # not a train's missing tunnel_resistance
    if tunnels:
        warnings.warn(problem(track_path, "tunnels", f"the heavy-haul plant does not model tunnel resistance (nor does "
                              f"its single-mass reference; a consist file has no field for it): every tunnel between "
                              f"'{from_stop}' and '{to_stop}' ({tunnels}) costs nothing in these runs"),
                      EcostudyWarning, stacklevel=2)
    segment = make_segment(track, single_mass(consist, 1.0), from_stop, to_stop)
    grade = ruling_grade(segment, float(consist.length.sum()))
    force, needed = starting_coupler_force(consist, grade)
    if force > consist.force_limit:
        raise InputError(problem(consist_path, "couplers.force_limit_kN", f"{consist.force_limit / KN:g} kN "
                                 f"is below the {force / KN:.0f} kN a coupler carries when the train starts on the "
                                 f"ruling grade ({1e3 * grade:.1f} per mille) of '{track.name}'"))
    reference, trusted = _reference(s, path, consist, track, from_stop, to_stop)
    field = "reference.table" if s.reference.table else "reference"
    off = s.reference.table and end_off(reference, segment, s.stop_tolerance_m)  # the last row: one line, that row
    problems = [problem(named_file(path, "reference.table", s.reference.table), f"distance_m, row {reference.distance.size + 1}",
                        off)] if off else []
    problems += [problem(path, field, p) for p in reference_problems(reference, segment, s.speed_tolerance_kmh * KMH, not off)]
    braking = s.reference.table and not problems and braking_asked(  # of a table followable otherwise
        reference, _utmost_braking(consist), s.reference.service_deceleration_mps2)
    hard = problem(named_file(path, "reference.table", s.reference.table), *braking[:2]) if braking else None
    if braking and braking[2]:  # beyond the brakes: refused (beyond the service rate: followed, said below)
        problems.append(hard)
    problems += [problem(path, "fence", f"{f} is not within 1..{consist.cars} (the consist's cars)")
                 for f in s.fence if f > consist.cars]
    if s.effort_penalty == "magnitude" and s.qp_solver not in MAGNITUDE_FORMS:
        problems.append(problem(path, "effort_penalty", f"magnitude is solved by qp_solver {' or '.join(MAGNITUDE_FORMS)} "
                                f"(the condensed QP), not {s.qp_solver}"))
    if s.brake_penalty_on == "all" and (s.qp_solver not in MAGNITUDE_FORMS or s.effort_penalty != "squared"):
        problems.append(problem(path, "brake_penalty_on", f"all is solved with effort_penalty squared by qp_solver "
                                f"{' or '.join(MAGNITUDE_FORMS)} (the condensed QP), not {s.effort_penalty} by {s.qp_solver}"))
    if s.brake_penalty_on == "all" and min(s.brake_penalty) < 1:
        problems.append(problem(path, "brake_penalty_on", f"all needs every brake_penalty >= 1 (a braking locomotive's "
                                f"term K_b u^2 is u^2 plus (K_b - 1) u^2; got {min(s.brake_penalty):g})"))
    fewest = min([locomotive_groups(consist.kinds, f) for f in s.fence if f <= consist.cars] or [1])  # no model built
    ramp = samples_to_start(needed, s.rate_kN_per_sample * KN, fewest)  # the fewest locomotive groups ramp slowest
    if ramp * s.sample_time_s > reference.running_time:
        problems.append(problem(path, "rate_kN_per_sample", f"{s.rate_kN_per_sample:g} kN per sample takes {ramp:.3g} "
                                f"samples to reach the {needed / KN:.0f} kN the train needs on the ruling grade; the "
                                f"trip has {reference.running_time / s.sample_time_s:.0f}"))
    if s.max_samples * s.sample_time_s < reference.running_time:  # every run would stop short, flagged, at the cap
        problems.append(problem(path, "max_samples", f"{s.max_samples} samples of {s.sample_time_s:g} s (sample_time_s) "
                                f"end {s.max_samples * s.sample_time_s:.3g} s in, before the reference's "
                                f"{reference.running_time:.0f} s trip ends"))
    if problems:
        raise InputError(problems)
    if hard:
        warnings.warn(hard, EcostudyWarning, stacklevel=2)
    longest = max(h.np for h in s.horizons) * s.sample_time_s
    if longest > reference.running_time:
        raise InputError(problem(path, "horizons", f"a horizon of {longest:g} s (np x sample_time_s) is longer than "
                                 f"the trip ({reference.running_time:.0f} s)"))
    shared = {"study": s.name, "consist": consist_doc, "track": track_doc, "from": from_stop, "to": to_stop,
              "reference": {"distance": reference.distance.tolist(), "speeds": reference.speeds.tolist(),
                            "times": reference.times.tolist(), "energy": reference.energy},
              "sample_time": s.sample_time_s, "weights": s.weights.model_dump(), "rate_kN": s.rate_kN_per_sample,
              "observer": s.observer, "qp_solver": s.qp_solver,
              **({"observer_q": s.observer_q, "observer_r": s.observer_r} if s.observer else {}),
              "fence_coupling": s.fence_coupling, "fence_sharing": s.fence_sharing, "fence_weights": s.fence_weights,
              "objective_scale": s.objective_scale, "effort_penalty": s.effort_penalty, "adhesion": s.adhesion, "air_brake": s.air_brake, "draft_gear": s.draft_gear,
              **({"notches": True} if s.notches else {}),  # absent when off: the cases' keys as without the switch
              **({"brake_penalty_on": "all"} if s.brake_penalty_on == "all" else {}),  # likewise
              **({} if trusted.ok else {"reference_status": trusted.reason}),  # likewise: each run is flagged for it
              "max_samples": s.max_samples,
              "stop_tolerance_m": s.stop_tolerance_m, "speed_tolerance_kmh": s.speed_tolerance_kmh,
              "arrival_tolerance_percent": s.arrival_tolerance_percent, "arrival_tolerance_s": s.arrival_tolerance_s}
    cases = []
    for kb, f, h in product(s.brake_penalty, s.fence, s.horizons):
        case = {**shared, "K_b": kb, "scenario": f"Kb={kb:g} f={f} Np={h.np} Nc={h.nc}",  # K_b exact: in the key
                "labels": {"K_b": kb, "f": f, "Np": h.np, "Nc": h.nc}}
        case["key"] = case_key(case)
        case["plan"] = Plan(s, reference, segment)  # after the key: all follow from the inputs the key hashes
        cases.append(case)
    return s, output, reference, cases


class Plan(NamedTuple):
    """What a heavy-haul case carries beside its key: the study file, the reference solved once at
    expansion and the line between the stops, its limits for the train's length at the head (for
    the study's size and its plots)."""

    study: HeavyhaulFile
    reference: Reference
    segment: Segment


QP_FORMS = {  # a study's qp_solver: the same QP four ways (docs/heavyhaul.md)
    "daqp": CondensedHorizon,  # condensed to the inputs, DAQP warm-started from the last working set
    "condensed": partial(CondensedHorizon, solver=ClarabelSolver),
    "clarabel": ConicHorizon,  # the states kept
    "ipopt": RecedingHorizon,  # the Pyomo model
}
MAGNITUDE_FORMS = ("daqp", "condensed")  # the forms with eq. 11's magnitudes and brake_penalty_on: all (heavyhaul.magnitude)


def case_plant(case):
    """(consist, the cascade plant with the case's switches, the reference) of a case."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)  # shown once when the study was expanded
        consist = consist_from_document(case["consist"], "consist")
        track = unmodelled_tunnels(track_from_schema(schemas.TrackFile.model_validate(case["track"])), case["from"],
                                   case["to"])[0]
    r = case["reference"]
    reference = Reference(*(np.array(r[k]) for k in ("distance", "speeds", "times")), r["energy"])
    plant = CascadePlant(consist, make_segment(track, single_mass(consist, 1.0), case["from"], case["to"]),
                         adhesion=case["adhesion"], air_brake=case["air_brake"],
                         draft_gear=case["draft_gear"], notches=case.get("notches", False))
    return consist, plant, reference


def drive(case):
    """One closed-loop run of a case: (consist, controller, record, reference, plant)."""
    consist, plant, reference = case_plant(case)
    reduction, controller = case_controller(case, consist, plant)
    state = plant.initial(head=-0.5 * consist.length[0], speed=0.0)
    observer = (KalmanObserver(reduction.model, reduction.kinds, q=case["observer_q"], r=case["observer_r"],
                               estimate=reduced_state(plant, reduction, state)) if case["observer"] else None)
    state, record = run(plant, reduction, controller, state, reference, case["max_samples"], observer=observer)
    return consist, controller, record, reference, plant


def case_controller(case, consist, plant):
    """(the fence reduction, the receding-horizon controller) of a case: the run's set-up (the
    condensed QP's prediction matrices and Hessian are built here, ``sizes.heavyhaul_setup_seconds``)."""
    labels, w, ts = case["labels"], case["weights"], case["sample_time"]
    reduction = fence(consist, labels["f"], ts, case["fence_coupling"], case["fence_sharing"])
    scales = None
    if case["objective_scale"] == "limits":  # docs/heavyhaul.md, "What the terms are measured in"
        largest = np.maximum(plant.traction_limits[0], plant.dynamic_limits[0] + consist.pneumatic_brake)
        scales = Scales(consist.force_limit / KN, reduction.effort_scale(largest, consist.mass, case["fence_weights"]) / KN,
                        float(plant.segment.limit.values.max()))
    controller = QP_FORMS[case["qp_solver"]](reduction.model, reduction.kinds, np_=labels["Np"], nc=labels["Nc"],
                      weights=(w["force"], w["speed"], w["energy"], labels["K_b"]), rate_kN=case["rate_kN"],
                      force_limit_kN=consist.force_limit / KN, scales=scales,
                      represented=reduction.represented(consist.mass, case["fence_weights"]),
                      effort=case["effort_penalty"], brake_on=case.get("brake_penalty_on", "wagons"))
    return reduction, controller


def summarise(consist, controller, record, reference, stop, locomotives=(), stop_tolerance=Tolerances().stop_m):
    """The per-run numbers (SI in, the units in the names out); ``stop`` the line's stop [m] (the
    plant's segment's length), ``locomotives`` the controller's locomotive (virtual) cars,
    ``stop_tolerance`` [m] how near the stop a run has arrived."""
    error = record.mean_speed - record.reference
    forces = np.abs(record.couplers) / KN
    wagons, total = record.wagon_brake_work, record.traction_work + record.dynamic_brake_work + record.wagon_brake_work
    size = controller.size
    step = max(1, consist.cars // 100)  # the heat map keeps at most about 100 couplers
    return {
        "tracking_mean_mps": float(np.mean(np.abs(error))), "tracking_std_mps": float(np.std(error)),
        **run_metrics(record, reference, list(locomotives), consist.force_limit, stop, stop_tolerance),
        "force_mean_kN": float(forces.mean()),
        "force_std_kN": float(forces.std()), "energy_total_kWh": total / KWH,
        "traction_kWh": record.traction_work / KWH, "dynamic_brake_kWh": record.dynamic_brake_work / KWH,
        "wagon_brake_kWh": wagons / KWH, "reference_kWh": reference.energy / KWH,
        "reference_time_s": reference.running_time, "samples": len(record.times),
        "virtual_cars": controller.n, "qp_inputs": size["inputs"], "qp_states": size["states"],
        "qp_constraints": size["constraints"], "solve_mean_ms": 1e3 * float(record.solve_seconds.mean()),
        "solve_p95_ms": 1e3 * float(np.percentile(record.solve_seconds, 95)),
        "solve_max_ms": 1e3 * float(record.solve_seconds.max()), "over_budget_count": record.overruns,
        **unproven_columns(list(record.unproven)),
        "peak_memory_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "profile": {"head_m": np.round(record.head, 1).tolist(), "speed_mps": np.round(record.mean_speed, 3).tolist(),
                    "reference_mps": np.round(record.reference, 3).tolist()},
        "forces_kN": np.round(record.couplers[:, ::step] / KN).astype(int).tolist(), "coupler_step": step,
    }


def run_heavyhaul_case(case):
    """One run of :func:`expand`'s cases; never raises: failures are results."""
    return outcome(case, lambda: _run(case))


def _run(case):
    consist, controller, record, reference, plant = drive(case)
    summary = {**summarise(consist, controller, record, reference, plant.segment.distance, controller.locos,
                           case["stop_tolerance_m"]),
               **in_train_metrics(plant.history, consist), **closing_metrics(plant.closest, consist, plant.travel)}
    why = reasons(summary, case["max_samples"], summary["over_budget_count"],
                  Tolerances(case["stop_tolerance_m"], case["speed_tolerance_kmh"] * KMH,
                             case["arrival_tolerance_percent"] / 100, case["arrival_tolerance_s"]))
    unproven = unproven_solves(summary["unproven_solves_count"], summary["samples"], summary["unproven_solver_status"])
    if not unproven.ok:  # the QP's plans it drove were usable, not proven optimal
        why.append(unproven.reason)
    if "reference_status" in case:  # the speeds it tracked are not a proven, verified optimum
        why.append(case["reference_status"])
    return ("flagged", "; ".join(why), summary) if why else ("ok", None, summary)


IN_TRAIN = ("draft_max_kN", "draft_coupler", "draft_position_m", "draft_time_s", "buff_max_kN", "buff_coupler",
            "buff_position_m", "buff_time_s", "run_ins_count", "run_outs_count", "fatigue_damage", "fatigue_damage_max",
            "fatigue_damage_coupler", "rainflow_cycles_over_100kN_count",  # metrics.in_train_metrics
            "compression_max_m", "compression_coupler", "compression_position_m", "compression_time_s",
            "compression_spacing_m", "compression_limit_m")  # metrics.closing_metrics
COLUMNS = ("tracking_mean_mps", "tracking_std_mps", "force_max_kN", "force_max_braking_kN", "force_limit_kN",
           "force_mean_kN", "force_std_kN", "energy_total_kWh", "traction_kWh", "dynamic_brake_kWh",
           "wagon_brake_kWh", "J_force", "J_tracking", "J_energy", "J_braking", "dynamic_brake_use_max",
           "dynamic_brake_use_mean", "dynamic_brake_at_limit_samples", "adhesion_use_max", "adhesion_use_time_s", "adhesion_use_head_m",
           "adhesion_use_kmh", "adhesion_use_effort_kN", "braking_samples", "stretch_braking_samples",
           "stretch_braking_kWh",
           "speed_excess_kmh", "running_resistance_kWh", "curve_resistance_kWh", "grade_kWh", "coupler_damping_kWh", "draft_gear_kWh", "stored_change_kWh",
           "balance_residual_kWh", "arrived", "ended", "ended_s", "arrival_s", "arrival_late_s", "arrival_late_pct", "reference_time_s", "reference_kWh", "stop_error_m", "rollback_m", "stalled_before_stop_m", "stalled_after_start_m", "reference_at_end_kmh",
           "speed_at_end_kmh", "rolling_back", "resistance_at_end_kN", "traction_utmost_at_end_kN", "held_s", "held_at_end",
           "traction_asked_at_end_kN", "samples", "virtual_cars",
           "qp_inputs", "qp_states", "qp_constraints", "solve_mean_ms", "solve_p95_ms", "solve_max_ms", "over_budget_count",
           "unproven_solves_count", "unproven_solver_status", "peak_memory_MB", *IN_TRAIN)


def expand_heavyhaul(path, out=None):
    """A heavy-haul study file as the study engine's cases (:func:`expand`), into its output."""
    _, output, _, cases = expand(path, out)
    return Expanded(output, cases)


def heavyhaul_size(where, cases, workers=1):
    """Refuse a heavy-haul study estimated above the command's budget (unless forced)."""
    study, reference = cases[0]["plan"].study, cases[0]["plan"].reference
    check_heavyhaul_study(where, study, reference, cases, workers)


def heavyhaul_table(cases, rows):
    """One row per run (``runs.csv``): its labels, status and reason, :data:`COLUMNS`, its wall time."""
    table = []
    for case in cases:
        row = rows.get(case["key"]) or {}
        s = row.get("summary") or {}
        status, reason = cells(row.get("status"), row.get("error"))
        table.append({**case["labels"], "status": status, "reason": reason,
                      **{c: s.get(c) for c in COLUMNS}, "wall_s": row.get("seconds")})
    return pd.DataFrame(table)


def heavyhaul_study(path, workers=1, dask=None, retry_failed=False, out=None, progress=None, draw=None, names=None):
    """Run the cases not stored yet through the study engine (kind ``heavyhaul``: ``runs.csv``,
    ``summary.json``, and the files ``draw(study)`` writes of the :class:`HeavyhaulStudy` and returns;
    ``names(cases)``: their file names, checked in the output folder before any run); returns a
    :class:`HeavyhaulStudy`."""
    study, output, reference, cases = expand(path, out)
    drawn = []  # the figures of the draw
    ran = run_expanded("heavyhaul", Expanded(output, cases), path, workers, dask, retry_failed, out, progress,
                       heavyhaul_files(draw, names, drawn))
    return HeavyhaulStudy(study, ran.table, ran.counts, ran.output, reference, cases, summaries_of(cases, ran.rows),
                          tuple(drawn))


def heavyhaul_files(draw=None, names=None, drawn=None):
    """The study engine's ``draw`` (:func:`~ecostudy.studies.batch.run_expanded`) of a heavy-haul
    study, the same for ``ecostudy heavyhaul`` and ``ecostudy run --kind heavyhaul``: the figures
    ``draw(study)`` writes of the :class:`HeavyhaulStudy` and returns (``report.heavyplots``; None:
    none; ``names(cases)``: the file names it may write), their names also appended to ``drawn``
    when given."""
    def files(out_dir, cases, rows, table):
        study, reference = cases[0]["plan"].study, cases[0]["plan"].reference  # solved at expansion
        written = draw(HeavyhaulStudy(study, table, {}, Path(out_dir), reference, cases,
                                      summaries_of(cases, rows))) if draw is not None else []
        if drawn is not None:
            drawn.extend(written)
        return written, {}
    return Draw(files, names or (lambda cases: ()))


def summaries_of(cases, rows):
    """Every case's stored summary by key ({} for a run not stored, or failed)."""
    return {c["key"]: (rows.get(c["key"]) or {}).get("summary") or {} for c in cases}


class HeavyhaulStudy(NamedTuple):
    """A heavy-haul study's outcome: the study file, the runs table, the counts, the output folder,
    the reference, the cases, every stored run's summary by case key and the figures drawn."""

    study: object
    runs: pd.DataFrame
    counts: dict
    output: Path
    reference: Reference
    cases: list
    summaries: dict
    files: tuple = ()


STUDY_KINDS.register("heavyhaul", StudyKind(expand_heavyhaul, run_heavyhaul_case, heavyhaul_table, heavyhaul_size,
                                            table_file="runs.csv", table_name="runs", expand_into=expand_heavyhaul),
                     doc="Zhang & Zhuan's braking-penalised receding-horizon control, one run per (K_b, f, Np, Nc)")
