"""Plots of a heavy-haul study: speed tracking against the reference, the in-train forces along the
train over distance (a heat map per run), and the K_b trade-off (largest in-train force and energy).
Each says what runs.csv says of the runs it draws: a run's status in its forces' title, the runs not
ok in the tracking figure's title and legend, ringed in the trade-off."""
import numpy as np

from ecostudy.core.status import parsed
from ecostudy.core.units import to_kmh
from ecostudy.report import style
from ecostudy.report.plots import _save, _speed_limit, figure, marked, overall, titled


def _label(case):
    return case["scenario"]


def statuses(outcome):
    """Every run's status line by its label (``Kb=1 f=10 Np=4 Nc=2``), from runs.csv's status and
    reason: a failed run's too, which no figure draws."""
    return parsed(map(_label, outcome.cases), outcome.runs["status"], outcome.runs["reason"])


def tracking(outcome, path, dpi=None):
    """Mean speed of every run, the reference speed and the line's limit for the train's length
    (what the fastest car is held to, at the head's position) against the head's position; the runs
    not ok named in the title (:func:`~ecostudy.report.plots.overall`) and marked in the legend."""
    fig, ax = figure(figsize=(10, 4.5))
    ref, status = outcome.reference, statuses(outcome)
    _speed_limit(ax, outcome.cases[0]["plan"].segment)
    given = outcome.study.reference.table is not None  # a user's speed-distance table, or the single-mass optimum
    ax.plot(ref.distance, to_kmh(ref.speeds), color=style.colour("reference"), lw=1.2,
            label="reference (the study's table)" if given else "reference (single-mass optimum)")
    palette = style.Palette()  # a colour per run, none the reference's black
    for i, case in enumerate(outcome.cases):
        p = outcome.summaries[case["key"]].get("profile")
        if p:
            ax.plot(p["head_m"], to_kmh(np.asarray(p["speed_mps"])), lw=0.8, color=palette(_label(case)),
                    ls=style.DASHES[i % len(style.DASHES)], label=marked(_label(case), status[_label(case)]))
    ax.set_xlabel("head position from departure [m]")
    ax.set_ylabel("mean speed of the cars [km/h]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    titled(ax, f"{outcome.study.name}: speed tracking", overall(status))
    return _save(fig, path, dpi=dpi)


def forces(case, summary, path, dpi=None, status="ok"):
    """In-train force of the couplers (rows: along the train) at every sample (columns: the head's
    position), tension positive; the run's ``status`` in the title where it is not ok."""
    f = np.asarray(summary["forces_kN"], float).T
    head = np.asarray(summary["profile"]["head_m"])
    limit = max(np.abs(f).max(), 1.0)
    fig, ax = figure(figsize=(10, 4))
    mesh = ax.pcolormesh(head, np.arange(f.shape[0]) * summary["coupler_step"] + 1, f, cmap=style.DIVERGING,
                         vmin=-limit, vmax=limit, shading="nearest")
    fig.colorbar(mesh, ax=ax, label="in-train force [kN] (tension +)")
    ax.set_xlabel("head position from departure [m]")
    ax.set_ylabel("coupler (1: behind the head car)")
    ax.invert_yaxis()
    titled(ax, f"{_label(case)}: largest |f_in| {summary['force_max_kN']:.0f} kN", status)
    return _save(fig, path, dpi=dpi)


def trade_off(runs, path, title="", dpi=None):
    """Largest in-train force (whole run, and while a car brakes) and energy (total, wagons) against
    K_b, one line per (f, Np, Nc)."""
    fig, (a, b) = figure(1, 2, figsize=(10, 4))
    ok = runs[runs["status"].isin(["ok", "flagged"])]
    palette = style.Palette()  # every curve in a colour of its own; whole run / total solid, the part dashed
    for (f, n_p, n_c), group in ok.groupby(["f", "Np", "Nc"]):
        group = group.sort_values("K_b")
        label = f"f={f} Np={n_p} Nc={n_c}"
        for ax, column, drawn, part in ((a, "force_max_kN", "o-", " whole run"),
                                         (a, "force_max_braking_kN", "s--", " while braking"),
                                         (b, "energy_total_kWh", "o-", " total"), (b, "wagon_brake_kWh", "s--", " wagons")):
            ax.plot(group["K_b"], group[column], drawn, color=palette(label + part), label=label + part)
    bad = ok[ok["status"] != "ok"]  # flagged runs ringed: a trade-off of runs not ok is no result to quote
    for ax, column in ((a, "force_max_kN"), (a, "force_max_braking_kN"), (b, "energy_total_kWh"), (b, "wagon_brake_kWh")):
        if len(bad):
            style.ring(ax, bad["K_b"], bad[column], None if column in ("force_max_braking_kN", "wagon_brake_kWh")
                       else f"flagged ({len(bad)} of {len(runs)} runs: see runs.csv's status)")
    a.set_ylabel("largest |in-train force| [kN]")
    b.set_ylabel("energy int |u v| dt [kWh]")
    for ax in (a, b):
        ax.set_ylim(bottom=0)
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.set_xlabel("brake penalty K_b")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, path, dpi=dpi)


def forces_stem(case):
    """The stem of a run's in-train force figure (``forces_K_b0p5_f1_Np20_Nc5``)."""
    return "forces_" + "_".join(f"{k}{v:g}" for k, v in case["labels"].items()).replace(".", "p")


def names(cases, out=style.Output()):
    """The figures :func:`draw` may write for ``cases`` in the format of ``out`` (a run's forces if
    it ran, the trade-off where K_b varies), known before any run: the output folder's check."""
    trade_off = ["brake_penalty"] if len({c["labels"]["K_b"] for c in cases}) > 1 else []
    return out.filenames(["tracking", *map(forces_stem, cases), *trade_off])


def draw(outcome, out=style.Output()):
    """The plots of a heavy-haul study (``studies.heavyhaul.HeavyhaulStudy``) into its output folder,
    in the format and resolution of ``out`` (:class:`~ecostudy.report.style.Output`); returns the
    file names written."""
    written = []
    if not any(outcome.summaries.values()):
        return written
    written.append(out.filename("tracking"))
    tracking(outcome, outcome.output / written[-1], dpi=out.dpi)
    status = statuses(outcome)
    for case in outcome.cases:
        summary = outcome.summaries[case["key"]]
        if summary:
            name = out.filename(forces_stem(case))
            forces(case, summary, outcome.output / name, dpi=out.dpi, status=status[_label(case)])
            written.append(name)
    if outcome.runs["K_b"].nunique() > 1:
        written.append(out.filename("brake_penalty"))
        trade_off(outcome.runs, outcome.output / written[-1], outcome.study.name, dpi=out.dpi)
    return written
