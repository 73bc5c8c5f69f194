"""Study commands of the command line: pareto, compare, journey, run (registered on ``cli.app``).

Like ``cli/solve.py`` they only parse options, call :mod:`ecostudy.api` and print; errors become one line.
"""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli import options as o
from ecostudy.cli.app import app, call, finish


@app.command(short_help="Energy against running time: the Pareto front.")
def pareto(
    study: o.Study = None, track: o.Track = None, train: o.Train = None, from_stop: o.From = None, to_stop: o.To = None,
    count: int = typer.Option(20, help="Points on the front, the all-out run included; a study file's own running time is one more."),
    supplement_max: float = typer.Option(40.0, help="Largest running-time supplement over all-out [%]."),
    points: o.Points = None, workers: o.EveryCore = None, dask: o.Dask = None, retry_failed: o.RetryFailed = False,
    weighted: int = typer.Option(0, help="Also N weighted-sum points (w_t T [s] + w_e E/Ms [J/kg], Yazhemsky 2017, eq. 4.1a)."),
    das: Optional[o.DasMethod] = typer.Option(None, help="Also the DAS front: round | phases | minlp at every point."),
    das_time_limit: o.DasTimeLimit = None, out: o.ParetoOut = None, no_plot: o.NoPlot = False, fig_format: o.Format = "png",
    dpi: o.Dpi = 110.0, force: o.Force = False, no_progress: o.NoProgress = False, debug: o.Debug = False,
):
    """Energy against running time (epsilon-constraint sweep from the all-out time, and a study file's own running time), ATO and optionally DAS; every point stored, resumable. Example: ecostudy pareto studies/default.yaml --count 9"""
    finish(call(debug, "pareto_folder", study, track, train, from_stop, to_stop, count, supplement_max, points,
                workers, out, not no_plot, weighted, das and das.value, das_time_limit, fig_format, dpi, dask,
                retry_failed, force=force, bar=("points", no_progress)))


@app.command(name="compare", short_help="Strategies side by side, each re-simulated by one simulator.")
def compare_command(
    study: o.Study = None, track: o.Track = None, train: o.Train = None, from_stop: o.From = None, to_stop: o.To = None,
    time: o.Time = None, supplement: o.Supplement = None, points: o.Points = None, out: o.CompareOut = None,
    no_plot: o.NoPlot = False, fig_format: o.Format = "png", dpi: o.Dpi = 110.0, force: o.Force = False,
    debug: o.Debug = False, workers: o.EveryCore = None, dask: o.Dask = None, retry_failed: o.RetryFailed = False,
    no_progress: o.NoProgress = False):
    """Strategies side by side, every one scored by the same independent simulator: all-out, ATO optimum,
    eco-drive coasting, MARECO-style (after OSRD's MARECO), DAS round and DAS phases; resumable.

    Example: ecostudy compare studies/default.yaml --out out/compare
    """
    finish(call(debug, "compare_folder", study, track, train, from_stop, to_stop, time, supplement, points, out,
                not no_plot, fig_format, dpi, workers, dask, retry_failed, force=force, bar=("strategies", no_progress)))


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
    points: int = typer.Option(o.FRONT_POINTS, "--points", "-K", help="Grid nodes per segment."),
    workers: int = typer.Option(1, help="Processes for the segments' fronts."),
    out: o.JourneyOut = None, no_plot: o.NoPlot = False, fig_format: o.Format = "png", dpi: o.Dpi = 110.0,
    force: o.Force = False, no_progress: o.NoProgress = False, debug: o.Debug = False,
):
    """Spread a journey's running time over its segments: equal marginal saving vs same percentage. Example: ecostudy journey --train trains/amsterdam_metro.yaml --track tracks/metro_line_4stops.yaml --supplement 10"""
    finish(call(debug, "journey_folder", train, track, stops, time, supplement, timetable, dwell, points, workers,
                out, not no_plot, fig_format, dpi, force=force, bar=("runs", no_progress, False)))


@app.command(short_help="Every case of a study file; resumable, in parallel.")
def run(
    study: Path = typer.Argument(..., help="Study file (YAML) with optional scenarios and sweep."),
    workers: o.EveryCore = None, dask: o.Dask = None, retry_failed: o.RetryFailed = False, out: o.RunOut = None,
    no_progress: o.NoProgress = False, force: o.Force = False, debug: o.Debug = False,
    kind: str = typer.Option("run", help="Study kind: run (scenarios x sweep, or a library), or one registered."),
    no_plot: o.NoPlot = False, fig_format: o.Format = "png", dpi: o.Dpi = 110.0,
):
    """Run every case of a study; finished cases are stored and never computed twice. --no-plot, --format and --dpi apply to the figures of --kind pareto, compare, network, heavyhaul and simulate: the kind run draws none. Example: ecostudy run studies/metro_supplements.yaml"""
    finish(call(debug, "run_folder", study, workers, dask, retry_failed, out, kind, not no_plot, fig_format, dpi, force=force,
                bar=("cases", no_progress)))
