"""Study commands of the command line: pareto, compare, journey, run (registered on ``cli.app``).

Like ``cli/solve.py`` they only parse options, call the library and print; errors become one line.
"""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli.app import (DasMethod, FORCE_HELP, app, case_progress, check_options, every_core, flag_folder, guarded,
                              listed, only_one, with_force)
from ecostudy.core.errors import InputError, problem


def no_windows(st, command):
    """Refuse a study's timing windows where ``command`` would ignore them."""
    if st is not None and (st.windows or st.timing.window is not None):
        raise InputError(problem(str(st.name), "windows/window_s", f"{command} does not keep timing windows yet; "
                                 "use `ecostudy solve` (or remove the windows)"))


def _case_from(study, track, train, from_stop, to_stop, points):
    """(track, train, from, to, K, study or None) from a study file or from options."""
    from ecostudy.io.loaders import chosen_stops, load_track, load_train
    from ecostudy.studies.cases import load_checked_study
    if study is not None:
        st = load_checked_study(study)
        return st.track, st.train, st.from_stop, st.to_stop, points or st.points, st
    if not (track and train):
        raise InputError(problem("command line", "--track/--train", "give a study file, or both --track and --train"))
    trk, trn = load_track(track), load_train(train)
    f, t = chosen_stops(trk, from_stop, to_stop, "command line")
    return trk, trn, f, t, points, None


def _pareto(study, track, train, from_stop, to_stop, count, supplement_max, points, workers, cold, out, no_plot,
            weighted=0, das=None, das_time_limit=60.0, figures=("png", None)):
    from ecostudy.report.style import output
    figures = output(*figures)
    check_options(count=count, supplement_max=supplement_max, points=points, workers=workers, weighted=weighted,
                  das_time_limit=das_time_limit)
    from ecostudy.core import units
    from ecostudy.io.writers import check_output_dir
    trk, trn, f, t, k, st = _case_from(study, track, train, from_stop, to_stop, points)
    no_windows(st, "pareto")
    from ecostudy.report.files import write_front  # the optimiser only once the inputs are known good
    from ecostudy.studies.pareto import das_front, das_meta, front_meta, sweep, weighted_points
    k = k or 500
    if count < 2:
        raise InputError(problem("command line", "--count", "need at least 2 points"))
    if supplement_max <= 0:
        raise InputError(problem("command line", "--supplement-max", "must be > 0 (per cent)"))
    out_dir = Path(out) if out else (st.output.parent / (st.output.name + "_pareto") if st else Path("out") / "pareto")
    check_output_dir(out_dir, ("pareto.csv", "pareto.json", "pareto.png"))
    table, results = sweep(trk, trn, f, t, count=count, supplement_max=supplement_max * units.PERCENT,
                           points=k, workers=workers, warm=not cold)
    meta = front_meta(table, {"track": trk.name, "train": trn.name, "from": f, "to": t}, k, count, workers, not cold)
    if das is not None:
        table = das_front(table, results, das.value, k, workers, das_time_limit)
        meta["das"] = das_meta(table)
    extra = weighted_points(trk, trn, f, t, count=weighted, points=k) if weighted else None
    write_front(table, results, out_dir, meta, plot=not no_plot, weighted=extra, out=figures)
    cols = ["running_time_s", "supplement_pct", "traction_energy_kWh", "net_energy_kWh", "saving_vs_all_out_pct",
            "marginal_saving_kWh_per_s", "coasting_share_pct", "regime_sequence"]
    if das is not None:
        cols += ["das_traction_energy_kWh", "das_gap_to_ato_on_time_pct", "das_mode_changes"]
    typer.echo(table[[c for c in cols if c in table]].to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    if das is not None:
        d = meta["das"]
        typer.echo(f"DAS {d['method']}: {d['solved']} of {d['points']} points; gap to ATO on time "
                   f"{d['min_gap_on_time_pct']:.2f} to {d['max_gap_on_time_pct']:.2f} %; monotone: {d['monotone']}")
    typer.echo(f"all-out {meta['all_out_time_s']:.2f} s; +5 % saves {meta['saving_at_5_pct_supplement_pct']:.1f} %, "
               f"+10 % saves {meta['saving_at_10_pct_supplement_pct']:.1f} % of the all-out traction energy")
    typer.echo(f"monotone: {meta['monotone']}, all optimal: {meta['all_optimal']}, all verified: "
               f"{meta['all_verified']}; {meta['wall_s']:.1f} s; outputs "
               + listed(out_dir))
    return out_dir


@app.command(short_help="Energy against running time: the Pareto front.")
def pareto(
    study: Optional[Path] = typer.Argument(None, help="Study file (YAML)."),
    track: Optional[Path] = typer.Option(None, help="Track file."),
    train: Optional[Path] = typer.Option(None, help="Train file."),
    from_stop: Optional[str] = typer.Option(None, "--from", help="Departure stop (default: first)."),
    to_stop: Optional[str] = typer.Option(None, "--to", help="Arrival stop (default: last)."),
    count: int = typer.Option(20, help="Points on the front, the all-out run included."),
    supplement_max: float = typer.Option(40.0, help="Largest running-time supplement over all-out [%]."),
    points: Optional[int] = typer.Option(None, "--points", "-K", help="Grid nodes K (default 500)."),
    workers: int = typer.Option(1, help="Processes; each solves a contiguous warm-started chain."),
    cold: bool = typer.Option(False, help="Solve every point on its own (no shared model, no warm start)."),
    weighted: int = typer.Option(0, help="Also N weighted-sum points (w_t T + w_e E/m, Yazhemsky 2017, eq. 4.1a)."),
    das: Optional[DasMethod] = typer.Option(None, help="Also the DAS front: round | phases | minlp at every point."),
    das_time_limit: float = typer.Option(60.0, help="Time limit of each MINLP search [s] (--das minlp)."),
    out: Optional[Path] = typer.Option(None, help="Output folder."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the figures."),
    fig_format: str = typer.Option("png", "--format", help="Figure format: png, svg or pdf."),
    dpi: float = typer.Option(110.0, help="Figure resolution [dots per inch] (raster images)."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Energy against running time (epsilon-constraint sweep from the all-out time), ATO and optionally DAS."""
    flag_folder(guarded(debug, with_force(force, _pareto), study, track, train, from_stop, to_stop, count,
                        supplement_max, points, workers, cold, out, no_plot, weighted, das, das_time_limit,
                        (fig_format, dpi)))


def _compare(study, track, train, from_stop, to_stop, time, supplement, points, out, no_plot, figures=("png", None)):
    from ecostudy.report.style import output
    figures = output(*figures)
    check_options(time=time, supplement=supplement, points=points)
    only_one(time=time, supplement=supplement)
    from ecostudy.core import units
    from ecostudy.core.types import Timing
    from ecostudy.io.writers import check_output_dir
    trk, trn, f, t, k, st = _case_from(study, track, train, from_stop, to_stop, points)
    no_windows(st, "compare")
    from ecostudy.report.files import write_compare
    from ecostudy.studies.compare import compare  # the optimiser only once the inputs are known good
    if time is not None or supplement is not None:
        timing = Timing(running_time=time, supplement=None if supplement is None else supplement * units.PERCENT)
    elif st is not None:
        timing = st.timing
    else:
        raise InputError(problem("command line", "--time", "give --time or --supplement"))
    out_dir = Path(out) if out else (st.output.parent / (st.output.name + "_compare") if st else Path("out") / "compare")
    check_output_dir(out_dir, ("compare.csv", "compare.png"))
    table, outcomes, case = compare(trk, trn, f, t, timing, points=k or 1000)
    write_compare(table, outcomes, case.segment, out_dir,
                  f"{trn.name} - {f} to {t}, target {table.attrs['target_s']:.1f} s", plot=not no_plot,
                  out=figures)
    typer.echo(table.to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    typer.echo("outputs " + listed(out_dir))
    return out_dir


@app.command(name="compare", short_help="Strategies side by side, each re-simulated by one simulator.")
def compare_command(
    study: Optional[Path] = typer.Argument(None, help="Study file (YAML)."),
    track: Optional[Path] = typer.Option(None, help="Track file."),
    train: Optional[Path] = typer.Option(None, help="Train file."),
    from_stop: Optional[str] = typer.Option(None, "--from", help="Departure stop (default: first)."),
    to_stop: Optional[str] = typer.Option(None, "--to", help="Arrival stop (default: last)."),
    time: Optional[float] = typer.Option(None, "--time", help="Running time [s]."),
    supplement: Optional[float] = typer.Option(None, help="Running-time supplement over all-out [%]."),
    points: Optional[int] = typer.Option(None, "--points", "-K", help="Grid nodes K (default 1000)."),
    out: Optional[Path] = typer.Option(None, help="Output folder."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip compare.png."),
    fig_format: str = typer.Option("png", "--format", help="Figure format: png, svg or pdf."),
    dpi: float = typer.Option(110.0, help="Figure resolution [dots per inch] (raster images)."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Strategies side by side, every one scored by the same independent simulator: all-out, ATO optimum,
    eco-drive coasting, MARECO-style (after OSRD's MARECO), DAS round and DAS phases.

    Example: ecostudy compare studies/default.yaml --out out/compare
    """
    flag_folder(guarded(debug, with_force(force, _compare), study, track, train, from_stop, to_stop, time, supplement,
                        points, out, no_plot, (fig_format, dpi)))


def associated_track(tt, path):
    """The track file a timetable names (TTOBench 'associated track'), looked for beside it and in a
    sibling ``tracks/`` folder (the library's layout)."""
    if tt is None or tt.track is None:
        raise InputError(problem("command line", "--track", "missing (the timetable names no track)"))
    here = Path(path).resolve().parent
    for candidate in (here / f"{tt.track}.json", here.parent / "tracks" / f"{tt.track}.json",
                      here / f"{tt.track}.yaml"):
        if candidate.is_file():
            return candidate
    raise InputError(problem(path, "metadata.associated track", f"track '{tt.track}' not found beside the "
                             "timetable or in ../tracks/; give --track"))


def _journey(track, train, stops, time, supplement, timetable, dwell, points, workers, out, no_plot,
             figures=("png", None)):
    from ecostudy.report.style import output
    figures = output(*figures)
    check_options(time=time, supplement=supplement, dwell=dwell, points=points, workers=workers)
    from ecostudy.core import units
    from ecostudy.io.loaders import check_stop_list, load_timetable, load_track, load_train, timing_from_timetable
    from ecostudy.io.timetable import journey_plan, name_stops
    from ecostudy.io.writers import check_output_dir
    tt = load_timetable(timetable) if timetable is not None else None
    trk, trn = load_track(track if track is not None else associated_track(tt, timetable)), load_train(train)
    scheduled, plan = None, None
    if tt is not None:
        if stops or time is not None or supplement is not None or not tt.stops:
            raise InputError(problem("command line", "--timetable", "a timetable with stop times replaces --stops, "
                                     "--time and --supplement"))
        tt, trk = name_stops(tt, trk, timetable)
        names = [row.stop for row in tt.stops]
        if tt.windowed:
            plan = journey_plan(tt, trk, timetable, dwell)
        else:
            scheduled = [timing_from_timetable(tt, a, b, timetable).running_time for a, b in zip(names, names[1:])]
        time, supplement = None, None
    else:
        names = list(trk.stops) if stops is None else [n.strip() for n in stops.split(",")]
    check_stop_list(trk, names, "command line", "--stops")
    if scheduled is None and plan is None and (time is None) == (supplement is None):
        raise InputError(problem("command line", "--time/--supplement",
                                 "give one total running time or supplement, or --timetable"))
    out_dir = check_output_dir(Path(out) if out else Path("out") / "journey",
                               ("journey.csv", "journey_totals.csv", "journey.png"))
    from ecostudy.report.files import write_journey
    from ecostudy.studies.journey import journey  # the optimiser only once the inputs are known good
    table, totals, results, _ = journey(trk, trn, names, total_time=time,
                                        supplement=None if supplement is None else supplement * units.PERCENT,
                                        points=points, workers=workers, scheduled=scheduled, plan=plan)
    passing = []
    if plan is not None:  # timing points along the journey (segment lengths from the first split)
        start = 0.0
        for windows, run in zip(plan.windows, next(iter(results.values()))):
            passing += [(start + w.distance, None if w.max_speed is None else units.to_kmh(w.max_speed))
                        for w in windows]
            start += run.summary["distance_m"]
    write_journey(table, totals, results, out_dir, f"{trn.name}: {' - '.join(names)}", passing, plot=not no_plot,
                  out=figures)
    typer.echo(table.to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    typer.echo(totals.to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    typer.echo("outputs " + listed(out_dir))
    return out_dir


@app.command(name="journey", short_help="Spread a journey's running time over its segments.")
def journey_command(
    track: Optional[Path] = typer.Option(None, help="Track file with the stops (default: the track a "
                                         "TTOBench journey names, from ../tracks/)."),
    train: Path = typer.Option(..., help="Train file."),
    stops: Optional[str] = typer.Option(None, help="Stops served, comma-separated (default: all, in order)."),
    time: Optional[float] = typer.Option(None, "--time", help="Total running time, dwell excluded [s]."),
    supplement: Optional[float] = typer.Option(None, help="Total supplement over the sum of all-out times [%]."),
    timetable: Optional[Path] = typer.Option(None, help="Timetable: stops with times (its running times, "
                                             "redistributed) or with windows, or a TTOBench journey JSON."),
    dwell: float = typer.Option(0.0, help="Dwell at intermediate stops whose timetable gives none; with "
                                "departure windows, the least dwell [s]."),
    points: int = typer.Option(500, "--points", "-K", help="Grid nodes per segment."),
    workers: int = typer.Option(1, help="Processes for the segments' fronts."),
    out: Optional[Path] = typer.Option(None, help="Output folder."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip journey.png."),
    fig_format: str = typer.Option("png", "--format", help="Figure format: png, svg or pdf."),
    dpi: float = typer.Option(110.0, help="Figure resolution [dots per inch] (raster images)."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Spread a journey's running time over its segments: equal marginal saving vs same percentage."""
    flag_folder(guarded(debug, with_force(force, _journey), track, train, stops, time, supplement, timetable, dwell,
                        points, workers, out, no_plot, (fig_format, dpi)))


def _run(study, workers, dask, retry_failed, out, no_progress):
    check_options(workers=workers)
    workers = every_core(workers)
    from ecostudy.studies.batch import run_study
    with case_progress("cases", no_progress) as progress:
        table, counts, output = run_study(study, workers=workers, dask=dask, retry_failed=retry_failed,
                                          out=Path(out) if out else None, progress=progress)
    typer.echo(f"{counts['total']} cases: {counts['stored_before']} already stored, {counts['computed']} computed "
               f"now ({counts['failed']} of them failed or infeasible); not ok in the table: {counts['not_ok']}")
    from ecostudy.report.html import write_html
    write_html(output)
    typer.echo("outputs " + listed(output, ("results.csv", "results.sqlite", "report.html")))
    return output


@app.command(short_help="Every case of a study file; resumable, in parallel.")
def run(
    study: Path = typer.Argument(..., help="Study file (YAML) with optional scenarios and sweep."),
    workers: Optional[int] = typer.Option(None, help="Local worker processes (default: every core)."),
    dask: Optional[str] = typer.Option(None, help="Address of a running Dask scheduler (tcp://host:port)."),
    retry_failed: bool = typer.Option(False, help="Compute failed cases again (infeasible ones stay)."),
    out: Optional[Path] = typer.Option(None, help="Output folder (default: the study's 'output')."),
    no_progress: bool = typer.Option(False, "--no-progress", help="No progress bar."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Run every case of a study; finished cases are stored and never computed twice."""
    flag_folder(guarded(debug, with_force(force, _run), study, workers, dask, retry_failed, out, no_progress))
