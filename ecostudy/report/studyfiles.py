"""The files of a study kind beyond its table and ``summary.json``: each a ``draw`` of the study
engine (:func:`ecostudy.studies.batch.run_expanded`, a :class:`~ecostudy.studies.batch.Draw`),
called with the output folder, the cases, the stored rows and the table; it writes its files
atomically and returns (file names, {table name: file name}); its ``names(cases)`` are the files it
will write, figures in the format asked, checked in the output folder before any case is computed."""
import time
from pathlib import Path

import pandas as pd

from ecostudy.core.status import Status
from ecostudy.io.writers import write_csv, write_json
from ecostudy.report import style
from ecostudy.report.files import figures, later, stale
from ecostudy.studies import compare, front, network
from ecostudy.studies.batch import Draw

COMPARE_FIGURE = "compare"  # the figure of compare_figures
NETWORK_FIGURES = ("network", "network_supply")  # of network_files, by stem
FRONT_FIGURES = ("pareto", "pareto_profiles")  # of front_files, by stem


def compare_figures(plot=True, out=style.Output()):
    """The study engine's ``draw`` (:func:`ecostudy.studies.batch.run_expanded`) of a comparison:
    ``compare.<format>``, every stored strategy's simulated speed (none with ``plot`` False: an
    earlier figure is removed)."""
    def draw(out_dir, cases, rows, table):
        drawings = {COMPARE_FIGURE: later("compare_plot", compare.outcomes(cases, rows), compare.segment_of(cases[0]),
                                         title=table.attrs["title"],
                                         statuses=dict(zip(table["strategy"], table["status"]))) if plot else None}
        return figures(out_dir, plot, drawings, out), {}
    return Draw(draw, lambda cases: out.filenames([COMPARE_FIGURE], plot))


def network_files(plot=True, out=style.Output()):
    """The study engine's ``draw`` (:func:`ecostudy.studies.batch.run_expanded`) of a network study:
    ``network_trains.csv``, ``network_steps_<strategy>.csv``, ``network.json``, ``network.<format>`` and
    ``network_supply.<format>`` from the stored strategies (``studies.network.outcomes``; no figure when
    every strategy failed)."""
    def draw(out_dir, cases, rows, table):
        out_dir, fl, study = Path(out_dir), cases[0]["fleet"], cases[0]["study"]
        outcome = network.outcomes(cases, rows)
        done = {n: r for n, r in outcome.items() if "failed" not in r}
        trains = [{"strategy": name, "train": train, **rec} for name, res in done.items()
                  for train, rec in res["trains"].items()]
        for name, res in done.items():
            write_csv(out_dir / f"network_steps_{name}.csv", res["steps"])
        # with its header also when every strategy failed: an empty file is no table to read back
        write_csv(out_dir / "network_trains.csv", pd.DataFrame(trains, columns=None if trains else ["strategy", "train"]))
        write_json(out_dir / "network.json", {
            "study": study, "segment_times_s": [leg.running_time for leg in fl.legs[0]], "steps_count": fl.steps,
            "dt_s": fl.dt, "strategies": {n: {**r["totals"], **r["info"]} if n in done else
                                          {"status": f"failed: {r['failed']}"} for n, r in outcome.items()}})
        # no strategy to draw when every one failed: no figures (an earlier run's removed)
        statuses = {n: r["totals"]["status"] if n in done else f"failed: {r['failed']}" for n, r in outcome.items()}
        drawn = figures(out_dir, plot and bool(done), dict(zip(NETWORK_FIGURES, (
            later("network_plot", fl, done, title=study, statuses=statuses),
            later("supply_plot", fl, done, title=study, statuses=statuses)))), out)
        return [f"network_steps_{name}.csv" for name in done] + ["network.json"] + drawn, {"trains": "network_trains.csv"}

    def names(cases):
        return ("network_trains.csv", "network.json", *(f"network_steps_{c['strategy']}.csv" for c in cases),
                *out.filenames(NETWORK_FIGURES, plot))
    return Draw(draw, names)


def front_files(plot=True, out=style.Output(), weighted=None, workers=1, started=None):
    """The study engine's ``draw`` (:func:`ecostudy.studies.batch.run_expanded`) of a Pareto front:
    ``pareto.json`` (the table's facts, ``workers`` and the wall seconds since ``started``),
    ``pareto_weighted.csv`` (the ``weighted`` points, if any), ``pareto.<format>`` and
    ``pareto_profiles.<format>`` (five stored points' speed profiles, and the study's own running time's)."""
    started = time.perf_counter() if started is None else started

    def draw(out_dir, cases, rows, table):
        out_dir = Path(out_dir)
        meta = {**table.attrs, "workers": workers, "wall_s": time.perf_counter() - started}
        if weighted is not None:
            write_csv(out_dir / "pareto_weighted.csv", weighted)
        write_json(out_dir / "pareto.json", meta)
        stale(out_dir, weighted=weighted is None, names={"weighted": ["pareto_weighted.csv"]})
        title = f"{meta['train']} - {meta['from']} to {meta['to']} (K = {meta['points']})"
        drawn = figures(out_dir, plot, front_drawings(cases, rows, table, title, weighted), out)
        return ["pareto.json", *drawn], {"weighted": "pareto_weighted.csv"} if weighted is not None else {}
    return Draw(draw, lambda cases: ("pareto.json", *(["pareto_weighted.csv"] if weighted is not None else []),
                                     *out.filenames(FRONT_FIGURES, plot)))


def front_drawings(cases, rows, table, title, weighted=None):
    """{stem: draw(path, ...)} of a front's figures (:data:`FRONT_FIGURES`): every point of the
    table, those not solved named in the title, and the profiles of :func:`studies.front.profile_picks`
    with the status of each pick, solved or not."""
    picks = front.profile_picks(cases)
    return dict(zip(FRONT_FIGURES, (
        later("pareto_plot", table, title=title, weighted=weighted, runs_ok=runs_ok(table),
              names=[cases[i]["name"] for i in table.index]),
        later("profiles_plot", front.front_points(cases, rows, picks), title=title,
              statuses=front.pick_statuses(cases, rows, picks)))))


def runs_ok(table):
    """Per row of a front's table, whether its ATO run is ok (``studies.front.own_status``: not ok
    only by its driver advice, the figure rings the advice, not the run)."""
    das = "das_method" in table
    return [front.own_status(Status.parse(str(row["status"])), row if das and pd.notna(row["das_method"]) else None).ok
            for _, row in table.iterrows()]
