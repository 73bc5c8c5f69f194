"""Plots of a closed-loop study: the speed band (5-95 %, median) of the runs per controller, the solve time of every
step against the real-time budget, and the mass estimates over distance. Each says what runs.csv says of
the runs it draws: how many are ok in each band's title, the runs not ok in the title of the others
(:func:`~ecostudy.report.plots.overall`) and marked in their legends."""
import textwrap

import numpy as np

from ecostudy.core.status import parsed
from ecostudy.core.units import to_kmh
from ecostudy.report import style
from ecostudy.report.plots import _save, _steps, figure, marked, overall, titled, word

LABELLED = 10  # draws named in the mass estimates' legend (the rest counted)


def run_statuses(table, controllers):
    """The status line of every run of ``controllers`` in ``table`` (runs.csv: status, reason) by
    ``<controller> draw <i>``: a failed run's too, which no figure draws; a run not computed yet
    (``--only``) left out."""
    table = table[table["controller"].isin(list(controllers)) & (table["status"] != "missing")]
    return parsed([f"{r.controller} draw {r.draw}" for r in table.itertuples()], table["status"], table["reason"])


def _drawn(runs):
    """The status lines of the runs drawn (their summaries' ``status``; ok where none is given)."""
    return {f"{name} draw {s.get('draw', i)}": s.get("status", "ok")
            for name, group in runs.items() for i, s in enumerate(group)}


def _of(statuses, name):
    """The statuses of controller ``name``'s runs."""
    return {k: v for k, v in statuses.items() if k.startswith(f"{name} draw ")}


def speed_percentiles(group, positions, levels=(5, 50, 95)):
    """Per position [m]: the ``levels`` percentiles of the runs' speeds [m/s] (each run's speed
    interpolated on ``positions``; a run that stopped short counts as standing beyond its stop)."""
    speeds = np.array([np.interp(positions, *_increasing(s["profile"]["x"], s["profile"]["v"]), right=0.0)
                       for s in group])
    return np.percentile(speeds, levels, axis=0)


def _increasing(x, v):
    x, v = np.asarray(x, float), np.asarray(v, float)
    keep = np.concatenate([[True], np.diff(x) > 0])
    return x[keep], v[keep]


def _reasons(statuses, name, width=110):
    """One or two lines naming the runs of controller ``name`` that are not ok with their reasons
    (``statuses``: :func:`run_statuses`), e.g. ``draw 0 flagged: stopped 16.66 m beyond the stop``;
    empty when every one is ok."""
    bad = [f"{key[len(name) + 1:]} {status}" for key, status in _of(statuses, name).items() if word(status) != "ok"]
    return "\n".join(textwrap.wrap("; ".join(bad), width, max_lines=2, placeholder=" ... (runs.csv's reason)"))


def bands(runs, segment, path, title="", dpi=None, ok=None, statuses=None):
    """Speed against distance per controller, one panel each, with the speed limit and the stop: the
    5-95 % band of the runs and their median (a single run: its profile), as far as the furthest run
    went (a run that overshot its stop shows where it stood). ``ok``: the runs ok per controller, in
    each panel's title (red where some are not: the band is not of trusted runs); ``statuses``
    (:func:`run_statuses`): the runs not ok named there with their reasons."""
    fig, axes = figure(len(runs), 1, figsize=(9, 2.6 * len(runs) + 0.6), sharex=True, squeeze=False)
    x_lim, v_lim = _steps(segment.limit, segment.distance)
    furthest = max([segment.distance] + [float(np.max(s["profile"]["x"])) for group in runs.values() for s in group
                                         if len(s["profile"]["x"])])
    positions = np.linspace(0.0, furthest, 600)
    palette = style.Palette(list(runs))
    for ax, (name, group) in zip(axes[:, 0], runs.items()):
        colour = palette(name)
        ax.step(x_lim, to_kmh(v_lim), where="post", color=style.LIMIT["speed limit"], lw=1, label="speed limit")
        ax.axvline(segment.distance, color=style.LIMIT["stop"], lw=0.8, ls=":", label="stop")
        low, median, high = to_kmh(speed_percentiles(group, positions))
        if len(group) > 1:
            ax.fill_between(positions, low, high, color=colour, alpha=0.25, lw=0, label="5-95 % of the runs")
        ax.plot(positions, median, color=colour, lw=1.0, label="median" if len(group) > 1 else "run")
        ax.set_ylabel("speed [km/h]")
        good = (ok or {}).get(name)
        why = _reasons(statuses or {}, name)
        ax.set_title(f"{name}: {len(group)} runs" + ("" if good is None else f", {good} ok (runs.csv's status)")
                     + (f"\n{why}" if why else ""), fontsize=9,
                     color=style.LIMIT["title" if (good is None or good == len(group)) and not why else "not ok"])
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower center")
    axes[-1, 0].set_xlabel("distance from departure [m]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, path, dpi=dpi)


def solve_times(runs, budgets, path, title="", dpi=None, statuses=None):
    """Solve time of every control step [ms] of every run, per controller, against its budget
    (``budgets``: controller name -> sample time [s]); ``statuses`` (:func:`run_statuses`; by
    default those of the runs drawn): the runs not ok named in the title, a controller with any
    marked in the legend."""
    statuses = _drawn(runs) if statuses is None else statuses
    fig, ax = figure(figsize=(9, 4))
    palette = style.Palette(list(runs))
    for name, group in runs.items():
        for i, s in enumerate(group):
            ms = np.asarray(s["solve_ms"])
            ax.plot(np.arange(ms.size), ms, ".", ms=1.5, color=palette(name), alpha=0.5,
                    label=marked(name, overall(_of(statuses, name))) if i == 0 else None)
    for j, budget in enumerate(sorted(set(budgets.values()), reverse=True)):
        ax.axhline(1e3 * budget, color=style.LIMIT["budget"], lw=1, ls=style.DASHES[j % len(style.DASHES)],
                   label=f"budget {1e3 * budget:g} ms ({', '.join(n for n, b in budgets.items() if b == budget)})")
    ax.set_xlabel("control step")
    ax.set_ylabel("solve time [ms]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, markerscale=6)
    titled(ax, title, overall(statuses))
    return _save(fig, path, dpi=dpi)


def mass_estimates(runs, path, title="", dpi=None, statuses=None):
    """The Kalman mass estimate over distance of every run with an estimator (solid) and its true
    mass (dotted), each draw in a colour of its own (a controller in a line style of its own), so
    that an estimate is read against its own truth; the first :data:`LABELLED` named in the legend
    (a run not ok marked). ``statuses`` (:func:`run_statuses`; by default those of the runs drawn):
    those of the estimating controllers' runs, the runs not ok named in the title."""
    estimating = [name for name, group in runs.items() if any(s.get("estimates") for s in group)]
    statuses = _drawn(runs) if statuses is None else statuses
    fig, ax = figure(figsize=(9, 4.5))
    palette, shown = style.Palette(), 0
    for k, name in enumerate(estimating):
        for i, s in enumerate(runs[name]):
            if not s.get("estimates"):
                continue
            x, e = np.asarray(s["estimates"]).T
            draw = s.get("draw", i)
            colour = palette(f"draw {draw}")  # a draw is one plant, its colour the same in every controller
            label = marked(f"{name}, draw {draw}: true {s['true_mass_factor']:.3f}", s.get("status", "ok"))
            ax.plot(x, e, color=colour, lw=0.9, ls=style.DASHES[k % 3], label=label if shown < LABELLED else None)
            ax.plot([x[0], x[-1]], [s["true_mass_factor"]] * 2, color=colour, lw=0.8, ls=":")
            shown += 1
    if shown > LABELLED:
        ax.plot([], [], " ", label=f"and {shown - LABELLED} more runs")
    ax.set_xlabel("distance from departure [m]")
    ax.set_ylabel("mass / model mass")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2 if shown > 5 else 1)
    titled(ax, (f"{title}: " if title else "") + "estimate (solid) and true mass (dotted), each draw in its own colour",
           overall({k: v for name in estimating for k, v in _of(statuses, name).items()}))
    return _save(fig, path, dpi=dpi)


FIGURES = ("bands", "solve_times", "mass_estimates")  # the figures of draw, by stem (the last where a mass is estimated)


def draw(outcome, out=style.Output()):
    """The plots of a closed-loop study (``studies.closedloop.LoopStudy``) into its output folder,
    in the format and resolution of ``out`` (:class:`~ecostudy.report.style.Output`); returns the
    file names written."""
    runs, name, folder = outcome.by_controller, outcome.name, outcome.output
    if not runs:
        return []
    names = list(out.filenames(FIGURES))
    ok = {c: int((g["status"] == "ok").sum()) for c, g in outcome.runs.groupby("controller")}
    statuses = run_statuses(outcome.runs, runs)
    bands(runs, outcome.segment, folder / names[0], title=name, dpi=out.dpi, ok=ok, statuses=statuses)
    solve_times(runs, outcome.budgets, folder / names[1], title=name, dpi=out.dpi, statuses=statuses)
    if not any(s.get("estimates") for group in runs.values() for s in group):
        return names[:2]
    mass_estimates(runs, folder / names[2], title=name, dpi=out.dpi, statuses=statuses)
    return names
