"""Plots of a calibration (the replayed speed against the logged one, and the residuals) and of a
validation (logged and model traction energy and running time per run). Each says what its folder's
summary.json says: the calibration's status, the runs of a validation not ok, in the figure's title
(in red where not ok) and, for a validation, beneath each run."""
import numpy as np

from ecostudy.core.status import parsed
from ecostudy.core.units import to_kmh
from ecostudy.report.plots import _save, figure, marked, overall, titled

CHARACTERS_PER_INCH = 12  # a title's wrapping width per inch of the figure (10 pt text)


class _Whole:
    """A figure of several panels as :func:`~ecostudy.report.plots.titled` sees an axes: its title
    is the figure's own (``suptitle``), over every panel."""

    def __init__(self, fig):
        self.figure = fig

    def set_title(self, text, fontsize, color):
        self.figure.suptitle(text, fontsize=fontsize, color=color)


def _titled(fig, title, status):
    """``title`` over the whole figure, and ``status`` beneath it where it is not ok (in red), wrapped
    to the figure's width; then the panels laid out below them."""
    titled(_Whole(fig), title, status, width=int(CHARACTERS_PER_INCH * fig.get_figwidth()))
    fig.tight_layout()


def residuals(table, path, title="", fmt=None, dpi=None, status="ok"):
    """Per run: logged and replayed speed over time, and the residual (replayed minus logged); the
    calibration's ``status`` (summary.json's) under the title where it is not ok."""
    groups = list(table.groupby(["log", "run"], sort=False))
    fig, axes = figure(2, len(groups), figsize=(3.6 * len(groups) + 1.0, 5.2), squeeze=False, sharey="row")
    for k, ((log, run), g) in enumerate(groups):
        top, bottom = axes[0, k], axes[1, k]
        t = g["time_s"].to_numpy() - g["time_s"].iloc[0]
        top.plot(t, to_kmh(g["speed_mps"].to_numpy()), color="0.6", lw=0.6, label="logged")
        top.plot(t, to_kmh(g["model_speed_mps"].to_numpy()), color="C0", lw=1.0, label="replayed")
        top.set_title(f"{log}, run {run}", fontsize=8)
        used = g["used"].to_numpy()
        bottom.plot(t[used], g["residual_mps"].to_numpy()[used], color="C3", lw=0.5)
        bottom.axhline(0.0, color="0.3", lw=0.6)
        bottom.set_xlabel("time from departure [s]")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("speed [km/h]")
    axes[1, 0].set_ylabel("replayed - logged [m/s]")
    axes[0, 0].legend(fontsize=7)
    _titled(fig, title, status)
    return _save(fig, path, fmt, dpi)


def validation(table, path, title="", fmt=None, dpi=None):
    """Logged and model traction energy, and logged and model running time, per run; a run not ok
    (``table``'s status and reason, validate.csv's) marked beneath its bars and named in the title."""
    fig, (left, right) = figure(1, 2, figsize=(9, 3.4))
    x = np.arange(len(table))
    statuses = parsed([f"{r.log} run {r.run}" for r in table.itertuples()], table["status"], table["reason"])
    labels = [marked(f"{r.log}\nrun {r.run}", status) for r, status in zip(table.itertuples(), statuses.values())]
    for ax, (logged, model, unit) in ((left, ("logged_traction_kWh", "model_traction_kWh", "traction energy [kWh]")),
                                      (right, ("logged_time_s", "model_time_s", "running time [s]"))):
        ax.bar(x - 0.2, table[logged], 0.4, label="logged", color="0.6")
        ax.bar(x + 0.2, table[model], 0.4, label="model", color="C0")
        ax.set_xticks(x, labels, fontsize=7)
        ax.set_ylabel(unit)
        ax.grid(alpha=0.3, axis="y")
    left.legend(fontsize=7)
    left.set_title("following the logged speed", fontsize=8)
    right.set_title("driven by the logged handle", fontsize=8)
    _titled(fig, title, overall(statuses))
    return _save(fig, path, fmt, dpi)
