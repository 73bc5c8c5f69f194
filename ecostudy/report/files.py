"""The files of a run (``profile.csv``, ``summary.json``, ``speed.png``, ``advice.csv``) and of a
front (``pareto.csv``, ``pareto.json``, the plots), each written atomically."""
from pathlib import Path

import numpy as np

from ecostudy.io.writers import atomic_write, write_csv, write_json


def write_run(result, out_dir, plot=True):
    """``profile.csv``, ``summary.json``, ``speed.png`` (and ``advice.csv``) of one run into ``out_dir``."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "profile.csv", result.profile)
    write_json(out_dir / "summary.json", result.summary)
    if result.das is not None:
        write_csv(out_dir / "advice.csv", result.das.advice)
    if plot:
        from ecostudy.report.plots import speed_plot
        atomic_write(out_dir / "speed.png", lambda tmp: speed_plot(result, tmp))
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
