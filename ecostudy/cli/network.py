"""`ecostudy network STUDY.yaml`: trains on one line and one DC substation (registered on ``cli.app``).

Like ``cli/solve.py`` it only parses options, calls the library and prints; errors become one line.
"""
from pathlib import Path
from typing import Optional

import typer

from ecostudy.cli.app import FORCE_HELP, app, guarded, with_force


def _network(study_path, out, no_plot, workers=1):
    from contextlib import nullcontext

    from ecostudy.io.loaders import load_network_study
    from ecostudy.io.writers import atomic_write, check_output_dir, write_csv, write_json
    from ecostudy.network import fleet, strategies
    from ecostudy.studies.workers import worker_pool
    import pandas as pd
    st = load_network_study(study_path)
    from ecostudy.studies.estimate import check_network
    check_network(st, study_path)  # legs too big for a run refused with their estimate (unless --force)
    out_dir = check_output_dir(Path(out) if out else st.output)
    with worker_pool(workers) if workers > 1 else nullcontext() as pool:
        fl = fleet.plan(st.track, st.train, st.stops, st.running_times, st.dwell, st.offsets, st.names, st.dt,
                        st.supply, st.points, st.buffer, pool, st.supplement)
        typer.echo(f"{len(st.names)} trains, {len(st.stops) - 1} segments ({', '.join(f'{t:.1f}' for t in fl.asked_times)} s "
                   f"before rounding to {st.dt} s steps), {fl.steps} steps")
        outcome = strategies.run_strategies(fl, st.strategies, progress=typer.echo, pool=pool, workers=workers)
    base = outcome.get("independent", {}).get("totals", {}).get("substation_kWh")
    subs, trains = [], []
    failed = {n: r for n, r in outcome.items() if "failed" in r}
    outcome = {n: r for n, r in outcome.items() if "failed" not in r}
    for name, res in failed.items():
        subs.append({"strategy": name, "status": f"failed: {res['failed']}", "wall_s": res["wall_s"],
                     "all_verified": False})
    for name, res in outcome.items():
        tot = res["totals"]
        subs.append({"strategy": name, **{k: v for k, v in tot.items()},
                     "saving_vs_independent_pct": None if base is None else 100 * (1 - tot["substation_kWh"] / base)})
        for train, rec in res["trains"].items():
            trains.append({"strategy": name, "train": train, **rec})
        write_csv(out_dir / f"network_steps_{name}.csv", res["steps"])
    table = pd.DataFrame(subs)
    write_csv(out_dir / "network_substation.csv", table)
    write_csv(out_dir / "network_trains.csv", pd.DataFrame(trains))
    write_json(out_dir / "network.json", {"study": st.name, "segment_times_s": [leg.running_time for leg in fl.legs[0]],
                                          "steps": fl.steps, "dt_s": st.dt,
                                          "strategies": {**{n: {**r["totals"], **r["info"]} for n, r in outcome.items()},
                                                         **{n: {"status": f"failed: {r['failed']}"} for n, r in failed.items()}}})
    (out_dir / "network.png").unlink(missing_ok=True)  # never a plot of an earlier run beside these tables
    if not no_plot:
        from ecostudy.report.plots import network_plot
        atomic_write(out_dir / "network.png", lambda tmp: network_plot(fl, outcome, tmp, st.name))
    cols = ["strategy", "status", "substation_kWh", "saving_vs_independent_pct", "traction_input_kWh", "regen_used_kWh",
            "regen_lost_kWh", "line_losses_kWh", "unserved_kWh", "balance_error_pct", "min_separation_m",
            "all_verified"]
    typer.echo(table[[c for c in cols if c in table]].to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    typer.echo(f"outputs {out_dir}/ (network_substation.csv, network_trains.csv, network_steps_*.csv, network.json"
               + ("" if no_plot else ", network.png") + ")")
    return table


@app.command()
def network(
    study: Path = typer.Argument(..., help="Network study file (YAML)."),
    out: Optional[Path] = typer.Option(None, help="Output folder (default: the study's output)."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip network.png."),
    workers: int = typer.Option(1, min=1, help="Processes: the segments' first runs, then the strategies in "
                                "parallel (at least twice as many as workers), else one train's legs."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    debug: bool = typer.Option(False, help="Show tracebacks."),
):
    """Trains sharing one DC substation: independent, rules 7.7 / 7.11, dissension, joint optimum, following."""
    table = guarded(debug, with_force(force, _network), study, out, no_plot, workers)
    if not bool(table["all_verified"].all()) or not bool((table["status"] == "ok").all()):
        typer.secho("flagged: a strategy failed, its runs failed re-simulation, or its status says why (traction not "
                    "served, trains overlapping)",
                    fg=typer.colors.YELLOW, err=True)
        raise typer.Exit(1)
