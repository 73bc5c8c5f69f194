"""The heavy-haul command of the command line: ``ecostudy heavyhaul`` (registered on ``cli.app``)."""
from pathlib import Path

import typer

from ecostudy.cli import options as o
from ecostudy.cli.app import app, call, finish


@app.command(short_help="Heavy-haul train as coupled masses under braking-penalised RHC (Zhang & Zhuan).")
def heavyhaul(
    study: Path = typer.Argument(..., help="Heavy-haul study file (YAML): consist, track, reference, K_b/f/horizons."),
    workers: o.StepTimed = None, dask: o.Dask = None, retry_failed: bool = typer.Option(False, help="Compute failed runs again."),
    out: o.Out = None, no_progress: o.NoProgress = False, no_plot: o.NoPlot = False,
    blas_threads: int = typer.Option(1, min=1, max=256, help="OpenBLAS threads per process (1: the small QPs run "
                                     "fastest single-threaded, docs/heavyhaul.md)."),
    fig_format: o.Format = "png", dpi: o.Dpi = 110.0, force: o.Force = False, debug: o.Debug = False,
):
    """Heavy haul: Zhang & Zhuan's braking-penalised receding-horizon controller on the coupled-mass train (resumable). Every core by default; the step times are then measured with every core busy (--workers 1: quiet-machine step times). Example: ecostudy heavyhaul studies/heavyhaul_brake_penalty.yaml"""
    finish(call(debug, "heavyhaul_folder", study, workers, dask, retry_failed, out, not no_plot, blas_threads, fig_format, dpi,
                force=force, bar=("runs", no_progress)))
