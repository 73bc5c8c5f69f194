"""Plots: speed against distance with limits, the gradient profile and the handle beneath."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .units import PERMILLE, to_kmh  # noqa: E402


def _steps(profile, distance):
    """x, y arrays drawing a piecewise-constant profile as steps over [0, distance]."""
    x = np.append(profile.starts, distance)
    y = np.append(profile.values, profile.values[-1])
    return x, y


def speed_plot(result, path):
    seg, prof, s = result.segment, result.profile, result.summary
    fig, (ax, axg, axu) = plt.subplots(3, 1, figsize=(9, 7), sharex=True,
                                       gridspec_kw={"height_ratios": [3, 1, 1], "hspace": 0.12})
    fig.subplots_adjust(left=0.08, right=0.98, top=0.95, bottom=0.07)  # tight_layout costs 40 % of the plot
    x, y = _steps(seg.limit, seg.distance)
    ax.step(x, to_kmh(y), where="post", color="tab:red", lw=1.2, label="speed limit (train length)")
    ax.plot(prof["position_m"], prof["speed_kmh"], color="tab:blue", lw=1.6, label="optimal speed")
    if result.trace is not None:
        ax.plot(result.trace.x, to_kmh(result.trace.v), color="k", lw=0.8, ls="--", label="re-simulated")
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
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)
