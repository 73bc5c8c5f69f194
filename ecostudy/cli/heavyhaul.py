"""The heavy-haul command of the command line: ``ecostudy heavyhaul`` (registered on ``cli.app``)."""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli.app import app, case_progress, check_options, counts_line, flag_folder, guarded
from ecostudy.cli.blas import limit_blas_threads

SHOWN = ["K_b", "f", "Np", "Nc", "status", "tracking_mean_mps", "tracking_std_mps", "force_max_kN", "force_max_braking_kN",
         "force_mean_kN", "force_std_kN", "wagon_brake_kWh", "energy_total_kWh", "qp_inputs", "solve_mean_s", "solve_p95_s", "solve_max_s", "over_ts", "stop_error_m"]


def _heavyhaul(study, workers, dask, retry_failed, out, no_progress, no_plot, blas_threads):
    check_options(workers=workers)
    limit_blas_threads(blas_threads)  # before the workers fork: they inherit it
    from ecostudy.studies.heavyhaul import heavyhaul_study
    with case_progress("runs", no_progress) as progress:
        outcome = heavyhaul_study(study, workers, dask, retry_failed, Path(out) if out else None, progress)
    plots = []
    if not no_plot:
        from ecostudy.report import heavyplots
        plots = heavyplots.draw(outcome)
    runs, counts = outcome.runs, outcome.counts
    from ecostudy.report.files import write_cases_folder
    write_cases_folder(outcome.output, "heavyhaul", runs, ["K_b", "f", "Np", "Nc"], {"runs": "runs.csv"},
                       ["results.sqlite", *plots], study=str(study))
    typer.echo(runs[[c for c in SHOWN if c in runs]].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    typer.echo(counts_line(counts, "runs"))
    typer.echo(f"outputs {outcome.output}/ ({', '.join(['runs.csv', 'summary.json', 'report.html'] + plots[:3])}"
               f"{', ...' if len(plots) > 3 else ''})")
    return outcome.output


@app.command(short_help="Heavy-haul train as coupled masses under braking-penalised RHC (Zhang & Zhuan).")
def heavyhaul(
    study: Path = typer.Argument(..., help="Heavy-haul study file (YAML): consist, track, reference, K_b/f/horizons."),
    workers: int = typer.Option(1, help="Local worker processes."),
    dask: Optional[str] = typer.Option(None, help="Address of a running Dask scheduler (tcp://host:port)."),
    retry_failed: bool = typer.Option(False, help="Compute failed runs again."),
    out: Optional[Path] = typer.Option(None, help="Output folder (default: the study's 'output')."),
    no_progress: bool = typer.Option(False, "--no-progress", help="No progress bar."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the plots."),
    blas_threads: int = typer.Option(1, min=1, max=256, help="OpenBLAS threads per process (1: the small QPs run "
                                     "fastest single-threaded, docs/heavyhaul.md)."),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Heavy haul: Zhang & Zhuan's braking-penalised receding-horizon controller on the coupled-mass train (resumable)."""
    flag_folder(guarded(debug, _heavyhaul, study, workers, dask, retry_failed, out, no_progress, no_plot,
                        blas_threads))
