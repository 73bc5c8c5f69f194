"""One run into an output folder, and what reads a solved folder back: the commands ``solve``,
``check``, ``export`` and ``doctor`` as functions (the command line only parses and prints).
"""
import re
import warnings
from pathlib import Path
from typing import Any, Optional

import pyomo.core as pyo  # not pyomo.environ: see ocp.solver.prepare

from ecostudy import __version__
from ecostudy.analysis.single import RunResult, solve_run
from ecostudy.api.arguments import spelled
from ecostudy.api.outcome import Note, Report, listed, reported
from ecostudy.core.defaults import RUN_POINTS
from ecostudy.core.errors import (EcostudyWarning, FieldError, InfeasibleError, InputError, LineError, SolverError,
                                  TooFastError, TractionError, WeightError,
                                  problem)
from ecostudy.core.progress import Watcher, stage, watched
from ecostudy.core.status import Status
from ecostudy.core.types import Timing
from ecostudy.core.units import number, signed
from ecostudy.das.advice import failed_advice
from ecostudy.das.methods import DAS_METHODS, das_run
from ecostudy.io.writers import check_name_length, check_output_dir, default_output, write_json
from ecostudy.ocp import session
from ecostudy.report.drawer import drawing
from ecostudy.report.files import run_files, write_fixed_step, write_run
from ecostudy.report.style import output
from ecostudy.studies.cases import refuse_mixed_fixed, refuse_mixed_weights
from ecostudy.studies.check import AGREES, check_result
from ecostudy.studies.options import (OBJECTIVES, case_from, check_choices, check_options, das_limit, only_one,
                                      output_folder, parse_pair, timing_of)
from ecostudy.studies.estimate import check_solve, grid_nodes, table_points


def run_lines(result: RunResult, out_dir: Path) -> list[str]:
    """The report of one solved run: times, energies, solver, regimes, checks, driver advice, files."""
    s = result.facts
    ver = s.verification
    lines = [f"{s.train}: {s.from_stop} -> {s.to_stop} ({s.distance_m:.0f} m), objective {s.objective}, K = {s.points}",
             f"  running time      {s.running_time_s:9.2f} s",
             f"  traction energy   {s.traction_energy_kWh:9.3f} kWh  ({s.traction_energy_J_per_kg:.2f} J/kg)",
             f"  net energy        {number(s.net_energy_kWh, '9.3f')} kWh  (regenerated "
             f"{number(s.regenerated_energy_kWh)} kWh)",
             f"  solver            {s.solver.status}, {s.solver.iterations} iterations, {s.solver.wall_s:.2f} s",
             f"  regimes           {s.regime_sequence}"]
    if s.pontryagin is not None:
        pm = s.pontryagin
        lines.append(f"  Pontryagin check  {pm.agreement_pct:.1f} % of the distance obeys {pm.conditions}"
                     + "".join(f"; {d.regime} at {d.start_m:.0f}-{d.end_m:.0f} m disagrees"
                               for d in pm.disagreements[:3]))
    if ver is not None:
        flag = "passed" if ver.passed else "FAILED"
        lines.append(f"  verification      {flag}: {ver.errors}" + (f"; {ver.windows_said}" if ver.windows else ""))
    if s.das is not None and s.das.traction_energy_kWh is None:  # no advice made: why
        lines.append(f"  driver advice     {s.das.method}: {s.das.status}")
    elif s.das is not None:
        d = s.das
        net = s.objective == "net_energy"  # the gap is on the quantity the ATO run minimised: shown beside it
        gap = f"no gap: {d.no_gap}" if d.gap_to_ato_pct is None else f"{signed(d.gap_to_ato_pct, 2)} % against ATO"
        arrival = "no arrival" if d.arrival_error_s is None else f"arrival {signed(d.arrival_error_s, 2)} s"
        lines.append(f"  driver advice     {d.method}: {d.net_energy_kWh if net else d.traction_energy_kWh:.3f} kWh"
                     f"{' net' if net else ''} ({gap}), {d.mode_changes} mode changes, {arrival}, "
                     f"stop {signed(d.stop_error_m, 2)} m (advice.csv)")
        charged = (f"{signed(d.gap_to_ato_on_time_pct, 3)} % against ATO with lateness charged at "
                   f"{abs(s.marginal_energy_kWh_per_s):.4f} kWh/s; " if d.gap_to_ato_on_time_pct is not None
                   and s.marginal_energy_kWh_per_s is not None else "")
        lines.append(f"                    {charged}{d.status}")
        if d.note:
            lines.append(f"                    {d.note}")
        if d.method == "minlp":
            bound = "no bound" if d.bound_kWh is None else f"bound {d.bound_kWh:.3f} kWh (gap {number(d.gap_pct, '.2f')} %)"
            lines.append(f"                    MINLP search {d.search_s:.1f} s, {d.oa_iterations} OA iterations, "
                         f"{bound}")
    lines.append(f"  outputs           {listed(out_dir)}")
    return lines


@spelled
def solve_folder(study: Optional[Path] = None, track: Optional[Path] = None, train: Optional[Path] = None,
                 time: Optional[float] = None, supplement: Optional[float] = None, window: Optional[str] = None,
                 from_stop: Optional[str] = None, to_stop: Optional[str] = None, objective: Optional[str] = None,
                 weights: Optional[str] = None, points: Optional[int] = None, out: Optional[Path] = None,
                 plot: bool = True, das: Optional[str] = None, das_time_limit: Optional[float] = None, fig_format: str = "png",
                 dpi: Optional[float] = None, *, progress: Optional[Watcher] = None) -> Report:
    """``ecostudy solve``: the energy-optimal (or all-out) run of a study file, or of a track and a
    train file, verified and written to ``out`` (profile.csv, summary.json, the figures, inputs.json);
    ``time`` [s], ``supplement`` [%] and ``window`` ('earliest,latest' [s]) override the study's timing.
    ``progress`` watches its stages (:mod:`ecostudy.core.progress`): the ATO solve, each stage of the
    driver advice (the MINLP search against its time limit), the files."""
    with watched(progress):
        return _solve_folder(study, track, train, time, supplement, window, from_stop, to_stop, objective, weights,
                             points, out, plot, das, das_time_limit, fig_format, dpi)


def _solve_folder(study, track, train, time, supplement, window, from_stop, to_stop, objective, weights, points,
                  out, plot, das, das_time_limit, fig_format, dpi):
    figures = output(fig_format, dpi)
    check_options(time=time, supplement=supplement, points=points, das_time_limit=das_time_limit)
    check_choices(objective=(objective, OBJECTIVES), das=(das, DAS_METHODS.names()),
                  files={"study": study, "track": track, "train": train})
    only_one(time=time, supplement=supplement, window=window)
    timed = any(x is not None for x in (time, supplement, window))  # the options override a study's timing
    if objective == "time" and timed:
        raise InputError(problem("command line", "--objective time", "finds the fastest run: it takes no --time, "
                                 "--supplement or --window"))
    trk, trn, f, t, k, st, _ = case_from(study, track, train, from_stop, to_stop, points, "solve")
    if st is not None:
        paths, windows, obj = (st.track_path, st.train_path), st.windows, objective or st.objective
        timing, w = (timing_of(time, supplement, window) if timed else st.timing), st.weights or (1.0, 1.0)
        if st.weights is not None and obj != "mixed" and weights is None:  # as `ecostudy run` warns of it
            warnings.warn(problem(str(study), "weights", f"read but not used: the objective is {obj}, not mixed"),
                          EcostudyWarning, stacklevel=2)
        if obj == "time" and timing != Timing():  # --objective time on a study with a running time
            warnings.warn(problem(str(study), st.timing_field, "does not apply to --objective time (the fastest "
                                  "run): left out"), EcostudyWarning, stacklevel=2)
            timing = Timing()
        out_dir = output_folder(out, st.output)
    else:
        paths, windows, obj = (Path(track), Path(train)), (), objective or "energy"
        if not timed and obj not in ("time", "mixed"):
            raise InputError(problem("command line", "--time", "give --time, --supplement or --window "
                                     "(or --objective time for the all-out run)"))
        timing, w, k = timing_of(time, supplement, window), (1.0, 1.0), k or RUN_POINTS
        out_dir = output_folder(out, default_output(f"{Path(track).stem}_{f}_{t}"))
    das_time_limit = das_limit(das, das_time_limit)
    check_solve(grid_nodes(trk, trn, f, t, k), das, das_time_limit, table_points(trn))
    w = parse_pair(weights, "--weights", nonnegative=True) if weights is not None else w  # '' too: refused
    where, field = timing_source(study, st, time, supplement, window)
    fixes = timing.running_time is not None or timing.supplement is not None  # a window leaves the time free
    refuse_mixed_fixed(obj, fixes and (field if where == "command line" else f"{where}: {field}"),
                       *(("command line", "--objective") if objective else (str(study), "objective")))
    if weights is not None and obj != "mixed":
        raise InputError(problem("command line", "--weights", "weigh time against energy of --objective mixed only"))
    weighed = ("command line", ("--weights",) * 2) if weights is not None else (str(study), ("weights.time", "weights.energy"))
    refuse_mixed_weights(obj, w, timing != Timing(), *weighed)
    check_output_dir(out_dir, run_files(das is not None, plot, figures), "solve")
    if das is not None and windows and das != "round":
        raise InputError(problem(str(study), "windows", f"--das {das} does not handle timing "
                                 "windows on the way yet; use --das round"))
    with drawing(plot) as drawer:  # matplotlib loads in a child while this process solves
        stage(f"{obj} optimum, verified")
        try:
            result = solve_run(trk, trn, f, t, timing=timing, objective=obj, points=k, weights=w, windows=windows)
        except TooFastError as exc:  # the timing cannot be met: where it was given, by name
            where, field = timing_source(study, st, time, supplement, window)
            raise InfeasibleError([problem(where, field, p) for p in exc.problems]) from None
        except WeightError as exc:  # mixed weights that price energy at nothing the NLP can tell
            raise InputError([problem(weighed[0], weighed[1][1], p) for p in exc.problems]) from None
        except TractionError as exc:  # too weak to move where the line does not hold it back: the train's
            raise InfeasibleError([problem(paths[1], trn.traction_field, p) for p in exc.problems]) from None
        except LineError as exc:  # a climb or descent of the line the train's envelopes cannot make: the track's
            raise InfeasibleError([problem(paths[0], "gradients", p) for p in exc.problems]) from None
        except FieldError as exc:  # a window on the way no run keeps: the study's or its timetable's, by name
            where, field = st.window_origin(exc.field, study)
            raise InfeasibleError([problem(where, field, p) for p in exc.problems]) from None
        if das is not None:
            try:  # advice no method makes fails on its own: the ATO run is written, the status says why
                result.das = das_run(result, das, time_limit=das_time_limit)
            except (InfeasibleError, SolverError) as exc:
                result.das = failed_advice(das, str(exc))
            result.summary["das"] = result.das.summary
        stage("figures and files")
        write_run(result, out_dir, plot=plot, out=figures, drawer=drawer, study=study, das=das)
    return reported(out_dir, run_lines(result, out_dir))


def timing_source(study, st, time, supplement, window) -> tuple[str, str]:
    """(file or 'command line', field) that set a solve's timing, for a line that names it."""
    given = [name for name, value in (("--time", time), ("--supplement", supplement), ("--window", window))
             if value is not None]
    if given or st is None:
        return "command line", given[0] if given else "--time"
    if st.timetable_path is not None:  # the timetable's times: its file
        return str(st.timetable_path), "stops"
    return str(study), st.timing_field


@spelled
def check_folder(result_dir: Path, time: Optional[float] = None) -> Note:
    """``ecostudy check``: the Pontryagin regime check of a solve folder (Farooqi 2018, eq. 2.17;
    eq. 7.4 for net-energy runs), written to its check.json with the run's own status; ``ok`` at 95 %
    agreement or more for a run that is ok."""
    check_options(time=time)
    result_dir = Path(result_dir)
    check_name_length(result_dir)
    if result_dir.is_dir():
        check_output_dir(result_dir, ("check.json",))
    report = check_result(result_dir, time)
    run_ok = Status.parse(report["run_status"]).ok
    agrees = report["agreement_pct"] >= AGREES
    reasons = ([] if agrees else [f"{report['agreement_pct']:.1f} % of the distance agrees, below {AGREES:g} %: not the "
                                  f"{report['checked_as']}"]) + ([] if run_ok else ["the run checked is not ok"])
    verdict = "ok" if not reasons else "flagged: " + "; ".join(reasons)
    report = {"status": verdict, **report}  # the check's own verdict first: run_status is the run's
    write_json(result_dir / "check.json", report)
    lines = [f"checked as the {report['checked_as']}",
             "regimes: " + ", ".join(f"{r['regime']} {r['start_m']:.0f}-{r['end_m']:.0f} m" for r in report["sequence"]),
             (f"Pontryagin: {report['agreement_pct']:.1f} % of the distance agrees; stationarity "
              f"residual {report['stationarity_residual']:.1e}" if report["stationarity_residual"] is not None else
              f"all-out regimes: {report['agreement_pct']:.1f} % of the distance agrees")]
    lines += [f"  inconsistent: {d['regime']} at {d['start_m']:.0f}-{d['end_m']:.0f} m" + (
              f" (lambda/v from {number(d['psi_min'], '.2f')} to {number(d['psi_max'], '.2f')})" if "psi_min" in d else "")
              for d in report["disagreements"]]
    lines += [f"the run checked: {report['run_status']}", f"written {result_dir}/check.json", f"check: {verdict}"]
    return Note(Status.parse(verdict), "\n".join(lines), report)


@spelled
def export_folder(result_dir: Path, every: str = "1s") -> Note:
    """``ecostudy export``: a solve folder's run at fixed steps ('1s': seconds, '10m': metres) as
    profile_every_<step>.csv and .json in the folder; ``ok`` when the run exported is (its status is
    in the JSON and the text)."""
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(s|m)\s*", every if isinstance(every, str) else "")
    if not match or not 0 < float(match.group(1)) < float("inf"):
        raise InputError(problem("command line", "--every", f"expected a step such as '1s' (seconds) or '10m' "
                                 f"(metres), not '{every}'"))
    step = float(match.group(1))
    table, csv, js, status = write_fixed_step(result_dir, *((step, None) if match.group(2) == "s" else (None, step)))
    return Note(status, f"{len(table)} rows every {every.strip()}: {csv} and {js.name}\nthe run exported: {status}",
                table)


def doctor() -> Note:
    """``ecostudy doctor``: the solver chain's versions and a toy NLP solved with Ipopt."""
    lines = [f"{name:10s} {version}" for name, version in {"ecostudy": __version__, **session.versions()}.items()]
    m = pyo.ConcreteModel()
    m.x = pyo.Var(initialize=1.0)
    m.y = pyo.Var(initialize=1.0)
    m.c = pyo.Constraint(expr=m.x**2 + m.y**2 == 1)
    m.o = pyo.Objective(expr=m.x + 2 * m.y)
    out: Any = session.solve(m)
    ok = out.optimal and abs(pyo.value(m.o) + 5**0.5) < 1e-6
    toy = (f"toy NLP    {out.status} in {out.iterations} iterations, objective {pyo.value(m.o):.6f} "
           f"(expected {-(5**0.5):.6f})")
    lines.append(f"{toy}: {'ok' if ok else 'WRONG'}")
    return Note(Status("ok") if ok else Status("failed", " ".join(toy.split()) + ": wrong"), "\n".join(lines))

