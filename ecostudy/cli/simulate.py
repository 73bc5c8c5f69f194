"""The closed-loop command of the command line: ``ecostudy simulate`` (registered on ``cli.app``)."""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli import options as o
from ecostudy.cli.app import app, call, finish


@app.command(short_help="Closed loop: controllers drive a perturbed plant, Monte Carlo, resumable.")
def simulate(
    study: Path = typer.Argument(..., help="Closed-loop study file (YAML): controllers, deviations, draws."),
    workers: o.StepTimed = None, dask: o.Dask = None, retry_failed: bool = typer.Option(False, help="Compute failed runs again."),
    out: o.Out = None, no_progress: o.NoProgress = False, no_plot: o.NoPlot = False,
    only: Optional[list[str]] = typer.Option(None, "--only", help="Run only this controller's runs (repeatable); "
                                             "the tables show every stored run."),
    fig_format: o.Format = "png", dpi: o.Dpi = 110.0, force: o.Force = False, debug: o.Debug = False,
):
    """Closed loop: every controller drives every draw of the plant's deviations and noise (resumable). Every core by default; the step times are then measured with every core busy (--workers 1: quiet-machine step times). Example: ecostudy simulate studies/yazhemsky2017_closed_loop.yaml"""
    finish(call(debug, "simulate_folder", study, workers, dask, retry_failed, out, not no_plot, only, fig_format, dpi, force=force,
                bar=("runs", no_progress)))
