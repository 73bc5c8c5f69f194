"""Plots of a closed-loop study: the speed band of all runs per controller, the solve time of every
step against the real-time budget, and the mass estimates over distance."""
import numpy as np

from ecostudy.core.units import to_kmh
from ecostudy.report.plots import _save, figure, _steps


def bands(runs, segment, path, title=""):
    """Speed against distance of every run, one panel per controller, with the speed limit."""
    fig, axes = figure(len(runs), 1, figsize=(9, 2.6 * len(runs) + 0.6), sharex=True, squeeze=False)
    x_lim, v_lim = _steps(segment.limit, segment.distance)
    for ax, (name, group) in zip(axes[:, 0], runs.items()):
        ax.step(x_lim, to_kmh(v_lim), where="post", color="0.4", lw=1, label="speed limit")
        for i, s in enumerate(group):
            ax.plot(s["profile"]["x"], to_kmh(np.asarray(s["profile"]["v"])), color="C0", lw=0.7,
                    alpha=max(0.08, 1.0 / len(group)), label="runs" if i == 0 else None)
        ax.set_ylabel("speed [km/h]")
        ax.set_title(f"{name}: {len(group)} runs", fontsize=9)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower center")
    axes[-1, 0].set_xlabel("distance from departure [m]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def solve_times(runs, budgets, path, title=""):
    """Solve time of every control step [ms] of every run, per controller, against its budget
    (``budgets``: controller name -> sample time [s])."""
    fig, ax = figure(figsize=(9, 4))
    for c, (name, group) in enumerate(runs.items()):
        for i, s in enumerate(group):
            ms = np.asarray(s["solve_ms"])
            ax.plot(np.arange(ms.size), ms, ".", ms=1.5, color=f"C{c}", alpha=0.5, label=name if i == 0 else None)
    for budget in sorted(set(budgets.values())):
        ax.axhline(1e3 * budget, color="r", lw=1, ls="-" if budget == max(budgets.values()) else "--",
                   label=f"budget {1e3 * budget:g} ms ({', '.join(n for n, b in budgets.items() if b == budget)})")
    ax.set_xlabel("control step")
    ax.set_ylabel("solve time [ms]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, markerscale=6)
    ax.set_title(title, fontsize=10)
    return _save(fig, path)


def mass_estimates(runs, path, title=""):
    """The Kalman mass estimate over distance of every run with an estimator, and its true mass."""
    fig, ax = figure(figsize=(9, 4))
    for c, (name, group) in enumerate(runs.items()):
        for i, s in enumerate(group):
            if not s.get("estimates"):
                continue
            x, e = np.asarray(s["estimates"]).T
            ax.plot(x, e, color=f"C{c}", lw=0.8, alpha=0.6, label=name if i == 0 else None)
            ax.plot([x[0], x[-1]], [s["true_mass"]] * 2, color=f"C{c}", lw=0.5, ls=":")
    ax.set_xlabel("distance from departure [m]")
    ax.set_ylabel("mass / model mass")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(title + " (dotted: true mass)", fontsize=10)
    return _save(fig, path)


def draw(outcome):
    """The plots of a closed-loop study (``studies.closedloop.LoopStudy``) into its output folder."""
    runs, name, out = outcome.by_controller, outcome.study.name, outcome.output
    if not runs:
        return
    bands(runs, outcome.segment, out / "bands.png", title=name)
    solve_times(runs, outcome.budgets, out / "solve_times.png", title=name)
    if any(s.get("estimates") for group in runs.values() for s in group):
        mass_estimates(runs, out / "mass_estimates.png", title=name)
