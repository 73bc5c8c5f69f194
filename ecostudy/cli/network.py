"""`ecostudy network STUDY.yaml`: trains on one line and one DC substation (registered on ``cli.app``).

Like ``cli/solve.py`` it only parses options, calls the library and prints; errors become one line.
"""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli.app import FORCE_HELP, app, every_core, flag_folder, guarded, listed, with_force


def _network(study_path, out, no_plot, workers=None, figures=("png", None)):
    workers = every_core(workers)
    from ecostudy.report.style import output
    figures = output(*figures)
    from ecostudy.io.loaders import load_network_study
    from ecostudy.io.writers import check_output_dir
    from ecostudy.report.files import write_network
    from ecostudy.studies.network import run_network
    st = load_network_study(study_path)
    from ecostudy.studies.estimate import check_network
    check_network(st, study_path)  # legs too big for a run refused with their estimate (unless --force)
    out_dir = check_output_dir(Path(out) if out else st.output)
    table = write_network(run_network(st, workers, progress=typer.echo), st, out_dir, plot=not no_plot, out=figures)
    cols = ["strategy", "status", "substation_kWh", "saving_vs_independent_pct", "traction_input_kWh", "regen_used_kWh",
            "regen_lost_kWh", "line_losses_kWh", "unserved_kWh", "balance_error_pct", "min_separation_m",
            "all_verified"]
    typer.echo(table[[c for c in cols if c in table]].to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    typer.echo("outputs " + listed(out_dir))
    return out_dir


@app.command(short_help="Trains sharing a DC substation: independent, supervisor rules, joint optimum.")
def network(
    study: Path = typer.Argument(..., help="Network study file (YAML)."),
    out: Optional[Path] = typer.Option(None, help="Output folder (default: the study's output)."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the figures."),
    fig_format: str = typer.Option("png", "--format", help="Figure format: png, svg or pdf."),
    dpi: float = typer.Option(110.0, help="Figure resolution [dots per inch] (raster images)."),
    workers: Optional[int] = typer.Option(None, min=1, help="Processes: the segments' first runs, then the strategies "
                                          "in parallel (at least twice as many as workers), else one train's legs "
                                          "(default: every core)."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Trains sharing one DC substation: independent, rules 7.7 / 7.11, dissension, joint optimum, following."""
    flag_folder(guarded(debug, with_force(force, _network), study, out, no_plot, workers, (fig_format, dpi)))
