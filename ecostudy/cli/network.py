"""`ecostudy network STUDY.yaml`: trains on one line and one DC substation (registered on ``cli.app``).

Like ``cli/solve.py`` it only parses options, calls :mod:`ecostudy.api` and prints; errors become one line.
"""
from pathlib import Path

import typer

from ecostudy.cli import options as o
from ecostudy.cli.app import app, call, finish


@app.command(short_help="Trains sharing a DC substation: independent, supervisor rules, joint optimum.")
def network(
    study: Path = typer.Argument(..., help="Network study file (YAML)."),
    out: o.Out = None, no_plot: o.NoPlot = False, fig_format: o.Format = "png", dpi: o.Dpi = 110.0,
    workers: o.EveryCore = None, dask: o.Dask = None, retry_failed: o.RetryFailed = False,
    force: o.Force = False, no_progress: o.NoProgress = False, debug: o.Debug = False,
):
    """Trains sharing one DC substation (Farooqi 2018): independent, rules 7.7 / 7.11, dissension, joint optimum, following; resumable. Example: ecostudy network studies/network_metro_2trains.yaml"""
    finish(call(debug, "network_folder", study, out, not no_plot, workers, fig_format, dpi, dask, retry_failed,
                force=force, bar=("strategies", no_progress)))
