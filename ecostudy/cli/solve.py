"""Single-run commands: solve, check, doctor (registered on :data:`ecostudy.cli.app.app`).

They parse options, call the library and print; errors become one line (:func:`guarded`).
"""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli.app import (
    DasMethod, FORCE_HELP, Objective, app, check_options, flag_folder, guarded,
    listed, only_one, parse_pair, with_force,
)
from ecostudy.core.errors import InputError, problem


def _report(result, out_dir):
    s = result.summary
    ver = s["verification"]
    typer.echo(f"{s['train']}: {s['from']} -> {s['to']} ({s['distance_m']:.0f} m), objective {s['objective']}, "
               f"K = {s['points']}")
    typer.echo(f"  running time      {s['running_time_s']:9.2f} s")
    typer.echo(f"  traction energy   {s['traction_energy_kWh']:9.3f} kWh  "
               f"({s['traction_energy_J_per_kg']:.2f} J/kg)")
    typer.echo(f"  net energy        {s['net_energy_kWh']:9.3f} kWh  "
               f"(regenerated {s['regenerated_energy_kWh']:.3f} kWh)")
    typer.echo(f"  solver            {s['solver']['status']}, {s['solver']['iterations']} iterations, "
               f"{s['solver']['seconds']:.2f} s")
    typer.echo(f"  regimes           {s['regimes']['sequence']}")
    if s.get("pontryagin"):
        pm = s["pontryagin"]
        typer.echo(f"  Pontryagin check  {pm['agreement_pct']:.1f} % of the distance obeys {pm.get('conditions', 'eq. 2.17')}"
                   + "".join(f"; {d['regime']} at {d['start_m']:.0f}-{d['end_m']:.0f} m disagrees"
                             for d in pm["disagreements"][:3]))
    if ver is not None:
        flag = "passed" if ver["passed"] else "FAILED"
        typer.echo(f"  verification      {flag}: arrival {ver['arrival_time_error_s']:+.3f} s, stop "
                   f"{ver['stop_error_m']:+.3f} m, energy {ver['energy_error_pct']:+.3f} %, overspeed "
                   f"{ver['max_overspeed_kmh']:.3f} km/h")
    if s.get("das"):
        d = s["das"]
        typer.echo(f"  driver advice     {d['method']}: {d['traction_energy_kWh']:.3f} kWh ({d['gap_to_ato_pct']:+.2f} % "
                   f"against ATO), {d['mode_changes']} mode changes, arrival {d['arrival_error_s']:+.2f} s, "
                   f"stop {d['stop_error_m']:+.2f} m (advice.csv)")
        if d.get("gap_to_ato_on_time_pct") is not None:
            typer.echo(f"                    {d['gap_to_ato_on_time_pct']:+.3f} % against ATO with lateness charged at "
                       f"{abs(s['marginal_energy_kWh_per_s']):.4f} kWh/s; {d['status']}")
        if d["method"] == "minlp":
            bound = "no bound" if d["bound_kWh"] is None else f"bound {d['bound_kWh']:.3f} kWh (gap {d['gap_pct']:.2f} %)"
            typer.echo(f"                    MINLP search {d['search_s']:.1f} s, {d['oa_iterations']} OA iterations, "
                       f"{bound}")
    typer.echo(f"  outputs           {listed(out_dir)}")


def _solve(study, track, train, time, supplement, window, from_stop, to_stop, objective, weights,
           points, out, no_plot, das=None, das_time_limit=60.0, figures=("png", None)):
    from ecostudy.report.style import output
    figures = output(*figures)
    check_options(time=time, supplement=supplement, points=points, das_time_limit=das_time_limit)
    only_one(time=time, supplement=supplement, window=window)
    if objective is not None and objective.value == "time" and any(x is not None for x in (time, supplement, window)):
        raise InputError(problem("command line", "--objective time", "finds the fastest run: it takes no --time, "
                                 "--supplement or --window"))
    if weights is not None and (objective is None or objective.value != "mixed"):
        raise InputError(problem("command line", "--weights", "weigh time against energy of --objective mixed only"))
    from ecostudy.core import units
    from ecostudy.core.types import Timing
    from ecostudy.io.loaders import chosen_stops, load_track, load_train
    from ecostudy.io.results import file_digest
    from ecostudy.studies.cases import load_checked_study
    from ecostudy.io.writers import check_output_dir, write_json
    if study is not None:
        if track or train:
            raise InputError(problem("command line", "--track/--train",
                                     "give a study file or --track and --train, not both"))
        st = load_checked_study(study)
        st_paths = (st.track_path, st.train_path)
        trk, trn, f, t = st.track, st.train, st.from_stop, st.to_stop
        timing, obj, w, k = st.timing, st.objective, st.weights, st.points
        out_dir = Path(out) if out else st.output
        if time is not None or supplement is not None:
            timing = Timing(running_time=time, supplement=None if supplement is None else supplement * units.PERCENT)
        if points is not None:
            k = points
        if objective is not None:
            obj = objective.value
    else:
        if not (track and train):
            raise InputError(problem("command line", "--track/--train",
                                     "give a study file, or both --track and --train"))
        trk, trn = load_track(track), load_train(train)
        f, t = chosen_stops(trk, from_stop, to_stop, "command line")
        given = sum(x is not None for x in (time, supplement, window))
        obj = objective.value if objective is not None else "energy"
        if given == 0 and obj != "time" and obj != "mixed":
            raise InputError(problem("command line", "--time", "give --time, --supplement or --window "
                                     "(or --objective time for the all-out run)"))
        timing = Timing(running_time=time, supplement=None if supplement is None else supplement * units.PERCENT,
                        window=parse_pair(window, "--window", ordered=True) if window else None)
        w = parse_pair(weights, "--weights", nonnegative=True) if weights else (1.0, 1.0)
        k = points or 1000
        out_dir = Path(out) if out else Path("out") / f"{Path(track).stem}_{f}_{t}".replace(" ", "_")
    windows = st.windows if study is not None else ()
    check_output_dir(out_dir, ("profile.csv", "summary.json", "speed.png", "inputs.json"))
    from ecostudy.analysis.single import solve_run  # the optimiser only once the inputs are known good
    from ecostudy.das.methods import das_run
    from ecostudy.report.files import write_run
    result = solve_run(trk, trn, f, t, timing=timing, objective=obj, points=k, weights=w, windows=windows)
    if das is not None:
        if windows and das.value != "round":
            raise InputError(problem(str(study), "windows", f"--das {das.value} does not handle timing "
                                     "windows on the way yet; use --das round"))
        result.das = das_run(result, das.value, time_limit=das_time_limit)
        result.summary["das"] = result.das.summary
    write_run(result, out_dir, plot=not no_plot, out=figures)
    paths = (st_paths if study is not None else (Path(track), Path(train)))
    write_json(out_dir / "inputs.json", {"track": str(paths[0].resolve()), "train": str(paths[1].resolve()),
                                         "track_sha256": file_digest(paths[0]), "train_sha256": file_digest(paths[1]),
                                         "from": f, "to": t, "points": k})
    _report(result, out_dir)
    return out_dir


@app.command(short_help="Energy-optimal (or all-out) run between two stops, verified.")
def solve(
    study: Optional[Path] = typer.Argument(None, help="Study file (YAML)."),
    track: Optional[Path] = typer.Option(None, help="Track file (YAML, or TTOBench JSON)."),
    train: Optional[Path] = typer.Option(None, help="Train file (YAML, or TTOBench/OSRD JSON)."),
    time: Optional[float] = typer.Option(None, "--time", help="Running time [s]."),
    supplement: Optional[float] = typer.Option(None, help="Running-time supplement over all-out [%]."),
    window: Optional[str] = typer.Option(None, help="Arrival window 'earliest,latest' [s]."),
    from_stop: Optional[str] = typer.Option(None, "--from", help="Departure stop (default: first)."),
    to_stop: Optional[str] = typer.Option(None, "--to", help="Arrival stop (default: last)."),
    objective: Optional[Objective] = typer.Option(None, help="energy | net_energy | time | mixed."),
    weights: Optional[str] = typer.Option(None, help="Mixed objective weights 'w_t,w_e' (Yazhemsky 2017, eq. 4.1)."),
    points: Optional[int] = typer.Option(None, "--points", "-K", help="Grid nodes K (default 1000)."),
    out: Optional[Path] = typer.Option(None, help="Output folder."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the figures (speed, energy flow)."),
    fig_format: str = typer.Option("png", "--format", help="Figure format: png, svg or pdf."),
    dpi: float = typer.Option(110.0, help="Figure resolution [dots per inch] (raster images)."),
    das: Optional[DasMethod] = typer.Option(
        None, help="Also driver advice: round (nearest handle level), phases (optimal phase lengths, "
                   "Farooqi 2018, Ch. 5) or minlp (mode per phase chosen by binaries)."),
    das_time_limit: float = typer.Option(60.0, help="Time limit of the minlp search [s]."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Energy-optimal (or all-out) run between two stops, verified by re-simulation."""
    flag_folder(guarded(debug, with_force(force, _solve), study, track, train, time, supplement, window, from_stop,
                        to_stop, objective, weights, points, out, no_plot, das, das_time_limit, (fig_format, dpi)))


def _check(result_dir, time):
    check_options(time=time)
    from ecostudy.studies.check import check_result
    from ecostudy.io.writers import write_json
    result_dir = Path(result_dir)
    report = check_result(result_dir, time)
    write_json(result_dir / "check.json", report)
    typer.echo(f"checked as the {report['checked_as']}")
    typer.echo("regimes: " + ", ".join(f"{r['regime']} {r['start_m']:.0f}-{r['end_m']:.0f} m" for r in report["sequence"]))
    typer.echo(f"Pontryagin: {report['agreement_pct']:.1f} % of the distance agrees; stationarity "
               f"residual {report['stationarity_residual']:.1e}")
    for d in report["disagreements"]:
        typer.echo(f"  inconsistent: {d['regime']} at {d['start_m']:.0f}-{d['end_m']:.0f} m "
                   f"(lambda/v from {d['psi_min']:.2f} to {d['psi_max']:.2f})")
    typer.echo(f"written {result_dir}/check.json")
    return report


@app.command(short_help="Pontryagin regime check of a solved profile.")
def check(
    result_dir: Path = typer.Argument(..., help="Output folder of `ecostudy solve`."),
    time: Optional[float] = typer.Option(None, "--time", help="Test as the energy-optimal run arriving by this time [s]."),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Pontryagin regime check of a solved profile (Farooqi 2018, eq. 2.17; eq. 7.4 for net-energy runs); exit 1 below 95 % agreement."""
    report = guarded(debug, _check, result_dir, time)
    if report["agreement_pct"] < 95.0:
        raise typer.Exit(1)


def _export(result_dir, every):
    import re
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*(s|m)\s*", every or "")
    if not match or float(match.group(1)) <= 0:
        raise InputError(problem("command line", "--every", f"expected a step such as '1s' (seconds) or '10m' "
                                 f"(metres), not '{every}'"))
    from ecostudy.report.files import write_fixed_step
    step = float(match.group(1))
    table, csv, js = write_fixed_step(result_dir, *((step, None) if match.group(2) == "s" else (None, step)))
    typer.echo(f"{len(table)} rows every {every.strip()}: {csv} and {js.name}")


@app.command(short_help="A solved run every N s or N m (CSV and JSON), for on-board systems.")
def export(
    result_dir: Path = typer.Argument(..., help="Output folder of `ecostudy solve`."),
    every: str = typer.Option("1s", help="Step: seconds ('1s') or metres ('10m')."),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """The run of a solve folder at fixed steps of time or distance: position, time, speed, handle and,
    with driver advice, the advised mode (profile_every_<step>.csv and .json in the folder).

    Example: ecostudy export out/default --every 10m
    """
    guarded(debug, _export, result_dir, every)


def _doctor():

    from ecostudy import __version__
    from ecostudy.ocp import session
    import pyomo.environ as pyo
    for name, version in {"ecostudy": __version__, **session.versions()}.items():
        typer.echo(f"{name:10s} {version}")
    m = pyo.ConcreteModel()
    m.x = pyo.Var(initialize=1.0)
    m.y = pyo.Var(initialize=1.0)
    m.c = pyo.Constraint(expr=m.x**2 + m.y**2 == 1)
    m.o = pyo.Objective(expr=m.x + 2 * m.y)
    out = session.solve(m)
    ok = out.optimal and abs(pyo.value(m.o) + 5**0.5) < 1e-6
    typer.echo(f"toy NLP    {out.status} in {out.iterations} iterations, objective {pyo.value(m.o):.6f} "
               f"(expected {-(5**0.5):.6f}): {'ok' if ok else 'WRONG'}")
    return ok


@app.command(short_help="Check the install: solver chain versions and a toy solve.")
def doctor(debug: bool = typer.Option(False, help="Show tracebacks.")):
    """Check the install: versions of the solver chain and a toy NLP solved with Ipopt."""
    if not guarded(debug, _doctor):
        raise typer.Exit(3)


