"""The files of a run (``profile.csv``, ``summary.json``, ``speed.png``, ``advice.csv``) and of a
front (``pareto.csv``, ``pareto.json``, the plots), each written atomically."""
from pathlib import Path

import numpy as np
import pandas as pd

from ecostudy.core.status import OK, Status, flagged
from ecostudy.io.folder import write_summary
from ecostudy.io.writers import atomic_write, write_csv, write_json


def write_run(result, out_dir, plot=True):
    """``profile.csv``, ``summary.json``, ``speed.png`` (and ``advice.csv``) of one run into ``out_dir``."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "profile.csv", result.profile)
    tables = {"profile": "profile.csv"}
    if result.das is not None:
        write_csv(out_dir / "advice.csv", result.das.advice)
        tables["advice"] = "advice.csv"
    if plot:
        from ecostudy.report.plots import speed_plot
        atomic_write(out_dir / "speed.png", lambda tmp: speed_plot(result, tmp))
    s = result.summary
    write_summary(out_dir, "solve", {f"{s['from']}-{s['to']}": result.status}, tables,
                  ["speed.png"] if plot else [], **s)
    stale(out_dir, advice=result.das is None, plot=not plot, names={"advice": ["advice.csv"], "plot": ["speed.png"]})
    return out_dir


def stale(out_dir, names, **drop):
    """Remove files an earlier run left that this one does not write (``names[kind]`` where
    ``drop[kind]``), so a folder never mixes the files of two runs."""
    for kind, files in names.items():
        if drop.get(kind):
            for name in files:
                (Path(out_dir) / name).unlink(missing_ok=True)


def write_front(table, results, out_dir, meta, plot=True, weighted=None):
    """``pareto.csv``, ``pareto.json`` and the two plots of a front (and ``pareto_weighted.csv``)."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "pareto.csv", table)
    if weighted is not None:
        write_csv(out_dir / "pareto_weighted.csv", weighted)
    write_json(out_dir / "pareto.json", meta)
    tables = {"pareto": "pareto.csv", **({"weighted": "pareto_weighted.csv"} if weighted is not None else {})}
    statuses = {f"{t:.2f} s": Status.parse(st) for t, st in zip(table["running_time_s"], table["status"])}
    if not meta["monotone"]:
        statuses["front"] = flagged("energy does not fall as the running time grows")
    files = ["pareto.json"] + (["pareto.png", "pareto_profiles.png"] if plot else [])
    write_summary(out_dir, "pareto", statuses, tables, files, **meta)
    if plot:

        from ecostudy.report.plots import pareto_plot, profiles_plot
        title = f"{meta['train']} - {meta['from']} to {meta['to']} (K = {meta['points']})"
        atomic_write(out_dir / "pareto.png", lambda tmp: pareto_plot(table, tmp, title, weighted))
        picks = sorted(set(np.linspace(0, len(results) - 1, min(5, len(results))).round().astype(int)))
        atomic_write(out_dir / "pareto_profiles.png",
                     lambda tmp: profiles_plot([results[i] for i in picks], tmp, title))
    stale(out_dir, weighted=weighted is None, plot=not plot,
          names={"weighted": ["pareto_weighted.csv"], "plot": ["pareto.png", "pareto_profiles.png"]})
    return out_dir


def write_compare(table, outcomes, segment, out_dir, title, plot=True):
    """``compare.csv``, ``summary.json`` and ``compare.png`` of strategies side by side."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "compare.csv", table)
    (out_dir / "compare.png").unlink(missing_ok=True)  # never a plot of an earlier run beside this table
    if plot:
        from ecostudy.report.plots import compare_plot
        atomic_write(out_dir / "compare.png", lambda tmp: compare_plot(outcomes, segment, tmp, title))
    statuses = {name: Status.parse(st) for name, st in zip(table["strategy"], table["status"])}
    write_summary(out_dir, "compare", statuses, {"compare": "compare.csv"}, ["compare.png"] if plot else [],
                  title=title, target_running_time_s=table.attrs["target_s"],
                  ato_verified=table.attrs["verified"])
    return out_dir


def write_journey(table, totals, results, out_dir, title, passing=(), plot=True):
    """``journey.csv``, ``journey_totals.csv``, ``summary.json`` and ``journey.png`` of a journey's
    distributions (every segment's run re-simulated: ``verified``)."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "journey.csv", table)
    write_csv(out_dir / "journey_totals.csv", totals)
    (out_dir / "journey.png").unlink(missing_ok=True)  # never a plot of an earlier run beside these tables
    if plot:
        from ecostudy.report.plots import journey_plot
        atomic_write(out_dir / "journey.png", lambda tmp: journey_plot(results, tmp, title, passing))
    statuses = {f"{r['distribution']} {r['from']}-{r['to']}":
                OK if r["verified"] else flagged("not verified by the re-simulation") for _, r in table.iterrows()}
    write_summary(out_dir, "journey", statuses, {"segments": "journey.csv", "totals": "journey_totals.csv"},
                  ["journey.png"] if plot else [], title=title)
    return out_dir


def write_network(run, st, out_dir, plot=True):
    """``network_substation.csv`` (per strategy, with its ``status``), ``network_trains.csv``,
    ``network_steps_<strategy>.csv``, ``network.json``, ``summary.json`` and ``network.png``.
    Returns the per-strategy table."""
    out_dir = Path(out_dir)
    fl, outcome = run.fleet, run.outcome
    base = outcome.get("independent", {}).get("totals", {}).get("substation_kWh")
    subs, trains = [], []
    failed_ = {n: r for n, r in outcome.items() if "failed" in r}
    done = {n: r for n, r in outcome.items() if "failed" not in r}
    for name, res in failed_.items():
        subs.append({"strategy": name, "status": f"failed: {res['failed']}", "wall_s": res["wall_s"],
                     "all_verified": False})
    for name, res in done.items():
        tot = res["totals"]
        subs.append({"strategy": name, **tot,
                     "saving_vs_independent_pct": None if base is None else 100 * (1 - tot["substation_kWh"] / base)})
        for train, rec in res["trains"].items():
            trains.append({"strategy": name, "train": train, **rec})
        write_csv(out_dir / f"network_steps_{name}.csv", res["steps"])
    table = pd.DataFrame(subs)
    statuses = {}
    for _, row in table.iterrows():
        st_ = Status.parse(row["status"]) if isinstance(row["status"], str) else OK
        if st_.ok and not row["all_verified"]:
            st_ = flagged("a train's run failed its re-simulation")
        statuses[row["strategy"]] = st_
    table["status"] = [str(statuses[n]) for n in table["strategy"]]
    write_csv(out_dir / "network_substation.csv", table)
    write_csv(out_dir / "network_trains.csv", pd.DataFrame(trains))
    write_json(out_dir / "network.json", {"study": st.name, "segment_times_s": [leg.running_time for leg in fl.legs[0]],
                                          "steps": fl.steps, "dt_s": st.dt,
                                          "strategies": {**{n: {**r["totals"], **r["info"]} for n, r in done.items()},
                                                         **{n: {"status": f"failed: {r['failed']}"}
                                                            for n, r in failed_.items()}}})
    (out_dir / "network.png").unlink(missing_ok=True)  # never a plot of an earlier run beside these tables
    if plot:
        from ecostudy.report.plots import network_plot
        atomic_write(out_dir / "network.png", lambda tmp: network_plot(fl, done, tmp, st.name))
    steps = [f"network_steps_{name}.csv" for name in done]
    write_summary(out_dir, "network", statuses, {"substation": "network_substation.csv", "trains": "network_trains.csv"},
                  steps + ["network.json"] + (["network.png"] if plot else []), study=st.name, steps=fl.steps,
                  dt_s=st.dt)
    return table
