"""Closed-loop studies (``ecostudy simulate``): every controller x every Monte Carlo draw.

A study file (:mod:`ecostudy.io.loopfile`) names a track, a train, an arrival window, the
controllers and the deviations. Each draw fixes the plant's true parameters (uniform in the given
ranges) and a noise seed; every controller drives the same draws (paired comparison). Cases are
self-contained and keyed by a hash of their inputs, so a study runs resumably on the batch
machinery (:func:`ecostudy.studies.batch.execute`): serially, in processes or on Dask.
"""
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from ecostudy.control.controllers import Quantised
from ecostudy.control.estimators import make_estimator
from ecostudy.control.loop import run_loop
from ecostudy.control.terminal import TerminalApproach
from ecostudy.core.columns import with_statistic
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.grid import make_segment
from ecostudy.core.plant import Noise, Plant, Truth
from ecostudy.core.status import (STOP_TOLERANCE_M, Status, calibrated, cells, driven_run, flagged, solver_part, unproven_solves,
                                  worst)
from ecostudy.core.types import State
from ecostudy.io import schemas
from ecostudy.io.loaders import (check_fits, chosen_stops, read_document, read_track, read_train, track_from_schema,
                                 train_from_schema, validate)
from ecostudy.io.documents import named_file
from ecostudy.io.loopfile import Controller, SimulateFile
from ecostudy.ocp.convex import FASTEST, ConvexProgram, trapezoid_grid
from ecostudy.ocp.problem import prepare
from ecostudy.io.writers import check_output_dir, default_output, write_csv
from ecostudy.studies.batch import Draw, Expanded, StudyKind, outcome, run_expanded
from ecostudy.studies.cases import case_key
from ecostudy.studies.controllers import CONTROLLER_KINDS, Build
from ecostudy.studies.loopsteps import failures_reason, step_columns, step_counts, steps_frame

PARAMETERS = ("mass", "resistance", "traction", "braking")


def _inputs(case):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)  # shown once when the study was expanded
        train = train_from_schema(schemas.TrainFile.model_validate(case["train"]), case["study"])
    track = track_from_schema(schemas.TrackFile.model_validate(case["track"]))
    return track, train, make_segment(track, train, case["from"], case["to"])


def all_out_time(segment, train, points):
    """The nominal train's all-out time from a stand [s] by the SOCP (None: no run at all)."""
    fastest = ConvexProgram(segment, train, trapezoid_grid(segment, points), FASTEST).solve(State(), (0.0, np.inf))
    return float(fastest.t[-1]) if fastest.usable else None


def warn_inert_brake_levels(path, controllers, train):
    """Warn of a controller whose ``settings.brake_level_mps2`` (B_brk of Yazhemsky 2017 eq. 6.8) is at
    or above the braking the train's brakes give at most (its braking envelope's peak over its
    mass): braking never exceeds it, so the braking weight ``settings.braking`` has no effect."""
    strongest = train.braking.peak / train.mass
    for i, spec in enumerate(controllers):
        level = spec.settings.brake_level_mps2
        if "settings" in CONTROLLER_KINDS.spec(spec.kind).uses and spec.settings.braking > 0 and level >= strongest:
            warnings.warn(problem(path, f"controllers[{i}].settings.brake_level_mps2",
                                  f"{level:g} m/s^2 is at or above the strongest braking of the train "
                                  f"'{train.name}', {strongest:.3g} m/s^2 (its braking envelope's peak over its "
                                  "mass): braking is never penalised, settings.braking has no effect"),
                          EcostudyWarning, stacklevel=2)


def expand(path, out=None):
    """(study, output folder, cases); the inputs are validated here, once, the output folder
    (``out``, else the study's own) checked before the all-out run is solved."""
    path = Path(path)
    s = validate(SimulateFile, read_document(path), path)
    output = Path(s.output) if s.output else default_output(s.name)  # relative: to the working directory
    check_output_dir(out or output, ("runs.csv", "results.sqlite"), "simulate")
    train_file, track_file = named_file(path, "train", s.train), named_file(path, "track", s.track)
    (train_doc, train), (track_doc, track) = read_train(train_file), read_track(track_file)  # a bad field: as its
    # file names it (an OSRD or TTOBench file's own field, not the schema's)
    check_fits(train_file, train, track)
    warn_inert_brake_levels(path, s.controllers, train)
    from_stop, to_stop = chosen_stops(track, s.from_stop, s.to_stop, path)
    segment = make_segment(track, train, from_stop, to_stop)
    prepare(track, train, from_stop, to_stop, s.points)  # a train that cannot climb: refused, saying where
    fastest = all_out_time(segment, train, s.points)
    if fastest is None:
        raise InputError(problem(path, "train", "the nominal train has no run to the stop at all (the convex "
                                 "program of its fastest run is infeasible)"))
    if s.window_s[1] < fastest:
        raise InputError(problem(path, "window_s", f"the latest arrival {s.window_s[1]:g} s is below the all-out "
                                 f"time {fastest:.2f} s of the nominal train"))
    rng = np.random.default_rng(s.seed)
    draws = []
    for _ in range(s.draws):
        ranges = s.deviations.model_dump()
        truth = {name: float(rng.uniform(ranges[name]["low"], ranges[name]["high"])) for name in PARAMETERS}
        draws.append((truth, int(rng.integers(2 ** 31))))
    noise = s.noise.model_dump()
    cases = []
    for spec in s.controllers:
        for i, (truth, seed) in enumerate(draws):
            case = {"study": s.name, "scenario": spec.name, "labels": {"controller": spec.name, "draw": i},
                    "train": train_doc, "track": track_doc, "from": from_stop, "to": to_stop,
                    "window": list(s.window_s), "points": s.points,
                    "sample_time": spec.sample_time_s or s.sample_time_s,
                    # the spec as written (defaults left out): a field added later keeps the keys
                    "controller": spec.model_dump(exclude_defaults=True), "truth": truth,
                    "noise": {**noise, "seed": seed}}
            case["key"] = case_key(case)
            cases.append(case)
    return s, output, cases


def controller_spec(case):
    """A case's controller spec with every default filled in (the case stores it as written)."""
    return Controller.model_validate(case["controller"]).model_dump()


def build_controller(case, track, segment, train, estimator):
    """(the controller the loop drives, the planning controller inside it) of a case."""
    spec, window, points = controller_spec(case), tuple(case["window"]), case["points"]
    # the study's brake reserve if it gives one, else the controller's own default
    reserve = {} if spec["brake_reserve"] is None else {"brake_reserve": spec["brake_reserve"]}
    inner = CONTROLLER_KINDS.get(spec["kind"])(Build(case, spec, track, segment, train, estimator, window, points,
                                                     reserve, case["sample_time"]))
    outer = inner
    if spec["terminal_reserve"] is not None:
        outer = TerminalApproach(inner, prepare(track, train, case["from"], case["to"], points), case["sample_time"],
                                 spec["terminal_reserve"], fit=spec["terminal_fit"])
    if spec["das_levels"]:
        return Quantised(outer, train.das_levels, spec["delay_samples"]), inner
    return outer, inner


def _mode_changes(handles):
    modes = np.sign(np.where(np.abs(handles) < 1e-6, 0.0, handles))
    return int(np.sum(modes[1:] != modes[:-1]))


def summarise(case, result, controller, train, estimator):
    """The per-run numbers of a closed-loop trip (SI in, the units in the names out)."""
    sample, (t_min, t_max) = case["sample_time"], case["window"]
    seconds = np.array(controller.solve_seconds)
    solved = seconds[seconds > 0] if np.any(seconds > 0) else np.zeros(1)
    mass = train.static_mass * case["truth"]["mass"]  # J/kg per static mass Ms, as `solve` (Yazhemsky 2017 eq. 4.1a)
    x = [round(s.position, 3) for s in result.states]
    v = [round(s.speed, 4) for s in result.states]
    gaps = getattr(controller, "gaps", [])
    counts = step_counts(controller)
    # a train that stood short of its stop, beyond the tolerance, did not arrive: no arrival time
    arrived = result.stop_error_m >= -STOP_TOLERANCE_M
    at = result.arrival_time_s if arrived else np.nan
    return {
        "energy_J_per_kg": result.traction_work / mass, "traction_energy_kWh": result.traction_work / 3.6e6,
        "braking_energy_kWh": result.braking_work / 3.6e6, "arrival_s": at,
        "late_s": max(at - t_max, 0.0) if arrived else np.nan, "early_s": max(t_min - at, 0.0) if arrived else np.nan,
        "stop_error_m": result.stop_error_m, "overspeed_max_kmh": result.overspeed_max_kmh,
        "solve_mean_ms": 1e3 * float(solved.mean()), "solve_p95_ms": 1e3 * float(np.percentile(solved, 95)),
        "solve_max_ms": 1e3 * float(solved.max()), "over_budget_count": int(np.sum(seconds > sample)),
        "samples": len(seconds), "softened_count": counts["softened_steps"], **counts,
        "power_limit_dropped": _dropped(controller), "compute_delay_samples": case_delay(case),
        "failures_count": getattr(controller, "failures", 0), "gap_max": max(gaps) if gaps else None,
        "terminal_gamma_m": controller.gammas[-1] if getattr(controller, "gammas", None) else None,
        "mode_changes": _mode_changes(np.array(result.handles)),
        "mass_estimate": estimator.estimate if estimator is not None else None,
        **({} if result.adhesion_use_max is None else {"adhesion_use_max": result.adhesion_use_max}),
        **{f"true_{name}_factor": case["truth"][name] for name in PARAMETERS},
        "profile": {"x": x, "v": v}, "solve_ms": [round(1e3 * s, 2) for s in seconds],
        "estimates": [(round(p, 2), round(e, 5)) for p, e in result.mass_estimates[::10] if p is not None],
        "steps": step_columns(result, controller),
    }


def _dropped(controller):
    """The note of a formulation whose power limit never binds: 'traction power limit never binds: dropped'."""
    program = getattr(controller, "program", None)
    case = getattr(controller, "case", None)
    idle = getattr(program, "idle_power", None) or getattr(case, "idle_power", None) or ()
    return f"{', '.join(idle)} power limit never binds: dropped" if idle else None


def case_delay(case):
    """A case's computation delay (``loop.run_loop``): samples, or 'measured'."""
    return controller_spec(case)["compute_delay"]


def run_loop_case(case):
    """One closed-loop trip (a case of :func:`expand`); never raises: failures are results."""
    return outcome(case, lambda: _trip(case))


def _trip(case):
    track, train, segment = _inputs(case)
    n = case["noise"]
    noise = Noise(n["acceleration_mps2"], n["position_m"], n["speed_mps"], n["seed"], n["period_s"],
                  n["accelerometer_mps2"])
    estimator = make_estimator(controller_spec(case)["estimator"], noise)
    controller, planner = build_controller(case, track, segment, train, estimator)
    plant = Plant(segment, train, Truth(**case["truth"]))
    result = run_loop(plant, controller, case["sample_time"], noise, plant_step=case["sample_time"],
                      estimator=estimator, delay=case_delay(case), max_time=trip_limit(case["window"][1]))
    summary = summarise(case, result, planner, train, estimator)
    # "late" is after the window's latest arrival, "early" before its earliest: the window is the
    # timetable of a closed-loop study (a run that did not arrive has neither: its stop flags it)
    status = driven_run(summary["stop_error_m"], _number(summary["late_s"]), summary["overspeed_max_kmh"],
                        summary.get("adhesion_use_max"), early_s=_number(summary["early_s"]))
    if summary["failures_count"]:  # solves that did not converge: the fallback drove those samples, not the controller
        status = worst([status, flagged(failures_reason(summary["failures_count"], summary["over_time_budget_count"],
                                                        summary["samples"]))])
    status = worst([status, unproven_solves(summary["unproven_solves_count"], summary["samples"],
                                            summary["unproven_solver_status"])])
    if getattr(planner, "plan_ended", None) is not None:  # the convex plan it replays
        status = worst([status, solver_part("the open-loop plan", planner.plan_ended, "Clarabel", "Solved")])
    if getattr(planner, "plans_from", None) is not None:  # the ATO run it replays or plans from
        ended = planner.plans_from.facts.solver.status
        status = worst([status, solver_part("the ATO run", ended)])
    status = worst([status, calibrated(train.calibration_reason)])  # the model train of a flagged calibration
    status, error = (status.kind, status.reason or None)
    return status, error, summary


def trip_limit(latest):
    """The clock [s] at which a closed-loop trip that has not stood at its stop is ended: twice the
    window's latest arrival and five minutes more. A train that never moves off (every solve unusable,
    the fallback holding it) or crawls is ended there, flagged short of its stop, instead of running
    the loop's own limit (20 s per metre of track and ten minutes: 206 000 samples of 0.1 s on 1 km)."""
    return 2.0 * latest + 300.0


def _number(x):
    """``x``, or None where it is NaN (not measured: a run that did not arrive has no lateness)."""
    return None if x is None or np.isnan(x) else x


GRIP = "adhesion_use_max"  # a column of a train with an adhesion limit only (core.simulate.adhesion_use)
COLUMNS = ("energy_J_per_kg", "traction_energy_kWh", "arrival_s", "late_s", "early_s", "stop_error_m", "overspeed_max_kmh",
           "solve_mean_ms", "solve_p95_ms", "solve_max_ms", "over_budget_count", "over_time_budget_count", "softened_count",
           "failures_count",
           "gap_max", "fallback_shifted_plan_count", "fallback_reserve_count", "fallback_full_brake_count",
           "full_brake_before_final_count", "inexact_solves_count", "unproven_solves_count", "unproven_solver_status",
           "power_limit_dropped", "compute_delay_samples",
           "terminal_gamma_m", "mode_changes", "mass_estimate", *(f"true_{name}_factor" for name in PARAMETERS))


def runs_table(cases, rows):
    """One row per run: labels, status, reason and the numbers of :func:`summarise`."""
    out = []
    stored = [(rows.get(case["key"]) or {}).get("summary") or {} for case in cases]
    columns = (*COLUMNS, GRIP) if any(GRIP in s for s in stored) else COLUMNS  # a train with an adhesion limit
    for case, s in zip(cases, stored):
        row = rows.get(case["key"]) or {}
        status, reason = cells(row.get("status"), row.get("error"))
        out.append({**case["labels"], "key": case["key"], "status": status, "reason": reason,
                    **{c: s.get(c) for c in columns}, "wall_s": row.get("seconds")})
    return pd.DataFrame(out)


def not_ok(runs):
    """The rows of runs that ran and are not ok (flagged or failed; a run not computed is not one)."""
    return ~runs["status"].isin(["ok", "missing"])


ARRIVED_ONLY = ("energy_J_per_kg", "traction_energy_kWh", "arrival_s")  # statistics over the runs that arrived


def arrived_rows(group):
    """The rows of the runs that arrived: those with an arrival time (:func:`summarise`: a train that
    stood short of its stop, never left it or was not computed has none)."""
    return pd.to_numeric(group["arrival_s"], errors="coerce").notna()


def aggregate(runs):
    """Per controller: the number of runs computed (``runs``), of runs not computed yet (``missing``:
    another ``--only``), of runs ok and of runs that arrived, the mean, spread and
    extremes of the energy and the arrival over the runs that arrived (a trip not made has no energy
    of a trip: NaN where none arrived), of the stop error over every run, and the worst overspeed,
    lateness and solve times."""
    rows = []
    for name, group in runs.groupby("controller", sort=False):
        if (group["status"] == "missing").all():  # not run (``--only``): no row of NaNs
            continue
        came, missing = arrived_rows(group), int((group["status"] == "missing").sum())
        row = {"controller": name, "runs": len(group) - missing, "missing": missing,
               "ok": int((group["status"] == "ok").sum()), "arrived": int(came.sum())}
        for column in (*ARRIVED_ONLY, "stop_error_m"):
            values = pd.to_numeric(group[column], errors="coerce")
            values = values[came] if column in ARRIVED_ONLY else values
            row.update({with_statistic(column, how): getattr(values, how)(**({"ddof": 0} if how == "std" else {}))
                        for how in ("mean", "std", "min", "max")})
        for column, how in (("overspeed_max_kmh", "max"), ("late_s", "max"), ("solve_mean_ms", "mean"),
                            ("solve_p95_ms", "max"), ("solve_max_ms", "max"), ("over_budget_count", "sum"),
                            ("over_time_budget_count", "sum"),
                            ("softened_count", "sum"), ("gap_max", "max"), ("fallback_shifted_plan_count", "sum"),
                            ("fallback_reserve_count", "sum"), ("fallback_full_brake_count", "sum"),
                            ("inexact_solves_count", "sum"), ("unproven_solves_count", "sum"),
                            *([(GRIP, "max")] if GRIP in runs else [])):
            row[with_statistic(column, how)] = getattr(pd.to_numeric(group[column], errors="coerce"), how)()
        rows.append(row)
    return pd.DataFrame(rows)


def simulate_study(path, workers=1, dask=None, retry_failed=False, out=None, progress=None, only=None, draw=None,
                   drawn_names=()):
    """Run the runs of a closed-loop study not stored yet (``only``: of these controllers) through
    the study engine (kind ``simulate``): runs.csv and aggregate.csv of every stored run (a
    controller not run yet counts as missing), each run's steps/<controller>_draw<i>.csv
    (``studies.loopsteps``), ``summary.json`` and the figures ``draw(study)`` writes and returns
    (``drawn_names``: their file names, checked in the output folder before any run).

    Returns a :class:`LoopStudy` (the plots are drawn from it by ``report.loopplots``)."""
    study, output, cases = expand(path, out)
    names = [c.name for c in study.controllers]
    unknown = sorted(set(only or ()) - set(names))
    if unknown:
        raise InputError(problem("command line", "--only", f"{', '.join(map(repr, unknown))}: not among the controllers "
                                 f"of {path} ({', '.join(names)})"))
    compute = [c for c in cases if c["labels"]["controller"] in only] if only else None
    done = []
    ran = run_expanded("simulate", Expanded(output, cases), path, workers, dask, retry_failed, out, progress,
                       loop_files(draw, drawn_names, done), compute, SIMULATE)
    missing = int((ran.table["status"] == "missing").sum())  # left out by ``only``: flagged as not computed,
    counts = {**ran.counts, "missing": missing, "not_ok": ran.counts["not_ok"] - missing}  # said on a line of their own
    return done[0]._replace(counts=counts)


def loop_files(draw=None, names=(), done=None):
    """The study engine's ``draw`` (:func:`~ecostudy.studies.batch.run_expanded`) of a closed-loop
    study, the same for ``ecostudy simulate`` and ``ecostudy run --kind simulate``: aggregate.csv and
    every run's steps/<controller>_draw<i>.csv (:func:`loop_study`), and the figures ``draw(study)``
    writes of the :class:`LoopStudy` and returns (``report.loopplots``; None: none; ``names``: the
    file names it may write); the :class:`LoopStudy` appended to ``done`` when given."""
    def files(out_dir, cases, rows, table):
        study = loop_study(cases, rows, table, Path(out_dir))
        if done is not None:
            done.append(study)
        steps = sorted(f"steps/{p.name}" for p in (Path(out_dir) / "steps").glob("*_draw*.csv"))  # this run's alone
        return [*(draw(study) if draw is not None else []), *steps], {"aggregate": "aggregate.csv"}
    return Draw(files, lambda cases: ("aggregate.csv", *names))


def loop_study(cases, rows, runs, output):
    """The :class:`LoopStudy` of the stored ``rows`` (``runs``: their table), its aggregate.csv and
    every run's steps/<controller>_draw<i>.csv written into ``output`` (an earlier run's step file of
    a run not stored now removed)."""
    summary = aggregate(runs)
    write_csv(output / "aggregate.csv", summary)
    by_controller, budgets, steps = {}, {}, set()
    for case in cases:
        s = (rows.get(case["key"]) or {}).get("summary")
        if s and s.get("steps"):
            labels = case["labels"]
            steps.add(f"{labels['controller']}_draw{labels['draw']}.csv")
            write_csv(output / "steps" / f"{labels['controller']}_draw{labels['draw']}.csv", steps_frame(s["steps"]))
        if s:  # with its draw and status line: the figures say which of their runs are not ok
            row = rows[case["key"]]
            by_controller.setdefault(case["labels"]["controller"], []).append(
                {**s, "draw": case["labels"]["draw"], "status": str(Status.parse(row["status"], row.get("error") or ""))})
            budgets[case["labels"]["controller"]] = case["sample_time"]
    for earlier in (output / "steps").glob("*_draw*.csv"):
        if earlier.name not in steps:
            earlier.unlink()
    return LoopStudy(cases[0]["study"], runs, summary, {}, output, by_controller, _inputs(cases[0])[2], budgets)


def expand_simulate(path, out=None):
    """A closed-loop study file as the study engine's cases (:func:`expand`), into its output."""
    _, output, cases = expand(path, out)
    return Expanded(output, cases)


def loop_table(cases, rows):
    """:func:`runs_table`, the runs not computed yet counted in its attrs (``summary.json``)."""
    table = runs_table(cases, rows)
    table.attrs["missing_runs"] = int((table["status"] == "missing").sum())
    return table


class LoopStudy(NamedTuple):
    """A closed-loop study's outcome: the study's name, the runs and aggregate tables, the counts,
    the output folder, every stored run's summary per controller (with its ``draw`` and its
    ``status`` line), and the segment."""

    name: str
    runs: pd.DataFrame
    aggregate: pd.DataFrame
    counts: dict
    output: Path
    by_controller: dict
    segment: object
    budgets: dict  # each controller's sample time, its real-time budget [s]


SIMULATE = StudyKind(expand_simulate, run_loop_case, loop_table, table_file="runs.csv", table_name="runs")
"""The closed-loop study kind (registered as ``simulate``, its study file checked first, by
:mod:`ecostudy.studies.loopkind`)."""
