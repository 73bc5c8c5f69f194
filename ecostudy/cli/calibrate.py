"""The calibration commands of the command line: ``ecostudy calibrate`` and ``ecostudy validate``
(registered on ``cli.app``)."""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli.app import app, flag_folder, guarded, listed

SHOWN = ["name", "unit", "prior", "estimate", "low", "high", "boot_low", "boot_high", "identifiable"]


def _calibrate(logs, train, track, fit, out, draws, savings, no_plot):
    from ecostudy.studies.calibrate import calibrate_study
    result, summary = calibrate_study(logs, train, track, fit, out, draws, savings, () if no_plot else ("residuals.png",))
    if not no_plot:
        from ecostudy.report import calplots
        calplots.residuals(result.residuals, Path(out) / "residuals.png", "calibration from logged runs")
    from ecostudy.report.html import write_html
    write_html(out)
    table = result.table[[c for c in SHOWN if c in result.table]].dropna(axis=1, how="all")
    typer.echo(table.to_string(index=False, float_format=lambda x: f"{x:.5g}"))
    q = result.quality
    typer.echo(f"{q['runs']} runs, {q['speed_samples']} speed samples: replayed speed off the logged by "
               f"{q['rms_speed_mps']:.3f} m/s RMS; innovations {q['structure']:.2f} times white noise over 5 s")
    for row in summary.get("savings", []):
        typer.echo(f"{row['log']} run {row['run']}: optimum for {row['running_time_s']:.1f} s uses "
                   f"{row['optimal_traction_kWh']:.2f} kWh against {row['logged_traction_kWh']:.2f} kWh logged: saving "
                   f"{row['saving_pct']:.1f} % (band {row['saving_low_pct']:.1f} to "
                   f"{row['saving_high_pct']:.1f} % over "
                   f"{row['draws']} parameter draws)" + ("" if row["verified"] else " (optimum not verified)"))
    typer.echo(f"{result.status}" + (f": {result.reason}" if result.reason else ""))
    typer.echo("outputs " + listed(out))
    return out


@app.command(short_help="Fit a train's parameters to logged runs, with 95 % intervals.")
def calibrate(
    logs: list[Path] = typer.Argument(..., help="Logged runs (CSV with a YAML header), one or more."),
    train: Optional[Path] = typer.Option(None, help="Train file (default: the one the first log names)."),
    track: Optional[Path] = typer.Option(None, help="Track file (default: the one the first log names)."),
    fit: Optional[str] = typer.Option(None, help="Parameters to fit, comma-separated: mass, rotating_mass_factor, "
                                      "davis_a, davis_b, davis_c, efficiency, regeneration_efficiency "
                                      "(default: mass,davis_a,davis_b,davis_c,efficiency)."),
    out: Path = typer.Option(Path("out/calibration"), help="Output folder."),
    bootstrap: int = typer.Option(200, min=0, max=10000, help="Bootstrap draws over the logs (with two or more logs)."),
    savings: Optional[int] = typer.Option(None, min=0, max=100, help="Also the savings against the logged driving: "
                                          "the optimum for each logged running time, and its band over this many "
                                          "parameter draws from the fit (e.g. 8)."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the residual plot."),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Fit train parameters to logged runs: least squares on the replayed dynamics, 95 % intervals,
    identifiability (parameters the logs do not excite are held at the train file's value, exit 1)."""
    flag_folder(guarded(debug, _calibrate, logs, train, track, fit, out, bootstrap, savings, no_plot))


def _validate(log, train, track, out, energy_tolerance, time_tolerance, no_plot):
    from ecostudy.studies.calibrate import validate_study
    table, summary = validate_study(log, train, track, out, energy_tolerance / 100, time_tolerance / 100,
                                    () if no_plot else ("validate.png",))
    if not no_plot:
        from ecostudy.report import calplots
        calplots.validation(table, Path(out) / "validate.png", f"{Path(log).stem}: logged and model")
    from ecostudy.report.html import write_html
    write_html(out)
    shown = ["run", "from_m", "to_m", "logged_time_s", "model_time_s", "time_difference_pct", "logged_traction_kWh",
             "model_traction_kWh", "traction_difference_pct", "status"]
    typer.echo(table[shown].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    typer.echo(f"traction energy: logged {summary['logged_traction_kWh']:.2f} kWh, model "
               f"{summary['model_traction_kWh']:.2f} kWh ({summary['traction_difference_pct']:+.2f} %)")
    typer.echo(f"{summary['status']}" + (f": {summary['reason']}" if summary["reason"] else ""))
    typer.echo("outputs " + listed(out))
    return out


@app.command(short_help="Replay a logged run on the model: energy and time differences.")
def validate(
    log: Path = typer.Argument(..., help="A logged run (CSV with a YAML header)."),
    train: Optional[Path] = typer.Option(None, help="Train file (default: the one the log names)."),
    track: Optional[Path] = typer.Option(None, help="Track file (default: the one the log names)."),
    out: Path = typer.Option(Path("out/validate"), help="Output folder."),
    energy_tolerance: float = typer.Option(5.0, min=0.0, help="Flag a run whose traction energy differs by more [%]."),
    time_tolerance: float = typer.Option(5.0, min=0.0, help="Flag a run whose running time differs by more [%]."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the plot."),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Replay a logged run on the train file's model: traction energy following the logged speed, and
    running time driven by the logged handle, per run between stops."""
    flag_folder(guarded(debug, _validate, log, train, track, out, energy_tolerance, time_tolerance, no_plot))
