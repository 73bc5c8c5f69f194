"""Single-run commands: solve, check, export, doctor (registered on :data:`ecostudy.cli.app.app`).

They parse options, call :mod:`ecostudy.api` and print; errors become one line (:func:`~ecostudy.cli.app.call`).
"""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli import options as o
from ecostudy.cli.app import app, call, finish, told


@app.command(short_help="Energy-optimal (or all-out) run between two stops, verified.")
def solve(
    study: o.Study = None, track: o.Track = None, train: o.Train = None, time: o.Time = None, supplement: o.Supplement = None,
    window: Optional[str] = typer.Option(None, help="Arrival window 'earliest,latest' [s]."),
    from_stop: o.From = None, to_stop: o.To = None,
    objective: Optional[o.Objective] = typer.Option(None, help="energy | net_energy | time | mixed."),
    weights: Optional[str] = typer.Option(None, help="Mixed weights 'w_t,w_e': minimise w_t T [s] + w_e E/Ms [J/kg] (Yazhemsky 2017, eq. 4.1)."),
    points: o.Points = None, out: o.SolveOut = None, no_plot: o.NoPlot = False, fig_format: o.Format = "png", dpi: o.Dpi = 110.0,
    das: Optional[o.DasMethod] = typer.Option(
        None, help="Also driver advice: round (nearest handle level), phases (optimal phase lengths, "
                   "Farooqi 2018, Ch. 5) or minlp (mode per phase chosen by binaries)."),
    das_time_limit: o.DasTimeLimit = None, force: o.Force = False, no_progress: o.NoProgress = False, debug: o.Debug = False,
):
    """Energy-optimal (or all-out) run between two stops, verified by re-simulation. Example: ecostudy solve studies/default.yaml"""
    finish(call(debug, "solve_folder", study, track, train, time, supplement, window, from_stop, to_stop,
                objective and objective.value, weights, points, out, not no_plot, das and das.value, das_time_limit,
                fig_format, dpi, force=force, bar=("solve", no_progress, False)))


@app.command(short_help="Pontryagin regime check of a solved profile.")
def check(
    result_dir: Path = typer.Argument(..., help="Output folder of `ecostudy solve`."),
    time: Optional[float] = typer.Option(None, "--time", help="Test as the energy-optimal run arriving by this time [s]."),
    debug: o.Debug = False,
):
    """Pontryagin regime check of a solved profile (Farooqi 2018, eq. 2.17; eq. 7.4 for net-energy runs); exit 1 below 95 % agreement, or when the run checked is not ok. Example: ecostudy check out/default"""
    told(call(debug, "check_folder", result_dir, time), 1)


@app.command(short_help="A solved run every N s or N m (CSV and JSON), for on-board systems.")
def export(
    result_dir: Path = typer.Argument(..., help="Output folder of `ecostudy solve`."),
    every: str = typer.Option("1s", help="Step: seconds ('1s') or metres ('10m')."),
    debug: o.Debug = False,
):
    """The run of a solve folder at fixed steps of time or distance: position, time, speed, handle and, with driver
    advice, the advised mode (profile_every_<step>.csv and .json, with the run's status); exit 1 when it is not ok.

    Example: ecostudy export out/default --every 10m
    """
    told(call(debug, "export_folder", result_dir, every), 1)


@app.command(short_help="Check the install: solver chain versions and a toy solve.")
def doctor(debug: o.Debug = False):
    """Check the install: versions of the solver chain and a toy NLP solved with Ipopt. Example: ecostudy doctor"""
    told(call(debug, "doctor"), 3)
