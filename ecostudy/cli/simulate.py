"""The closed-loop command of the command line: ``ecostudy simulate`` (registered on ``cli.app``)."""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli.app import (FORCE_HELP, app, case_progress, check_options, counts_line, flag_folder, guarded, listed,
                              with_force)

SHOWN = ["controller", "runs", "ok", "energy_J_per_kg_mean", "energy_J_per_kg_std", "arrival_s_mean",
         "arrival_s_max", "stop_error_m_min", "stop_error_m_max", "max_overspeed_kmh_max", "solve_mean_ms_mean",
         "solve_p95_ms_max", "over_budget_sum", "softened_sum"]


def _simulate(study, workers, dask, retry_failed, out, no_progress, no_plot, only):
    check_options(workers=workers)
    from ecostudy.studies.closedloop import simulate_study
    from ecostudy.studies.sizes import check_closed_loop_study
    check_closed_loop_study(study, workers, only)  # runs that cannot end, or too big: refused (unless --force)
    with case_progress("runs", no_progress) as progress:
        outcome = simulate_study(study, workers, dask, retry_failed, Path(out) if out else None, progress,
                                 only)
    runs, summary, counts, output = outcome.runs, outcome.aggregate, outcome.counts, outcome.output
    if not no_plot:
        from ecostudy.report import loopplots
        loopplots.draw(outcome)
    from ecostudy.report.files import write_cases_folder
    figures = [n for n in ("bands.png", "solve_times.png", "mass_estimates.png") if not no_plot and (output / n).is_file()]
    computed = runs[runs["status"] != "missing"]  # runs left out by --only are not results
    write_cases_folder(output, "simulate", computed, ["controller", "draw"],
                       {"runs": "runs.csv", "aggregate": "aggregate.csv"}, ["results.sqlite", *figures],
                       study=str(study), missing_runs=int(counts["missing"]))
    typer.echo(summary[[c for c in SHOWN if c in summary]].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    typer.echo(counts_line(counts, "runs"))
    typer.echo("outputs " + listed(output))
    if counts["missing"]:
        left = runs.loc[runs["status"] == "missing", "controller"].unique()
        typer.echo(f"not run yet: {counts['missing']} runs of {', '.join(left)} (run without --only to compute them)")
    return output


@app.command(short_help="Closed loop: controllers drive a perturbed plant, Monte Carlo, resumable.")
def simulate(
    study: Path = typer.Argument(..., help="Closed-loop study file (YAML): controllers, deviations, draws."),
    workers: int = typer.Option(1, help="Local worker processes."),
    dask: Optional[str] = typer.Option(None, help="Address of a running Dask scheduler (tcp://host:port)."),
    retry_failed: bool = typer.Option(False, help="Compute failed runs again."),
    out: Optional[Path] = typer.Option(None, help="Output folder (default: the study's 'output')."),
    no_progress: bool = typer.Option(False, "--no-progress", help="No progress bar."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the plots."),
    only: Optional[list[str]] = typer.Option(None, "--only", help="Run only this controller's runs (repeatable); "
                                             "the tables show every stored run."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Closed loop: every controller drives every draw of the plant's deviations and noise (resumable)."""
    flag_folder(guarded(debug, with_force(force, _simulate), study, workers, dask, retry_failed, out, no_progress,
                        no_plot, only))
