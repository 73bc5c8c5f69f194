"""The calibration commands of the command line: ``ecostudy calibrate`` and ``ecostudy validate``
(registered on ``cli.app``)."""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli import options as o
from ecostudy.cli.app import app, call, finish


@app.command(short_help="Fit a train's parameters to logged runs, with 95 % intervals.")
def calibrate(
    logs: list[Path] = typer.Argument(..., help="Logged runs (CSV with a YAML header), one or more."),
    train: Optional[Path] = typer.Option(None, help="Train file (default: the one the first log names)."),
    track: Optional[Path] = typer.Option(None, help="Track file (default: the one the first log names)."),
    fit: Optional[str] = typer.Option(None, help="Parameters to fit, comma-separated: mass, rotating_mass_factor, davis_a, "
                                      "davis_b, davis_c, efficiency, regeneration_efficiency (default: mass,davis_a,davis_b,davis_c,efficiency)."),
    out: Path = typer.Option(Path("out/calibration"), help="Output folder (relative: to the working directory)."),
    bootstrap: int = typer.Option(200, min=0, max=10000, help="Bootstrap draws over the logs (with five or more logs; fewer leave boot_low, boot_high empty): the spread between logs, not a confidence interval."),
    savings: Optional[int] = typer.Option(None, min=0, max=100, help="Also the savings against the logged driving: "
                                          "the optimum for each logged running time, and its band over this many "
                                          "parameter draws from the fit (e.g. 8)."),
    no_plot: o.NoPlot = False, fig_format: o.Format = "png", dpi: o.Dpi = 110.0, no_progress: o.NoProgress = False,
    debug: o.Debug = False):
    """Fit train parameters to logged runs: least squares on the replayed dynamics, 95 % intervals,
    identifiability (parameters the logs do not excite are held at the train file's value, exit 1). Example: ecostudy calibrate LOG.csv --train TRAIN.yaml --track TRACK.yaml --out out/cal"""
    finish(call(debug, "calibrate_folder", logs, train, track, fit, out, bootstrap, savings, not no_plot, fig_format, dpi,
                bar=("calibrate", no_progress, False)))


@app.command(short_help="Replay a logged run on the model: energy and time differences.")
def validate(
    log: Path = typer.Argument(..., help="A logged run (CSV with a YAML header)."),
    train: Optional[Path] = typer.Option(None, help="Train file (default: the one the log names)."),
    track: Optional[Path] = typer.Option(None, help="Track file (default: the one the log names)."),
    out: Path = typer.Option(Path("out/validate"), help="Output folder (relative: to the working directory)."),
    energy_tolerance: float = typer.Option(5.0, min=0.0, help="Flag a run whose traction energy differs by more [%]."),
    time_tolerance: float = typer.Option(5.0, min=0.0, help="Flag a run whose running time differs by more [%]."),
    no_plot: o.NoPlot = False, fig_format: o.Format = "png", dpi: o.Dpi = 110.0, no_progress: o.NoProgress = False,
    debug: o.Debug = False):
    """Replay a logged run on the train file's model: traction energy following the logged speed, and
    running time driven by the logged handle, per run between stops. Example: ecostudy validate LOG.csv --train TRAIN.yaml --track TRACK.yaml --out out/val"""
    finish(call(debug, "validate_folder", log, train, track, out, energy_tolerance, time_tolerance, not no_plot, fig_format, dpi,
                bar=("validate", no_progress, False)))
