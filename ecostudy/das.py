"""Driver advice (thesis 000 §3.1.2): a few handle positions instead of a continuous handle.

A DAS run is a handle per interval restricted to the train's ``das_handle_levels`` (traction
levels, coast 0, brake -1). The advice a driver reads is the sequence of modes with where and
when each starts. Methods so far: ``round``, the nearest level to the ATO optimum's handle in
every interval (thesis 000 §4.4), re-simulated: the baseline better DAS methods must beat.
"""
import numpy as np
import pandas as pd

from . import strategies
from .units import to_kmh


def mode_name(level):
    """Driver-readable mode of a handle level."""
    if level >= 1 - 1e-9:
        return "full traction"
    if level > 1e-9:
        return f"traction {100 * level:.0f} %"
    if level <= -1 + 1e-9:
        return "full service braking"
    if level < -1e-9:
        return f"braking {-100 * level:.0f} %"
    return "coast"


def advice_table(nodes, handle, trace):
    """One row per mode change: start position and (simulated) time, mode, handle, end position."""
    change = np.concatenate([[0], np.nonzero(np.diff(handle))[0] + 1])
    ends = np.append(change[1:], len(handle))
    x_sim, t_sim = np.maximum.accumulate(trace.x), trace.t
    rows = []
    for i0, i1 in zip(change, ends):
        rows.append({"start_position_m": float(nodes[i0]),
                     "start_time_s": float(np.interp(nodes[i0], x_sim, t_sim)),
                     "mode": mode_name(handle[i0]), "handle": float(handle[i0]),
                     "target_speed_kmh": np.nan,  # cruise modes (not in `round`) hold a speed
                     "end_position_m": float(nodes[i1])})
    return pd.DataFrame(rows)


def das_run(result, method="round"):
    """(summary block, advice table, outcome) of a DAS run derived from an ATO ``result``."""
    if method != "round":
        raise ValueError(f"unknown DAS method {method!r}")
    outcome = strategies.das_round(result.segment, result.train, result.nodes, result.handle)
    row = outcome.row(result.train, result.segment.distance)
    ato = result.summary["traction_energy_kWh"]
    advice = advice_table(result.nodes, outcome.handle, outcome.trace)
    summary = {"method": method, "traction_energy_kWh": row["traction_energy_kWh"],
               "net_energy_kWh": row["net_energy_kWh"],
               "gap_to_ato_pct": 100 * (row["traction_energy_kWh"] / ato - 1) if ato > 0 else None,
               "mode_changes": len(advice) - 1, "bound_kWh": None, "status": "re-simulated",
               "arrival_error_s": row["running_time_s"] - result.summary["running_time_s"],
               "stop_error_m": row["stop_error_m"],
               "top_speed_kmh": float(to_kmh(np.max(outcome.trace.v)))}
    return summary, advice, outcome

