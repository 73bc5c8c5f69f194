"""A solved run at fixed steps of time or distance: the form on-board advisory systems and
simulators take (position, time, speed, handle and, with driver advice, the advised mode).

Between grid nodes the run has constant acceleration, as the transcription assumes (the interval
time of the space-domain NLP is dt = 2 ds / (v0 + v1)): v is linear in time, and
v^2 = v0^2 + 2 a (s - s0) in distance. The handle of an interval holds over the whole interval.
"""
from typing import Optional

import numpy as np
import pandas as pd

from ecostudy.core.types import Trajectory
from ecostudy.core.units import to_kmh


def _intervals(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(clock at every node [s], acceleration of every interval [m/s^2])."""
    t = traj.time
    a = np.divide(np.diff(traj.v), traj.dt, out=np.zeros(len(traj.dt)), where=traj.dt > 0)
    return t, a


def at_times(traj: Trajectory, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(position [m], speed [m/s], interval index) at each clock value of ``times`` [s]."""
    t, a = _intervals(traj)
    k = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(traj.dt) - 1)
    tau = np.clip(times - t[k], 0.0, traj.dt[k])
    v = traj.v[k] + a[k] * tau
    s = traj.nodes[k] + traj.v[k] * tau + 0.5 * a[k] * tau ** 2
    return np.minimum(s, traj.nodes[k + 1]), np.maximum(v, 0.0), k


def at_positions(traj: Trajectory, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(clock [s], speed [m/s], interval index) at each position of ``positions`` [m]."""
    t, a = _intervals(traj)
    k = np.clip(np.searchsorted(traj.nodes, positions, side="right") - 1, 0, len(traj.dt) - 1)
    xi = np.clip(positions - traj.nodes[k], 0.0, np.diff(traj.nodes)[k])
    v = np.sqrt(np.maximum(traj.v[k] ** 2 + 2.0 * a[k] * xi, 0.0))
    moving = np.abs(a[k]) > 1e-12
    tau = np.where(moving, (v - traj.v[k]) / np.where(moving, a[k], 1.0),
                   xi / np.maximum(traj.v[k], 1e-12))
    return t[k] + np.minimum(tau, traj.dt[k]), v, k


def _steps(start: float, end: float, step: float) -> np.ndarray:
    """``start``, ``start + step``, ... before ``end``, then ``end``; a step within a millionth of a step
    (or of the run, when the step is longer) of ``end`` is ``end`` itself (a run of 80.00000001 s every
    second ends 79, 80, not 80, 80.00000001; every 1e9 s it is 0, 80)."""
    grid = np.arange(start, end, step)
    return np.append(grid[grid < end - 1e-6 * min(step, end - start)], end)


def fixed_step(traj: Trajectory, handle: np.ndarray, time_step_s: Optional[float] = None,
               distance_step_m: Optional[float] = None, advice: Optional[pd.DataFrame] = None) -> pd.DataFrame:
    """The run every ``time_step_s`` seconds or every ``distance_step_m`` metres (one of them),
    the arrival always the last row: ``time_s``, ``position_m``, ``speed_kmh``, ``speed_mps``,
    ``handle`` (the interval's, the last row 0) and, with an ``advice`` table (``advice.csv``:
    ``start_position_m``, ``mode``, ``handle``, ``target_speed_kmh``), the advised ``advice_mode``,
    ``advice_handle`` and ``advice_target_speed_kmh`` in force there."""
    if (time_step_s is None) == (distance_step_m is None):
        raise ValueError("give one of time_step_s and distance_step_m")
    if time_step_s is not None:
        end = float(traj.time[-1])
        times = _steps(0.0, end, time_step_s)
        position, speed, k = at_times(traj, times)
    else:
        assert distance_step_m is not None  # one of the two, as checked above
        end = float(traj.nodes[-1])
        position = _steps(float(traj.nodes[0]), end, distance_step_m)
        times, speed, k = at_positions(traj, position)
    # the last row is the arrival itself (a saved profile's rounding must not move it)
    times[-1], position[-1], speed[-1] = traj.time[-1], traj.nodes[-1], traj.v[-1]
    u = np.asarray(handle, dtype=float)[k]
    u[-1] = 0.0  # at the stop
    out = pd.DataFrame({"time_s": times, "position_m": position, "speed_kmh": to_kmh(speed), "speed_mps": speed,
                        "handle": u})
    if advice is not None and len(advice):
        row = np.clip(np.searchsorted(advice["start_position_m"].to_numpy(), position, side="right") - 1,
                      0, len(advice) - 1)
        out["advice_mode"] = advice["mode"].to_numpy()[row]
        out["advice_handle"] = advice["handle"].to_numpy()[row]
        out["advice_target_speed_kmh"] = advice["target_speed_kmh"].to_numpy()[row]
    return out


def missed_phases(runs: list[dict], positions: np.ndarray) -> list[str]:
    """The phases of a run (its summary's ``regimes.runs``: regime, start_m, end_m) in which no row of
    an export at ``positions`` [m from the departure] falls, as ``MA 210-267 m``: an on-board system
    reading the export never sees them (a traction phase between two samples, a cruise shorter than
    a step)."""
    x = np.asarray(positions, float)
    return [f"{r['regime']} {r['start_m']:.0f}-{r['end_m']:.0f} m" for r in runs
            if not np.any((x >= r["start_m"]) & (x < r["end_m"]))]


def advice_phases(advice: pd.DataFrame, end_m: float) -> list[dict]:
    """The advised modes of an ``advice`` table (``advice.csv``) as phases (``advice <mode>``,
    ``start_m``, ``end_m``: each to the next one's start, the last to ``end_m`` [m]), for
    :func:`missed_phases`: a driver's cruise or gentle brake a step jumps over is lost as much."""
    starts = advice["start_position_m"].to_numpy(float)
    ends = np.append(starts[1:], end_m)
    return [{"regime": f"advice {mode}", "start_m": float(a), "end_m": float(b)}
            for mode, a, b in zip(advice["mode"], starts, ends) if b > a]

