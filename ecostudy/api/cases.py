"""Studies of many cases into an output folder, each resumable from its store where it has one:
the commands ``run``, ``simulate``, ``heavyhaul``, ``network``, ``calibrate`` and ``validate`` as
functions (the command line only parses and prints).

``progress(done, failed, remaining, total)`` is called after each case (``studies.batch.execute``);
``note(line)`` receives the network study's progress lines. calibrate and validate tell their
``progress`` (a :class:`ecostudy.core.progress.Watcher`) their stages and the steps of each.
"""
import logging
from contextlib import nullcontext
from os import PathLike
from functools import partial
from pathlib import Path
from typing import Callable, Optional, Sequence

from ecostudy.api.arguments import spelled
from ecostudy.api.blas import limit_blas_threads
from ecostudy.calibration.estimate import MAX_STRUCTURE, WINDOW
from ecostudy.calibration.replay import LIMIT_TOLERANCE_KMH
from ecostudy.calibration.validate import STATION_TOLERANCE_M
from ecostudy.api.outcome import Report, counts_line, listed, not_reused, reported, shown
from ecostudy.core.progress import Watcher, stage, watched
from ecostudy.core.status import Status, status_word
from ecostudy.core.units import number, signed
from ecostudy.io.store import whole_command
from ecostudy.report import calplots, heavyplots, loopplots
from ecostudy.report.console import counted
from ecostudy.report.files import figures as figure_files
from ecostudy.report.studyfiles import compare_figures, front_files, network_files
from ecostudy.report.html import write_html
from ecostudy.report.style import Output, output
from ecostudy.studies.batch import run_expanded, run_kind
from ecostudy.studies.kinds import STUDY_KINDS  # noqa: F401  (every built-in kind registered)
from ecostudy.studies.calibrate import calibrate_study, validate_study
from ecostudy.studies.closedloop import loop_files, simulate_study
from ecostudy.studies.heavyhaul import heavyhaul_files, heavyhaul_study
from ecostudy.studies.network import expand_network
from ecostudy.studies.options import check_options
from ecostudy.studies.workers import every_core, worker_pool
from ecostudy.studies.sizes import check_closed_loop_study

Progress = Optional[Callable[[int, int, int, int], None]]
log = logging.getLogger("ecostudy")

# each printed table's columns, with the format of each number column whose digits .4g would vary
# (84 beside 84.06, -2.789e-06 m): None, the table's own
LOOP_COLUMNS = {"controller": None, "runs": None, "ok": None, "arrived": None, "traction_energy_mean_kWh": ".3f",
                "traction_energy_std_kWh": ".3f",
                "arrival_mean_s": ".2f", "arrival_max_s": ".2f", "stop_error_min_m": ".3f", "stop_error_max_m": ".3f",
                "overspeed_max_max_kmh": ".2f", "solve_mean_mean_ms": ".1f", "solve_p95_max_ms": ".1f",
                "over_budget_count_sum": None, "softened_count_sum": None}
HEAVY_COLUMNS = {"K_b": None, "f": None, "Np": None, "Nc": None, "status": None, "tracking_mean_mps": ".3f",
                 "tracking_std_mps": ".3f", "force_max_kN": ".1f", "force_max_braking_kN": ".1f", "force_mean_kN": ".1f",
                 "force_std_kN": ".1f", "wagon_brake_kWh": ".0f", "energy_total_kWh": ".0f", "qp_inputs": None,
                 "solve_mean_ms": ".1f", "solve_p95_ms": ".1f", "solve_max_ms": ".1f", "over_budget_count": None, "stop_error_m": ".3f"}
NETWORK_COLUMNS = ["strategy", "status", "substation_kWh", "saving_vs_independent_pct", "traction_input_kWh",
                   "regen_used_kWh", "regen_lost_kWh", "line_losses_kWh", "unserved_kWh", "balance_error_pct",
                   "separation_min_m", "all_verified"]
CALIBRATION_COLUMNS = {"name": None, "unit": None, **dict.fromkeys(["prior", "estimate", "low", "high", "boot_low",
                                                                     "boot_high"], "~5"), "identifiable": None}
VALIDATION_COLUMNS = {"run": None, "from_m": ".0f", "to_m": ".0f", "logged_time_s": ".1f", "model_time_s": ".1f",
                      "time_difference_pct": ".2f", "logged_traction_kWh": ".2f", "model_traction_kWh": ".2f",
                      "traction_difference_pct": ".2f", "status": None}


@spelled
@whole_command()
def run_folder(study: Path, workers: Optional[int] = None, dask: Optional[str] = None, retry_failed: bool = False,
               out: Optional[Path] = None, kind: str = "run", plot: bool = True, fig_format: str = "png",
               dpi: Optional[float] = None, *, progress: Progress = None) -> Report:
    """``ecostudy run``: every case of a study file not stored yet, through the one study engine
    (:func:`~ecostudy.studies.batch.run_kind`); ``kind``: a registered study kind
    (:data:`~ecostudy.studies.batch.STUDY_KINDS`; ``run``: scenarios x sweep, or a library);
    ``plot`` False: the kind's files without its figures (else in ``fig_format`` at ``dpi``)."""
    workers = every_core(workers)
    check_options(workers=workers, dask=dask)  # a study too big for the command: refused by its kind's size (unless --force)
    table, counts, folder = run_kind(kind, study, workers, dask, retry_failed, Path(out) if out else None, progress,
                                     own_files(kind, workers, plot, output(fig_format, dpi)))
    write_html(folder)
    return reported(folder, [f"{counted(counts['total'], 'cases')}: {counts['stored_before']} already stored, {counts['computed']} "
                             f"computed now ({counts['failed']} of them failed); not ok in the table: "
                             f"{counts['not_ok']}" + not_reused(counts), "outputs " + listed(folder, ("results.csv", "results.sqlite",
                                                                                  "report.html"))])


def own_files(kind: str, workers: int, plot: bool = True, figures: Output = Output()):
    """The files the command of a study ``kind`` writes beside its table, with its default options
    (``pareto``: pareto.json and its two figures; ``compare``: compare.png; ``simulate``:
    aggregate.csv, steps/ and the figures of ``report.loopplots``; ``heavyhaul``: the figures of
    ``report.heavyplots``; ``network``: the trains' and steps' tables, network.json and two figures;
    the figures left out where ``plot`` is False, as the command's ``--no-plot`` does, else written as
    ``figures`` says), so that
    ``run --kind`` writes the same set through the same writers; None for the others."""
    draws = {"pareto": lambda: front_files(plot, figures, workers=workers), "compare": lambda: compare_figures(plot, figures),
             "simulate": lambda: loop_files(*loop_drawing(plot, figures)),
             "heavyhaul": lambda: heavyhaul_files(*heavyhaul_drawing(plot, figures)),
             "network": lambda: network_files(plot, figures)}
    return draws[kind]() if kind in draws else None


@spelled
@whole_command()
def simulate_folder(study: Path, workers: Optional[int] = None, dask: Optional[str] = None, retry_failed: bool = False,
                    out: Optional[Path] = None, plot: bool = True, only: Optional[Sequence[str]] = None,
                    fig_format: str = "png", dpi: Optional[float] = None, *, progress: Progress = None) -> Report:
    """``ecostudy simulate``: every controller of a closed-loop study drives every draw of the
    plant's deviations and noise (``only``: these controllers' runs computed now); ``workers``: every
    core by default (the per-step solve times are then measured with every core busy)."""
    workers = every_core(workers)
    check_options(workers=workers, dask=dask)
    figures = output(fig_format, dpi)
    check_closed_loop_study(study, workers, only, Path(out) if out else None)  # runs that cannot end, or too big: refused (unless --force)
    draw, names = loop_drawing(plot, figures)
    outcome = simulate_study(study, workers, dask, retry_failed, Path(out) if out else None, progress, only, draw,
                             names)
    runs, counts, folder = outcome.runs, outcome.counts, outcome.output
    write_html(folder)
    table = outcome.aggregate  # with the runs not computed yet beside the runs when some are
    columns = {**dict(list(LOOP_COLUMNS.items())[:2]), "missing": None, **LOOP_COLUMNS} if counts["missing"] else LOOP_COLUMNS
    lines = [shown(table, columns, ".4g"), counts_line(counts, "runs"), "outputs " + listed(folder)]
    if counts["missing"]:
        left = runs.loc[runs["status"] == "missing", "controller"].unique()
        lines.append(f"not run yet: {counts['missing']} runs of {', '.join(left)} (run without --only to compute them)")
    return reported(folder, lines)


def loop_figures(outcome, out: Output = Output()) -> list:
    """The figures of a closed-loop study (``report.loopplots``), drawn as ``out`` says; their file
    names (of this drawing only: an earlier run's figure it does not draw again is not this run's)."""
    return loopplots.draw(outcome, out)


def loop_drawing(plot: bool, figures: Output):
    """(draw, the file names it may write) of a closed-loop study's figures; (None, ()) without ``plot``."""
    return partial(loop_figures, out=figures) if plot else None, figures.filenames(loopplots.FIGURES, plot)


def heavyhaul_drawing(plot: bool, figures: Output):
    """(draw, names(cases): the file names it may write) of a heavy-haul study's figures; (None, None)
    without ``plot``."""
    return ((partial(heavyplots.draw, out=figures), partial(heavyplots.names, out=figures)) if plot
            else (None, None))


@spelled
@whole_command()
def heavyhaul_folder(study: Path, workers: Optional[int] = None, dask: Optional[str] = None, retry_failed: bool = False,
                     out: Optional[Path] = None, plot: bool = True, blas_threads: int = 1, fig_format: str = "png",
                     dpi: Optional[float] = None, *, progress: Progress = None) -> Report:
    """``ecostudy heavyhaul``: Zhang & Zhuan's braking-penalised receding-horizon controller on the
    coupled-mass train, every K_b, fence and horizon of the study (OpenBLAS set to ``blas_threads``);
    ``workers``: every core by default (the per-step solve times are then measured with every core busy)."""
    workers = every_core(workers)
    check_options(workers=workers, dask=dask)
    figures = output(fig_format, dpi)
    limit_blas_threads(blas_threads)  # before the workers fork: they inherit it
    outcome = heavyhaul_study(study, workers, dask, retry_failed, Path(out) if out else None, progress,
                              *heavyhaul_drawing(plot, figures))
    runs, folder, plots = outcome.runs, outcome.output, list(outcome.files)
    write_html(folder)
    return reported(folder, [shown(runs, HEAVY_COLUMNS, ".4g"), counts_line(outcome.counts, "runs"),
                             f"outputs {folder}/ ({', '.join(['runs.csv', 'summary.json', 'report.html'] + plots[:3])}"
                             f"{', ...' if len(plots) > 3 else ''})"])


@spelled
@whole_command()
def network_folder(study: Path, out: Optional[Path] = None, plot: bool = True, workers: Optional[int] = None,
                   fig_format: str = "png", dpi: Optional[float] = None,
                   dask: Optional[str] = None, retry_failed: bool = False, note: Callable[[str], None] = log.info, *,
                   progress: Progress = None) -> Report:
    """``ecostudy network``: trains sharing one DC substation under every strategy of the study
    (independent, rules 7.7 / 7.11, dissension, joint optimum, following; Farooqi 2018, Ch. 7); each
    strategy a case of the study kind ``network`` (:mod:`ecostudy.studies.network`), stored in
    ``results.sqlite`` and resumed, over ``workers`` processes (every core by default) or Dask."""
    draw, workers = network_files(plot, output(fig_format, dpi)), every_core(workers)
    check_options(workers=workers, dask=dask)
    with worker_pool(workers) if workers > 1 else nullcontext() as pool:  # the fleet's first runs
        # too big: refused first (unless --force); the folder checked for the files beside the table (by strategy: later)
        expanded = expand_network(study, workers, pool, note, out, draw.names([]))
    ran = run_expanded("network", expanded, study, workers, dask, retry_failed, progress=progress, draw=draw)
    for name, row in ran.table.set_index("strategy").iterrows():
        note(f"{name:12s} " + (f"substation {row['substation_kWh']:.3f} kWh, "
                               f"scored {row['wall_s']:.1f} s after its start"
                               if status_word(row["status"]) != "failed" else "FAILED (its status says why)"))
    write_html(ran.output)
    table = ran.table  # no separation (one train, or no two on the line at once): '-', not NaN or None
    if "separation_min_m" in table:
        table = table.assign(separation_min_m=[number(x) if x is not None and x == x else "-"
                                                  for x in table["separation_min_m"]])
    saving = [ran.table.attrs["saving_note"]] if "saving_note" in ran.table.attrs else []
    return reported(ran.output, [shown(table, NETWORK_COLUMNS), *saving, counts_line(ran.counts, "strategies"),
                                 "outputs " + listed(ran.output)])


@spelled
def calibrate_folder(logs: Sequence[Path] | Path | str, train: Optional[Path] = None, track: Optional[Path] = None,
                     fit: Optional[str] = None, out: Path = Path("out/calibration"), bootstrap: int = 200,
                     savings: Optional[int] = None, plot: bool = True, fig_format: str = "png",
                     dpi: Optional[float] = None, *, progress: Optional[Watcher] = None) -> Report:
    """``ecostudy calibrate``: train parameters fitted to logged runs (least squares on the replayed
    dynamics), 95 % intervals, ``bootstrap`` draws, and optionally the savings against the logs.
    ``progress`` watches the fit, each bootstrap draw and each optimal run of the savings
    (:mod:`ecostudy.core.progress`). ``logs`` is one path or a sequence of them."""
    check_options(bootstrap=bootstrap, savings=savings)
    paths: Sequence[Path | str] = [logs] if isinstance(logs, (str, PathLike)) else logs
    figures = output(fig_format, dpi)
    with watched(progress):
        result, summary = calibrate_study(paths, train, track, fit, out, bootstrap, savings,
                                          (figures.filename("residuals"),) if plot else ())
        stage("figures and report")
    # residuals.<format> (an earlier run's in another format, or with --no-plot any, removed)
    figure_files(out, plot, {"residuals": partial(calplots.residuals, result.residuals, title="calibration from logged runs",
                                                  status=Status.parse(result.status, result.reason or ""))}, figures)
    write_html(out)
    q = result.quality
    lines = [shown(result.table.dropna(axis=1, how="all"), CALIBRATION_COLUMNS), *result.footnotes,
             f"{q['runs']} runs, {q['speed_samples']} speed samples: replayed speed off the logged by "
             f"{q['rms_speed_mps']:.3f} m/s RMS; innovations {q['structure_ratio']:.2f} times white noise over 5 s"]
    lines += [f"{row['log']} run {row['run']}: optimum for {row['running_time_s']:.1f} s uses "
              f"{row['optimal_traction_kWh']:.2f} kWh against {row['logged_traction_kWh']:.2f} kWh logged: saving "
              f"{number(row['saving_pct'], '.1f')} % (band {number(row['saving_low_pct'], '.1f')} to "
              f"{number(row['saving_high_pct'], '.1f')} % over "
              f"{row['draws']} parameter draws)" + ("" if row["verified"] else " (optimum not verified)")
              if row["saving_pct"] == row["saving_pct"] else f"{row['log']} run {row['run']}: {row['status']}"
              for row in summary.get("savings", [])]  # (a NaN saving: no optimum, its status says why)
    lines += [f"calibration ok: {'; '.join(result.checked)}" if result.status == "ok" else
              "calibration flagged (each reason below)",
              "outputs " + listed(out)]
    return reported(out, lines)


@spelled
def validate_folder(log_file: Path, train: Optional[Path] = None, track: Optional[Path] = None,
                    out: Path = Path("out/validate"), energy_tolerance: float = 5.0, time_tolerance: float = 5.0,
                    plot: bool = True, fig_format: str = "png", dpi: Optional[float] = None, *,
                    progress: Optional[Watcher] = None) -> Report:
    """``ecostudy validate``: a logged run replayed on the train file's model, per run between stops;
    a run whose traction energy or running time differs by more than the tolerances [%] is flagged.
    ``progress`` watches the runs replayed (:mod:`ecostudy.core.progress`)."""
    check_options(energy_tolerance=energy_tolerance, time_tolerance=time_tolerance)
    figures = output(fig_format, dpi)
    with watched(progress):
        table, summary = validate_study(log_file, train, track, out, energy_tolerance / 100, time_tolerance / 100,
                                        (figures.filename("validate"),) if plot else ())
        stage("figures and report")
    figure_files(out, plot, {"validate": partial(calplots.validation, table,
                                                 title=f"{Path(log_file).stem}: logged and model")}, figures)
    write_html(out)
    return reported(out, [shown(table, VALIDATION_COLUMNS, ".4g"),
                          f"traction energy: logged {summary['logged_traction_kWh']:.2f} kWh, model "
                          f"{summary['model_traction_kWh']:.2f} kWh ("
                          + (f"{signed(summary['traction_difference_pct'], 2)} %)" if summary["traction_difference_pct"]
                             is not None else "none logged)"),
                          validation_line(table, summary["tolerances_pct"]),
                          "outputs " + listed(out)])


def validation_line(table, tolerances: dict) -> str:
    """What validate judged and how many runs passed (the reasons of those that did not: the problems)."""
    bad, bounds = int((table["status"] != "ok").sum()), (f"{tolerances['energy']:g} % traction energy, "
                                                         f"{tolerances['time']:g} % running time")
    bounds += (f", the stop tolerance of the log, {STATION_TOLERANCE_M:g} m of a stop of the track, "
               f"{LIMIT_TOLERANCE_KMH:g} km/h of the line's limits and residuals "
               f"within {MAX_STRUCTURE:g} times white noise over {WINDOW:g} s at the train fitted to the log")
    if not bad:
        return f"runs replayed: every run of {len(table)} within {bounds}"
    return f"validate flagged: {bad} of {len(table)} runs not within {bounds} (each below)"
