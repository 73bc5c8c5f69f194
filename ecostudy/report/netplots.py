"""Plots of trains sharing a DC substation: speeds and pantograph powers of every train, the
substation power, bus voltage and current of every strategy (Farooqi 2018, Ch. 7). Apart from
:mod:`ecostudy.report.plots` so that drawing a single run never loads the network package."""
import numpy as np

from ecostudy.core.units import to_kmh
from ecostudy.network import circuit
from ecostudy.network.fleet import step_arrays
from ecostudy.report import style
from ecostudy.report.plots import figure, marked, overall, titled


def network_plot(fleet, outcome, path=None, title="", fmt=None, dpi=None, statuses=None):
    """Speeds and pantograph powers against time of every train (independent and joint, if
    run), and the substation power of every strategy: trains and strategies each in a colour no
    other curve of the figure has, the strategies' line styles cycled. ``statuses``: every
    strategy's (failed ones too, which have no runs to draw), marked in the legend and counted in the
    title (:func:`~ecostudy.report.plots.overall`)."""
    shown = [n for n in ("independent", "joint") if n in outcome] or list(outcome)[:1]
    rows = 2 * len(shown) + 1
    fig, axes = figure(rows, 1, figsize=(10, 2.4 * rows), sharex=True)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.95, bottom=0.06, hspace=0.25)
    titled(axes[0], title, _overall(outcome, statuses))
    palette = style.Palette(list(outcome) + list(fleet.names))
    for n, name in enumerate(shown):
        speed, power = axes[2 * n], axes[2 * n + 1]
        for i, (legs, runs) in enumerate(zip(fleet.legs, outcome[name]["runs"])):
            colour = palette(fleet.names[i])
            for k, (leg, run) in enumerate(zip(legs, runs)):
                t = (leg.start + np.arange(leg.steps + 1)) * fleet.dt
                speed.plot(t, to_kmh(run.v), color=colour, lw=1, label=fleet.names[i] if k == 0 else None)
                power.step(t[:-1], run.p / 1e6, where="post", color=colour, lw=0.8)
        speed.set_ylabel(f"{name}\nspeed [km/h]", fontsize=8)
        power.set_ylabel(f"{name}\npantograph [MW]", fontsize=8)
        speed.legend(fontsize=7, loc="upper right")
        for ax in (speed, power):
            ax.grid(alpha=0.3)
    ax = axes[-1]
    for j, (name, res) in enumerate(outcome.items()):
        steps = res["steps"]
        ax.plot(steps["time_s"], steps["substation_kW"] / 1e3, lw=0.9, color=palette(name),
                ls=style.DASHES[j % len(style.DASHES)],
                label=marked(f"{name} ({res['totals']['substation_kWh']:.2f} kWh)", (statuses or {}).get(name, "ok")))
    ax.set_ylabel("substation\npower [MW]", fontsize=8)
    ax.set_xlabel("time [s]")
    ax.legend(fontsize=7, loc="upper right", ncol=2 if len(outcome) > 4 else 1)
    ax.grid(alpha=0.3)
    return style.save(fig, path, fmt, dpi)


def supply_plot(fleet, outcome, path=None, title="", fmt=None, dpi=None, statuses=None):
    """Substation bus voltage [V] and current [A] against time of every strategy, from the
    circuit of eq. 7.8 (``network.circuit.solve_steps``) on each strategy's runs, with the
    nominal and highest voltage of the supply; ``statuses`` as :func:`network_plot`'s."""
    fig, (axv, axi) = figure(2, 1, figsize=(10, 5.5), sharex=True)
    fig.subplots_adjust(left=0.09, right=0.98, top=0.93, bottom=0.09, hspace=0.12)
    titled(axv, title, _overall(outcome, statuses))
    palette, supply = style.Palette(list(outcome)), fleet.supply
    for j, (name, res) in enumerate(outcome.items()):
        flows = circuit.solve_steps(supply, *step_arrays(fleet, res["runs"]))
        t = np.arange(fleet.steps) * fleet.dt
        dash = style.DASHES[j % len(style.DASHES)]
        label = marked(name, (statuses or {}).get(name, "ok"))
        axv.plot(t, flows["bus_voltage_V"], color=palette(name), lw=0.9, ls=dash, label=label)
        axi.plot(t, flows["substation_current_A"], color=palette(name), lw=0.9, ls=dash, label=label)
    for v, what in ((supply.voltage, "nominal"), (supply.max_voltage, "highest (regeneration cut-off)")):
        axv.axhline(v, color=style.LIMIT["voltage limit"], lw=0.8, ls=":", label=f"{what} {v:g} V")
    axv.set_ylabel("substation bus\nvoltage [V]", fontsize=8)
    axi.set_ylabel("substation\ncurrent [A]", fontsize=8)
    axi.set_xlabel("time [s]")
    axi.set_ylim(bottom=0)
    for ax in (axv, axi):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right", ncol=2 if len(outcome) > 4 else 1)
    return style.save(fig, path, fmt, dpi)


def _overall(outcome, statuses):
    """The figure's status line: every strategy's, those not drawn (failed) named so."""
    return overall({name if name in outcome else f"{name}, not drawn": st for name, st in (statuses or {}).items()},
                   "strategies")
