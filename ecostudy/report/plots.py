"""Plots: speed against distance with limits, the gradient profile and the handle beneath."""
import matplotlib
import numpy as np
from matplotlib.figure import Figure

from ecostudy.core.units import PERMILLE, to_kmh, to_kwh


def figure(nrows=1, ncols=1, figsize=None, **kwargs):
    """A figure and its axes, as ``pyplot.subplots`` gives them, without pyplot: no backend and no
    global figure registry (pyplot and pylab cost about a second of start-up; issue 15)."""
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kwargs)


def _steps(profile, distance):
    """x, y arrays drawing a piecewise-constant profile as steps over [0, distance]."""
    x = np.append(profile.starts, distance)
    y = np.append(profile.values, profile.values[-1])
    return x, y


def _save(fig, path):
    """Write ``fig`` as PNG to ``path`` and close it; with no path, return it (a notebook shows it)."""
    if path is None:
        return fig
    fig.savefig(path, dpi=110, format="png")
    return None


def _finish_speed_axes(fig, ax, path, title, xlabel="distance from departure [m]", legend_size=7):
    """Labels, grid, legend and title of a speed-against-distance axis; save and close (or return)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel("speed [km/h]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=legend_size, loc="lower center", ncol=2 if len(ax.get_lines()) > 5 else 1)
    ax.set_title(title, fontsize=10)
    return _save(fig, path)


def speed_plot(result, path):
    seg, prof, s = result.segment, result.profile, result.summary
    fig, (ax, axg, axu) = figure(3, 1, figsize=(9, 7), sharex=True,
                                       gridspec_kw={"height_ratios": [3, 1, 1], "hspace": 0.12})
    fig.subplots_adjust(left=0.08, right=0.98, top=0.95, bottom=0.07)  # tight_layout costs 40 % of the plot
    x, y = _steps(seg.limit, seg.distance)
    ax.step(x, to_kmh(y), where="post", color="tab:red", lw=1.2, label="speed limit (train length)")
    ax.plot(prof["position_m"], prof["speed_kmh"], color="tab:blue", lw=1.6, label="optimal speed")
    if result.trace is not None:
        ax.plot(result.trace.x, to_kmh(result.trace.v), color="k", lw=0.8, ls="--", label="re-simulated")
    if result.das is not None:
        advice, outcome = result.das.advice, result.das.driven
        ax.plot(outcome.trace.x, to_kmh(outcome.trace.v), color="tab:orange", lw=1.1,
                label=f"driver advice ({s['das']['method']}), simulated")
        colours = {"coast": "tab:gray", "full service braking": "tab:red"}
        for row in advice.itertuples():
            cruise = not np.isfinite(row.handle)
            colour = "tab:blue" if cruise else colours.get(row.mode, "tab:green" if row.handle > 0 else "tab:pink")
            alpha = 0.3 if cruise else 0.15 + 0.25 * abs(row.handle)
            axu.axvspan(row.start_position_m, row.end_position_m, color=colour, alpha=alpha)
    ax.set_ylabel("speed [km/h]")
    ax.set_ylim(bottom=0)
    ax.legend(loc="lower center", fontsize=8)
    ax.set_title(f"{s['train']} - {s['from']} to {s['to']}: {s['running_time_s']:.1f} s, "
                 f"{s['traction_energy_kWh']:.2f} kWh traction ({s['objective']})", fontsize=10)
    x, y = _steps(seg.gradient, seg.distance)
    axg.step(x, y / PERMILLE, where="post", color="tab:brown")
    axg.axhline(0, color="grey", lw=0.5)
    axg.set_ylabel("gradient [‰]")
    axu.step(prof["position_m"], prof["handle"], where="post", color="tab:green")
    axu.set_ylim(-1.1, 1.1)
    axu.set_ylabel("handle u")
    axu.set_xlabel("distance from departure [m]")
    for a in (ax, axg, axu):
        a.grid(alpha=0.3)
    return _save(fig, path)


def pareto_plot(table, path, title="", weighted=None):
    """Traction and net energy against running time, with the marginal saving beneath;
    ``weighted`` (optional table) adds the weighted-sum points."""
    fig, (ax, axm) = figure(2, 1, figsize=(8, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    fig.subplots_adjust(left=0.13, right=0.97, top=0.85, bottom=0.09, hspace=0.1)
    fig.suptitle(title, fontsize=10)
    t = table["running_time_s"]
    ax.plot(t, table["traction_energy_kWh"], "o-", color="tab:blue", label="traction (at the wheel)")
    ax.plot(t, table["net_energy_kWh"], "s--", color="tab:green", label="net electrical (regeneration credited)")
    if "das_traction_energy_kWh" in table and table["das_traction_energy_kWh"].notna().any():
        ax.plot(table["das_running_time_s"], table["das_traction_energy_kWh"], "^:", color="tab:orange",
                label=f"DAS {table.attrs.get('das_method', '')} (advice re-simulated, traction)")
    if weighted is not None and len(weighted):
        ax.plot(weighted["running_time_s"], weighted["traction_energy_kWh"], "x", color="tab:red", ms=8, mew=2,
                label="weighted sum w_t T + w_e E/m (traction)")
    ax.set_ylabel("energy [kWh]")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8)
    top = ax.secondary_xaxis("top", functions=(lambda x: 100 * (x / t.iloc[0] - 1), lambda p: t.iloc[0] * (1 + p / 100)))
    top.set_xlabel("supplement over all-out [%]", fontsize=8)
    axm.plot(t, table["marginal_saving_kWh_per_s"], ".-", color="tab:red")
    axm.set_ylabel("saving per\nextra second\n[kWh/s]", fontsize=8)
    axm.set_xlabel("running time [s]")
    for a in (ax, axm):
        a.grid(alpha=0.3)
    return _save(fig, path)


def profiles_plot(results, path, title=""):
    """Speed against distance for a few points of a front, with the speed limit."""
    fig, ax = figure(figsize=(9, 4.5))
    fig.subplots_adjust(left=0.08, right=0.98, top=0.92, bottom=0.12)
    seg = results[0].segment
    x, y = _steps(seg.limit, seg.distance)
    ax.step(x, to_kmh(y), where="post", color="tab:red", lw=1.2, label="speed limit (train length)")
    for r, colour in zip(results, matplotlib.colormaps["viridis"](np.linspace(0, 0.9, len(results)))):
        p = r.profile
        ax.plot(p["position_m"], p["speed_kmh"], color=colour, lw=1.3,
                label=f"{r.summary['running_time_s']:.1f} s, {r.summary['traction_energy_kWh']:.2f} kWh")
    return _finish_speed_axes(fig, ax, path, title)


def compare_plot(outcomes, segment, path, title=""):
    """Simulated speed against distance of each strategy, with the speed limit."""
    fig, ax = figure(figsize=(9, 4.5))
    fig.subplots_adjust(left=0.08, right=0.98, top=0.92, bottom=0.12)
    x, y = _steps(segment.limit, segment.distance)
    ax.step(x, to_kmh(y), where="post", color="tab:red", lw=1.2, label="speed limit (train length)")
    styles = [("tab:blue", "-"), ("black", "-"), ("tab:green", "--"), ("tab:orange", ":"), ("tab:purple", "-.")]
    for o, (colour, dash) in zip(outcomes, styles * 2):
        ax.plot(o.trace.x, to_kmh(o.trace.v), lw=1.4, color=colour, ls=dash,
                label=f"{o.name}: {o.trace.arrival_time:.1f} s, {to_kwh(o.trace.traction_energy):.2f} kWh")
    return _finish_speed_axes(fig, ax, path, title)


def journey_plot(results, path, title="", passing=()):
    """Speed against distance along the line for each distribution of the running time;
    ``passing``: (journey distance [m], highest speed [km/h] or None) of timing points, marked."""
    fig, ax = figure(figsize=(10, 4.5))
    fig.subplots_adjust(left=0.07, right=0.98, top=0.92, bottom=0.12)
    for x, cap in passing:
        ax.axvline(x, color="tab:red", lw=0.8, ls=":")
        if cap is not None:
            ax.plot([x - 30, x + 30], [cap, cap], color="tab:red", lw=2)
    for (name, runs), colour in zip(results.items(), ("tab:blue", "tab:orange", "tab:green")):
        offset = 0.0
        for i, r in enumerate(runs):
            p = r.profile
            label = f"{name}: {sum(x.summary['traction_energy_kWh'] for x in runs):.2f} kWh" if i == 0 else None
            ax.plot(offset + p["position_m"], p["speed_kmh"], color=colour, lw=1.2, label=label)
            offset += r.summary["distance_m"]
            ax.axvline(offset, color="grey", lw=0.5)
    return _finish_speed_axes(fig, ax, path, title, xlabel="distance along the journey [m]", legend_size=8)


def network_plot(fleet, outcome, path, title=""):
    """Speeds and pantograph powers against time of every train (independent and joint, if
    run), and the substation power of every strategy."""
    shown = [n for n in ("independent", "joint") if n in outcome] or list(outcome)[:1]
    rows = 2 * len(shown) + 1
    fig, axes = figure(rows, 1, figsize=(10, 2.4 * rows), sharex=True)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.95, bottom=0.06, hspace=0.25)
    fig.suptitle(title, fontsize=10)
    for n, name in enumerate(shown):
        speed, power = axes[2 * n], axes[2 * n + 1]
        for i, (legs, runs) in enumerate(zip(fleet.legs, outcome[name]["runs"])):
            for k, (leg, run) in enumerate(zip(legs, runs)):
                t = (leg.start + np.arange(leg.steps + 1)) * fleet.dt
                speed.plot(t, to_kmh(run.v), color=f"C{i}", lw=1, label=fleet.names[i] if k == 0 else None)
                power.step(t[:-1], run.p / 1e6, where="post", color=f"C{i}", lw=0.8)
        speed.set_ylabel(f"{name}\nspeed [km/h]", fontsize=8)
        power.set_ylabel(f"{name}\npantograph [MW]", fontsize=8)
        speed.legend(fontsize=7, loc="upper right")
        for ax in (speed, power):
            ax.grid(alpha=0.3)
    ax = axes[-1]
    for j, (name, res) in enumerate(outcome.items()):
        steps = res["steps"]
        ax.plot(steps["time_s"], steps["substation_kW"] / 1e3, lw=0.8, color=f"C{j}",
                label=f"{name} ({res['totals']['substation_kWh']:.2f} kWh)")
    ax.set_ylabel("substation\npower [MW]", fontsize=8)
    ax.set_xlabel("time [s]")
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=100, format="png")
