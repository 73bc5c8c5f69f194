"""A solved run as numbers a reader uses: handles, the regenerated share of braking, the profile
table with its totals."""
import numpy as np
import pandas as pd

from ecostudy.core.kinematics import cumulative_work, interval_power
from ecostudy.core.physics import efficiency, line_energy
from ecostudy.core.units import KN, KW, KWH, to_kmh


def handles(train, v, ft, fb):
    """Handle u in [-1, 1] per interval: net force over the envelope at the interval's mean speed."""
    vm = 0.5 * (v[:-1] + v[1:])
    net = ft - fb
    u = np.where(net >= 0, net / np.maximum(train.traction.force(vm), 1e-9),
                 net / np.maximum(train.braking.force(vm), 1e-9))
    return np.clip(u, -1.0, 1.0)


def regenerated_force(train, v, fb):
    """Part of the braking force the electric brake can take at the interval's mean speed [N]."""
    return train.electric_brake(np.asarray(fb, float), 0.5 * (v[:-1] + v[1:]))


def tabulate(train, nodes, v, dt, ft, fb):
    """Profile table (one row per node; interval quantities on the row of the interval start) and totals."""
    ds = np.diff(nodes)
    fr = regenerated_force(train, v, fb)
    work_t, work_b, work_r = ft * ds, fb * ds, fr * ds
    u = handles(train, v, ft, fb)
    pad = lambda a: np.append(a, np.nan)  # noqa: E731  the last node starts no interval
    profile = pd.DataFrame({
        "position_m": nodes,
        "time_s": np.concatenate([[0.0], np.cumsum(dt)]),
        "speed_kmh": to_kmh(v),
        "handle": pad(u),
        "traction_force_kN": pad(ft / KN),
        "braking_force_kN": pad(fb / KN),
        "power_kW": pad(interval_power(ft, v) / KW),
        "cumulative_energy_kWh": cumulative_work(ft, nodes) / KWH,
    })
    vm = 0.5 * (v[:-1] + v[1:])
    regen = float(np.sum(efficiency(train.eta_regeneration, vm, fr) * work_r))
    net = float(np.sum(line_energy(ft, fr, vm, ds, train.eta_traction, train.eta_regeneration)))
    totals = {
        "running_time_s": float(dt.sum()),
        "traction_energy_kWh": float(work_t.sum() / KWH),
        "braking_energy_kWh": float(work_b.sum() / KWH),
        "regenerated_energy_kWh": float(regen / KWH),
        "net_energy_kWh": net / KWH,
        "traction_energy_J_per_kg": float(work_t.sum() / train.static_mass),
        "top_speed_kmh": float(to_kmh(v.max())),
    }
    return profile, totals
