"""Plots: speed against distance with limits, the gradient profile and the handle beneath; fronts,
comparisons, journeys and a run's energy flow (networks: :mod:`ecostudy.report.netplots`). Every colour comes from
:mod:`ecostudy.report.style`; every plot takes ``fmt`` (png, svg, pdf) and ``dpi``."""
import textwrap

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from ecostudy.analysis.energyflow import run_energy_flow
from ecostudy.core.status import at_stop
from ecostudy.core.units import PERMILLE, number, signed, to_kmh, to_kwh
from ecostudy.report import style

SPEED_LIMIT = "speed limit (train length)"
# names are text: a '$' in a train, track or stop name is a dollar, not the start of maths (a name
# with one failed every figure after the solve; one with two was drawn in italics)
matplotlib.rcParams["text.parse_math"] = False


def titled(ax, title, status="ok", below="", width=110, fontsize=10):
    """``title`` wrapped at ``width`` characters (a long name clipped the numbers), then ``below``,
    and for a run that is not ``ok`` a line saying so with its reason, in red, at most two lines (a
    longer reason ends in "... (whole reason: summary.json)"): a figure copied out of its folder
    still says it is not a result to quote. The axes move down to make room."""
    lines = (textwrap.wrap(title, width) or [""]) + ([below] if below else [])
    status = str(status)
    if status != "ok":
        reason = textwrap.wrap(status.upper()[:7] + status[7:], width)
        if len(reason) > 2:  # clipped, and saying so: the whole reason is in the run's files
            reason = reason[:1] + textwrap.wrap(" ".join(reason[1:]), width, max_lines=1,
                                                 placeholder=" ... (whole reason: summary.json)")
        lines += reason
    ax.set_title("\n".join(lines), fontsize=fontsize, color=style.LIMIT["title" if status == "ok" else "not ok"])
    fig = ax.figure
    room = (len(lines) * 1.3 * fontsize / 72 + 0.15) / fig.get_figheight()  # [share of the height]
    if fig.subplotpars.top > 1 - room:
        fig.subplots_adjust(top=1 - room)


def word(status):
    """ok, flagged or failed: the first word of a status line."""
    return str(status).split(":", 1)[0].strip()


def overall(statuses, noun="runs", shown=3):
    """One status line for a figure that draws several runs (``statuses``: name -> status line, of
    every run the figure is about, those it cannot draw included): ``ok`` when every one is, else
    the worst word and which are not, e.g. ``flagged: 2 of 4 runs not ok: T1 (flagged), joint
    (failed, not drawn); see summary.json``, for :func:`titled`: a figure copied out of its folder
    still says which of its runs are no result to quote. ``not drawn``: names the figure leaves out."""
    bad = [(name, word(s)) for name, s in statuses.items() if word(s) != "ok"]
    if not bad:
        return "ok"
    worst = "failed" if any(w == "failed" for _, w in bad) else "flagged"
    names = ", ".join(f"{name} ({w})" for name, w in bad[:shown]) + (f" and {len(bad) - shown} more" if len(bad) > shown else "")
    return f"{worst}: {len(bad)} of {len(statuses)} {noun} not ok: {names}; see summary.json"


def marked(label, status):
    """A legend ``label`` with the run's status word in capitals where it is not ok."""
    kind = word(status)
    return label if kind == "ok" else f"{label} ({kind.upper()})"


def figure(nrows=1, ncols=1, figsize=None, **kwargs):
    """A figure and its axes, as ``pyplot.subplots`` gives them, without pyplot: no backend and no
    global figure registry (pyplot and pylab cost about a second of start-up)."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def _steps(profile, distance):
    """x, y arrays drawing a piecewise-constant profile as steps over [0, distance]."""
    x = np.append(profile.starts, distance)
    y = np.append(profile.values, profile.values[-1])
    return x, y


def _save(fig, path, fmt=None, dpi=None):
    """Write ``fig`` to ``path`` (``style.save``: png unless ``fmt`` or the path's suffix says
    otherwise); with no path, return it (a notebook shows it)."""
    return style.save(fig, path, fmt, dpi)


def _empty(fig, ax, title, message, path, fmt, dpi):
    """A figure with nothing to draw (every run of it failed): ``title`` and ``message`` saying so, in
    red, so the figure a user opens says why it is empty instead of the command stopping on it."""
    for a in np.ravel(ax):
        a.set_axis_off()
    titled(np.ravel(ax)[0], title or "", "failed")
    np.ravel(ax)[0].text(0.5, 0.5, message, ha="center", va="center", wrap=True, color=style.LIMIT["not ok"],
                         transform=np.ravel(ax)[0].transAxes)
    return _save(fig, path, fmt, dpi)


def _speed_limit(ax, segment):
    """The speed limit of ``segment`` as steps, in the limit colour of every plot."""
    x, y = _steps(segment.limit, segment.distance)
    ax.step(x, to_kmh(y), where="post", color=style.LIMIT["speed limit"], lw=1.2, label=SPEED_LIMIT)


def _finish_speed_axes(ax, title, xlabel="distance from departure [m]", legend_size=7, status="ok"):
    """Labels, grid, legend and title of a speed-against-distance axis (the title with ``status``
    where it is not ok: :func:`titled`)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel("speed [km/h]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=legend_size, loc="lower center", ncol=2 if len(ax.get_legend_handles_labels()[1]) > 5 else 1)
    titled(ax, title, status)


def _timing_point(ax, x, low=None, high=None, label=None):
    """A timing point at ``x`` [m] on a speed axis: a dotted line (``label`` in the legend) and its
    lowest and highest speed [km/h] as short bars."""
    ax.axvline(x, color=style.LIMIT["timing point"], lw=0.8, ls=":", label=label)
    for cap in (low, high):
        if cap is not None:
            ax.plot([x - 30, x + 30], [cap, cap], color=style.LIMIT["speed limit"], lw=2)


def window_text(window, check=None):
    """What a timing ``window`` asks, and (``check``: its :func:`core.simulate.window_checks` entry)
    whether the re-simulated run kept it: ``500 m: from 40 s, at most 55 km/h: kept``."""
    asked = [f"{word} {value:g} {unit}" for word, value, unit in (
        ("from", window.earliest, "s"), ("by", window.latest, "s"),
        ("at least", None if window.min_speed is None else to_kmh(window.min_speed), "km/h"),
        ("at most", None if window.max_speed is None else to_kmh(window.max_speed), "km/h")) if value is not None]
    kept = "" if check is None else ": kept" if check["kept"] else ": MISSED"
    return f"{window.distance:g} m: {', '.join(asked)}{kept}"


def _advice_regime(row):
    """The regime name of a DAS advice row (its shading beneath the run)."""
    if not np.isfinite(row.handle):
        return "cruise"
    if row.mode in ("coast", "full service braking"):
        return row.mode
    return "traction" if row.handle > 0 else "braking"


def speed_plot(result, path=None, fmt=None, dpi=None):
    """Speed against distance of a run with its speed limit, the gradient and the handle beneath
    (and the driver advice, re-simulated, when the run has one)."""
    seg, prof, s = result.segment, result.profile, result.summary
    fig, (ax, axg, axu) = figure(3, 1, figsize=(9, 7), sharex=True,
                                       gridspec_kw={"height_ratios": [3, 1, 1], "hspace": 0.12})
    fig.subplots_adjust(left=0.08, right=0.98, top=0.95, bottom=0.07)  # tight_layout costs 40 % of the plot
    _speed_limit(ax, seg)
    checks = (s.get("verification") or {}).get("windows") or []
    for k, w in enumerate(result.windows):  # each timing point, what it asks and whether the run kept it
        _timing_point(ax, w.distance, *(None if v is None else to_kmh(v) for v in (w.min_speed, w.max_speed)),
                      label="timing point " + window_text(w, checks[k] if k < len(checks) else None))
    ax.plot(prof["position_m"], prof["speed_kmh"], color=style.colour("traction"), lw=1.6, label="optimal speed")
    if result.trace is not None:
        ax.plot(result.trace.x, to_kmh(result.trace.v), color=style.colour("re-simulated"), lw=0.8, ls="--",
                label="re-simulated")
    if result.das is not None and result.das.driven is not None:  # advice that failed: none drawn
        advice, outcome = result.das.advice, result.das.driven
        ax.plot(outcome.trace.x, to_kmh(outcome.trace.v), color=style.colour("DAS advice"), lw=1.1,
                label=f"driver advice ({s['das']['method']}), simulated")
        for row in advice.itertuples():
            regime = _advice_regime(row)
            alpha = 0.3 if regime == "cruise" else 0.15 + 0.25 * abs(row.handle)
            axu.axvspan(row.start_position_m, row.end_position_m, color=style.REGIME[regime], alpha=alpha)
    ax.set_ylabel("speed [km/h]")
    ax.set_ylim(bottom=0)
    ax.legend(loc="lower center", fontsize=8)
    titled(ax, f"{s['train']} - {s['from']} to {s['to']}: {s['running_time_s']:.1f} s, "
           f"{s['traction_energy_kWh']:.2f} kWh traction ({s['objective']})", result.status)
    x, y = _steps(seg.gradient, seg.distance)
    axg.step(x, y / PERMILLE, where="post", color=style.LIMIT["gradient"])
    axg.axhline(0, color=style.LIMIT["stop"], lw=0.5)
    axg.set_ylabel("gradient [‰]")
    axu.step(prof["position_m"], prof["handle"], where="post", color=style.colour("handle"))
    axu.set_ylim(-1.1, 1.1)
    axu.set_ylabel("handle u")
    axu.set_xlabel("distance from departure [m]")
    for a in (ax, axg, axu):
        a.grid(alpha=0.3)
    return _save(fig, path, fmt, dpi)


def front_limits(times, margin=0.03):
    """x-axis limits [s] that show a front's running times with a margin on each side."""
    lo, hi = float(np.min(times)), float(np.max(times))
    pad = margin * max(hi - lo, 1e-3 * max(abs(hi), 1.0))
    return lo - pad, hi + pad


def _point_names(table):
    """A name for each row of a front's table: its running time, else its supplement, else ``study
    time`` or its place in the table."""
    def name(k, row):
        if pd.notna(row["running_time_s"]):
            return f"{row['running_time_s']:.1f} s"
        if row.get("is_study_time") is True:
            return "study time"
        return f"+{row['supplement_pct']:.4g} %" if pd.notna(row.get("supplement_pct")) else f"row {k + 1}"
    return [name(k, row) for k, (_, row) in enumerate(table.iterrows())]


def pareto_plot(table, path=None, title="", weighted=None, fmt=None, dpi=None, runs_ok=None, names=None):
    """Traction and net energy against running time, with the marginal saving beneath, for the rows
    that have a running time (a failed point has none: named ``not drawn`` in the title, by ``names``,
    per row, default :func:`_point_names`); ``weighted`` (optional table) adds the weighted-sum points;
    the study's own running time (``is_study_time``) is a star. The time axis spans the front's
    running times: weighted points beyond them are counted in the legend, not drawn. Points not ok
    are ringed and named in the title: the ATO runs where ``runs_ok`` (per row; default: the row's
    ``status``) is False, the driver advice where ``das_status`` is not ok (ringed apart); an advice
    that has no running time (it stood off its stop) is counted in the legend, not drawn."""
    fig, (ax, axm) = figure(2, 1, figsize=(8, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    fig.subplots_adjust(left=0.13, right=0.97, top=0.85, bottom=0.09, hspace=0.1)
    if not table["running_time_s"].notna().any():
        return _empty(fig, (ax, axm), title, f"no point of the front has a running time: all {len(table)} failed "
                      "(pareto.csv's status)", path, fmt, dpi)
    has_time = table["running_time_s"].notna().to_numpy()
    bad = np.zeros(len(table), bool) if "status" not in table else \
        (table["status"].astype(str).map(word) != "ok").to_numpy() if runs_ok is None else ~np.asarray(runs_ok, bool)
    names = _point_names(table) if names is None else list(names)
    statuses = {name if has_time[k] else f"{name}, not drawn": str(table["status"].iloc[k]) if bad[k] else "ok"
                for k, name in enumerate(names)} if "status" in table else {}
    everything, table = table, table[has_time]  # a row with no running time breaks every line at it
    t = table["running_time_s"]
    ax.plot(t, table["traction_energy_kWh"], "o-", color=style.colour("traction"), label="traction (at the wheel)")
    ax.plot(t, table["net_energy_kWh"], "s--", color=style.colour("net energy"),
            label="net electrical (regeneration credited)")
    study = table[table["is_study_time"].eq(True)] if "is_study_time" in table else []
    for _, row in (study.iterrows() if len(study) else ()):
        ax.plot(row["running_time_s"], row["traction_energy_kWh"], "*", ms=16, color=style.colour("study time"),
                zorder=5, label=f"the study's running time: {row['running_time_s']:.1f} s, "
                f"{row['traction_energy_kWh']:.2f} kWh")
        ax.annotate(f"study {row['running_time_s']:.1f} s", (row["running_time_s"], row["traction_energy_kWh"]),
                    xytext=(10, 8), textcoords="offset points", fontsize=8)
    lo, hi = front_limits(t)
    if "das_traction_energy_kWh" in table and table["das_traction_energy_kWh"].notna().any():
        unplaced = int((table["das_traction_energy_kWh"].notna() & table["das_running_time_s"].isna()).sum())
        ax.plot(table["das_running_time_s"], table["das_traction_energy_kWh"], "^:", color=style.colour("DAS advice"),
                label=f"DAS {table.attrs.get('das_method', '')} (advice re-simulated, traction)"
                + (f"; {unplaced} of {len(table)} not drawn: stood off the stop, no running time "
                   "(pareto.csv das_status)" if unplaced else ""))
        lo, hi = front_limits(np.concatenate([t, table["das_running_time_s"].dropna()]))
        advice_bad = (table["das_status"].astype(str).map(word) != "ok").to_numpy() if "das_status" in table \
            else np.zeros(len(table), bool)
        if advice_bad.any():
            style.ring(ax, table["das_running_time_s"][advice_bad], table["das_traction_energy_kWh"][advice_bad],
                       f"advice not ok ({int(advice_bad.sum())} of {len(table)}: see pareto.csv's das_status)")
    if weighted is not None and len(weighted):
        wt = weighted["running_time_s"]
        inside = (wt >= lo) & (wt <= hi)
        beyond = int((~inside).sum())
        ax.plot(wt[inside], weighted["traction_energy_kWh"][inside], "x", color=style.colour("weighted sum"),
                ms=8, mew=2, label="weighted sum w_t T + w_e E/m (traction)"
                + (f"; {beyond} point{'s' * (beyond > 1)} beyond the front's times not shown" if beyond else ""))
    if bad.any():  # the points not ok ringed: a front of flagged points is no front to quote
        ring = bad[has_time]
        style.ring(ax, t[ring], table["traction_energy_kWh"][ring],
                   f"not ok ({int(bad.sum())} of {len(everything)} points"
                   + (f", {int((bad & ~has_time).sum())} not drawn" if (bad & ~has_time).any() else "")
                   + ": see pareto.csv's status)")
    ax.set_xlim(lo, hi)
    ax.set_ylabel("energy [kWh]")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    titled(ax, title, overall(statuses, "points"))
    top = ax.secondary_xaxis("top", functions=(lambda x: 100 * (x / t.iloc[0] - 1), lambda p: t.iloc[0] * (1 + p / 100)))
    top.set_xlabel("supplement over all-out [%]", fontsize=8)
    axm.plot(t, table["marginal_saving_kWh_per_s"], ".-", color=style.colour("marginal saving"))
    axm.set_ylabel("saving per\nextra second\n[kWh/s]", fontsize=8)
    axm.set_xlabel("running time [s]")
    for a in (ax, axm):
        a.grid(alpha=0.3)
    return _save(fig, path, fmt, dpi)


def profiles_plot(results, path=None, title="", fmt=None, dpi=None, statuses=None):
    """Speed against distance for a few points of a front (``studies.front.FrontPoint``), with the
    speed limit; the study's own running time named, each point not ok marked in the legend and
    named in the title. ``statuses``: {name: status line} of every point the figure is about, those
    not solved (no profile) too, which the title names ``not drawn`` (default: the points drawn)."""
    fig, ax = figure(figsize=(9, 4.5))
    fig.subplots_adjust(left=0.08, right=0.98, top=0.92, bottom=0.12)
    if not results:
        return _empty(fig, ax, title, "no point of the front was solved: no speed profile to draw (pareto.csv's "
                      "status)", path, fmt, dpi)
    _speed_limit(ax, results[0].segment)
    drawn = {}
    for r, colour in zip(results, style.sequence(len(results))):
        p, study = r.profile, getattr(r, "study_time", False)  # a FrontPoint, or a RunResult of the library
        drawn[getattr(r, "name", "") or f"{r.facts.running_time_s:.1f} s"] = str(r.status)
        ax.plot(p["position_m"], p["speed_kmh"], color=colour, lw=2.0 if study else 1.3,
                label=marked(("the study's running time: " if study else "")
                             + f"{r.facts.running_time_s:.1f} s, {r.facts.traction_energy_kWh:.2f} kWh", str(r.status)))
    _finish_speed_axes(ax, title, status=overall({name if name in drawn else f"{name}, not drawn": st
                                                  for name, st in (statuses or drawn).items()}, "points"))
    return _save(fig, path, fmt, dpi)


def compare_plot(outcomes, segment, path=None, title="", fmt=None, dpi=None, statuses=None):
    """Simulated speed against distance of each strategy, with the speed limit; each strategy in
    its own colour (``style.STRATEGY``) and the line styles cycled, so overlapping runs show; a
    strategy whose status (``statuses``, by name) is not ok says so in the legend, and a run that
    did not arrive gives the time it stood, not an arrival."""
    fig, ax = figure(figsize=(9, 4.5))
    fig.subplots_adjust(left=0.08, right=0.98, top=0.92, bottom=0.12)
    _speed_limit(ax, segment)
    palette = style.Palette([o.name for o in outcomes])
    drawn = {o.name for o in outcomes}
    for i, o in enumerate(outcomes):
        error = o.trace.stop_position - segment.distance
        when = (f"{o.trace.arrival_time:.1f} s" if at_stop(error) else
                f"stood {abs(error):.1f} m {'short of' if error < 0 else 'past'} the stop at {o.trace.arrival_time:.1f} s")
        ax.plot(o.trace.x, to_kmh(o.trace.v), lw=1.4, color=palette(o.name), ls=style.DASHES[i % len(style.DASHES)],
                label=marked(f"{o.name}: {when}, {to_kwh(o.trace.traction_energy):.2f} kWh",
                             (statuses or {}).get(o.name, "ok")))
    _finish_speed_axes(ax, title, status=overall({name if name in drawn else f"{name}, not drawn": st
                                                  for name, st in (statuses or {}).items()}, "strategies"))
    return _save(fig, path, fmt, dpi)


def journey_plot(results, path=None, title="", passing=(), fmt=None, dpi=None, statuses=None):
    """Speed against distance along the line for each distribution of the running time, every
    distribution in its own colour, with each segment's speed limit; ``passing``: (journey distance [m], highest speed [km/h] or
    None) of timing points, marked; ``statuses``: each distribution's (failed ones too, which have no
    runs to draw), marked in the legend and counted in the title."""
    fig, ax = figure(figsize=(10, 4.5))
    fig.subplots_adjust(left=0.07, right=0.98, top=0.92, bottom=0.12)
    for x, cap in passing:
        _timing_point(ax, x, high=cap)
    palette = style.Palette(list(results))
    for n, (name, runs) in enumerate(results.items()):
        offset, colour = 0.0, palette(name)
        label = marked(f"{name}: {sum(r.facts.traction_energy_kWh for r in runs):.2f} kWh", (statuses or {}).get(name, "ok"))
        for i, r in enumerate(runs):
            p = r.profile
            ax.plot(offset + p["position_m"], p["speed_kmh"], color=colour, lw=1.2,
                    ls=style.DASHES[n % len(style.DASHES)], label=label if i == 0 else None)
            offset += r.facts.distance_m
    start = 0.0
    for i, r in enumerate(next(iter(results.values()), [])):  # limits and stops: once, not per distribution
        x, y = _steps(r.segment.limit, r.segment.distance)
        ax.step(start + x, to_kmh(y), where="post", color=style.LIMIT["speed limit"], lw=1.0,
                label=SPEED_LIMIT if i == 0 else None)
        start += r.facts.distance_m
        ax.axvline(start, color=style.LIMIT["stop"], lw=0.5)
    _finish_speed_axes(ax, title, xlabel="distance along the journey [m]", legend_size=8,
                       status=overall({name if name in results else f"{name}, not drawn": st
                                       for name, st in (statuses or {}).items()}, "distributions"))
    return _save(fig, path, fmt, dpi)


def energy_plot(result, path=None, fmt=None, dpi=None):
    """A run's energy flow as a waterfall [kWh] (``analysis.energyflow``): drawn from the line,
    the losses in traction, the traction at the wheel, then what it becomes (resistance,
    potential and kinetic energy, regeneration returned, braking dissipated), and the net energy
    from the line."""
    flow, s = run_energy_flow(result), result.summary
    bars = [("drawn from the line", 0.0, flow.drawn), ("losses in traction", flow.traction, flow.traction_losses),
            ("traction at the wheel", 0.0, flow.traction)]
    level = flow.traction
    for name, value in flow.parts().items():
        level -= value
        bars.append((name, level, value))
    bars.append(("net from the line", 0.0, flow.net))
    fig, ax = figure(figsize=(9, 4.8))
    fig.subplots_adjust(left=0.09, right=0.98, top=0.88, bottom=0.25)
    for i, (name, bottom, value) in enumerate(bars):
        kwh, base = to_kwh(value), to_kwh(bottom)
        ax.bar(i, abs(kwh), bottom=min(base, base + kwh), color=style.ENERGY[name], width=0.7, label=name)
        ax.annotate(number(kwh, ".2f"), (i, max(base, base + kwh)), ha="center", va="bottom", fontsize=7,
                    xytext=(0, 2), textcoords="offset points")
    ax.axhline(0, color=style.LIMIT["stop"], lw=0.5)
    low, high = ax.get_ylim()
    ax.set_ylim(low, high + 0.08 * (high - low))  # room for the labels of the tallest bars, below the title
    ax.set_xticks(range(len(bars)), [b[0] for b in bars], rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("energy [kWh]")
    ax.grid(alpha=0.3, axis="y")
    titled(ax, f"{s['train']} - {s['from']} to {s['to']}: energy flow", result.status, fontsize=9,
           below=f"balance residual {signed(to_kwh(flow.residual), 4)} kWh "
           f"({signed(100 * flow.residual / max(flow.traction, 1e-9), 3)} % of the traction at the wheel)")
    return _save(fig, path, fmt, dpi)
