"""Replaying a logged run on a model train: energy and time differences per run between stops.

Two replays, each answering one question:

- **speed as reference** (energy at equal running): the model follows the logged speed. Over each
  phase of the log (runs of intervals with traction, or without), its work at the wheel is the
  energy balance of :mod:`ecostudy.calibration.replay` with the model's parameters,
  1/2 M (v_e^2 - v_s^2) + int R_v(v) v dt + Ms w_fixed, the end speeds from straight lines fitted
  to the phase's own samples (:data:`END_FIT` seconds at each end, of its first and last handle
  only; the speed noise averages out, a change of handle does not bend the line; a traction phase takes its end speeds
  from its neighbours' lines, because the handle changes inside its edge intervals). The model's
  traction energy is the sum of the work of the traction phases and of the phases without
  traction where the model needs traction beyond twice the work's standard error from the end
  speeds (so that speed noise on a coast the model would also coast is not counted as traction).
  Its time is the logged time.
- **handle as input** (time at equal driving): the logged force divided by the model's traction
  or braking envelope at the logged speed is the driver's handle (within the envelope on average
  over a second); :meth:`Plant.drive` drives it by position from the departure, each sample's
  handle from the midpoint with the previous sample, until the model stops, which gives the
  model's running time, where it stops and its traction energy.

A run is ``flagged`` when its traction energy differs from the log's by more than
``energy_tolerance`` or its running time by more than ``time_tolerance`` (shares), or when the
model under the logged handle stops further from the logged stop than a driven run may
(``core.status.STOP_TOLERANCE_M``) plus what the replay itself moves the stop by
(:func:`stop_tolerance`): its time and energy are then not those of the logged run; and when the
logged speed broke the line's limit (:func:`~ecostudy.calibration.replay.over_limit`): a driver keeps
to it, so the log is not a driven run of this line as the track file gives it; and when the run's
residuals drift at the train fitted to the log (:func:`~ecostudy.calibration.estimate.fitted_drifts`,
calibrate's check): no train of the model replays the logged speed along the logged positions
(positions offset from the track's, another line); and when the run ends standing away from every
stop of the track (:func:`off_station`): a stand at a signal, not a run between the line's stops.
"""
from dataclasses import replace

import numpy as np
import pandas as pd

from ecostudy.calibration.estimate import MAX_STRUCTURE, drift_reason, fitted_drifts
from ecostudy.calibration.fit import Problem
from ecostudy.calibration.replay import coefficients, line_power, over_limit, smoothed, wheel_work
from ecostudy.core.grid import make_segment
from ecostudy.core.plant import Plant
from ecostudy.core.progress import stage, step
from ecostudy.core.status import STOP_TOLERANCE_M
from ecostudy.core.units import signed, to_kwh

END_FIT = 3.0          # [s] of samples at each end of a phase for its end speeds
TRACTION_SHARE = 0.01  # an interval draws traction (brakes) above (below minus) this share of the log's largest power
HANDLE_STEP = 0.01     # the replayed handle is rounded to this
# a run's logged stand this far [m] (plus three standard deviations of its positions' noise) from every
# stop of the track is not at a station: a track file gives a station as one point, a train stands at
# its platform's marker for its length and a logger's odometry drifts, but a stand 408 m short of the
# line's last stop or 2.2 km from any (at a signal) is another run than one between the line's stops
STATION_TOLERANCE_M = 100.0


def end_speed(t, v, at_start, span=END_FIT):
    """(speed, its standard error) at the first (``at_start``) or last sample of a phase: a straight
    line through the samples within ``span`` seconds of that end, evaluated there."""
    keep = (t - t[0] <= span) if at_start else (t[-1] - t <= span)
    if keep.sum() < 4:
        return float(v[0] if at_start else v[-1]), 0.0
    tt, vv = t[keep] - t[0 if at_start else -1], v[keep]
    slope, level = np.polyfit(tt, vv, 1)
    spread = np.std(vv - (level + slope * tt), ddof=2)
    error = spread * np.sqrt(1.0 / len(tt) + np.mean(tt) ** 2 / np.sum((tt - np.mean(tt)) ** 2))
    return float(max(level, 0.0)), float(error)


def phase_bounds(work, share=TRACTION_SHARE):
    """(start, end, traction) of each run of intervals with traction, with braking and with neither
    (coasting): sample indices, and whether the run is one of traction."""
    if not work.size:
        return []
    scale = share * np.max(np.abs(work))
    kind = (work > scale).astype(int) - (work < -scale).astype(int) if scale > 0 else np.zeros(len(work), int)
    edges = np.concatenate([[0], np.nonzero(np.diff(kind))[0] + 1, [len(work)]])
    return [(s, e, bool(kind[s] > 0)) for s, e in zip(edges[:-1], edges[1:])]


def speed_reference(run, train, work):
    """The model's traction work at the wheel [J] following the logged speed of ``run`` (whose
    intervals have the logged work ``work``)."""
    weights = coefficients(train.mass, train.static_mass, train.davis) * train.mass
    # a coast and the braking after it are phases of their own: over both at once the traction a
    # heavier-running model needs while coasting was netted against the braking it then needs less
    # of (a model with twice the Davis resistance: +10.0 % where it needs +20.9 %)
    bounds = phase_bounds(work)

    def speeds_at(s, e):
        return [end_speed(run.t[s:e + 1], run.v[s:e + 1], True) if s > 0 else (0.0, 0.0),
                end_speed(run.t[s:e + 1], run.v[s:e + 1], False)]
    ends = [speeds_at(s, e) for s, e, _ in bounds]
    total = 0.0
    for i, (s, e, pulling) in enumerate(bounds):
        # the handle changes inside a traction phase's edge interval: at the shared sample the
        # neighbouring phase's line is on the right side of the kink
        (v0, e0) = ends[i - 1][1] if pulling and i > 0 else ends[i][0]
        (v1, e1) = ends[i + 1][0] if pulling and i + 1 < len(bounds) else ends[i][1]
        basis = run.basis()[[s, e]]
        basis[:, 0] = 0.5 * np.square([v0, v1])
        basis[:, 1] = 0.0  # the balance with the logged work left out: the model's work to get there
        phase = float(np.diff(basis @ weights)[0])
        noise = train.mass * np.hypot(v0 * e0, v1 * e1)
        if pulling or phase > 2.0 * noise:  # a phase without traction counts only beyond its noise
            total += max(phase, 0.0)
    return total


def handle_replay(run, track, train, log, rounded=True, lead=0.5):
    """(running time [s], stop position from the departure [m], traction work [J]) of the model
    driven by the logged handle, by position; the handle rounded to :data:`HANDLE_STEP` unless
    ``rounded`` is False. A handle is known at the samples only: each sample's holds from ``lead``
    of the way back to the previous sample (0: from the sample itself, a change logged between two
    samples replayed up to one sample late; 1: up to one sample early; 0.5, the midpoint: up to half
    a sample either way)."""
    sign = 1.0 if run.x[-1] >= run.x[0] else -1.0
    far = float(np.clip(run.x[-1] + sign * 500.0, 0.0, track.length))
    segment = make_segment(replace(track, stops=dict(track.stops, _a=float(run.x[0]), _b=far)), train, "_a", "_b")
    # the furthest the train has come: noisy (GPS) positions go back and forth, the handle's nodes may not
    travel = np.maximum.accumulate(np.abs(run.x - run.x[0]))
    first = np.searchsorted(log.t, run.t[0])
    force = log.force[first:first + len(run.t)] if log.force is not None else None
    if force is None:
        force = np.append(np.diff(run.work) / np.diff(run.t), 0.0) / np.maximum(run.v, 1.0)
    v = np.maximum(run.v, 0.0)
    handle = np.where(force > 0, force / train.traction.force(v), force / train.braking.force(v))
    # within the envelope on average over SMOOTHING, not sample by sample: clipping each noisy sample
    # at full braking would take off the noise above the envelope only and replay the brake weaker
    handle = handle / np.maximum(np.abs(smoothed(run.t, handle)), 1.0)
    handle = np.round(handle / HANDLE_STEP) * HANDLE_STEP if rounded else handle
    keep = np.append(np.diff(travel) > 1e-3, True)  # the last sample at each furthest position: the one that moves on
    handle = handle[keep]
    # the rows before the first traction are the stand (a logger samples its zero force an instant
    # before traction; positions integrated from a noisy speed creep there): they take the first
    # traction handle, with the stand's zero the model never leaves
    pulling = np.nonzero(handle > 0)[0]
    if pulling.size:
        handle[:pulling[0]] = handle[pulling[0]]
    nodes, handle = travel[keep], handle[:-1]
    nodes[-1] = max(nodes[-1], nodes[-2] + 1e-3)
    nodes[1:-1] -= lead * np.diff(nodes)[:-1]
    y, t_stop, _ = Plant(segment, train).drive(nodes, handle, max_time=4 * (run.t[-1] - run.t[0]) + 600)
    return float(t_stop), float(y[0]), float(y[2])


def stop_tolerance(run, track, train, log, stop):
    """How far [m] the model's stop under the logged handle (``stop``, from the departure, each
    sample's handle from the midpoint with the previous sample) may lie from the logged stop:
    ``STOP_TOLERANCE_M``, plus what replaying every handle change one sample late instead of one
    sample early moves the stop by, plus what rounding the handle moved it by (the stop replayed under
    the handle unrounded), plus the logged positions' noise (:func:`position_noise`). A change
    logged between two samples is replayed up to half a sample late or
    early, so the midpoint replay lies within half that shift of an exactly timed one; the other half
    is left for the logged force's noise, which moves a stop the same way. The shift is measured, not
    taken as a sample's travel: on a descent a brake applied late lets the train gain speed first,
    and it stops further on by more than the travel."""
    late, early, exact = (handle_replay(run, track, train, log, **kind)[1] for kind in
                          ({"lead": 0.0}, {"lead": 1.0}, {"rounded": False}))
    return STOP_TOLERANCE_M + abs(late - early) + abs(stop - exact) + 3.0 * np.sqrt(2.0) * position_noise(run)


def position_noise(run):
    """The logged positions' own noise [m] (GPS; none where they are the speeds integrated): a robust
    standard deviation (1.4826 median absolute deviations) of each step's travel less the speeds'
    distance, over sqrt 2, each step being the difference of two noisy positions. The logged stop is
    the difference of two positions: :func:`stop_tolerance` takes three standard deviations of it."""
    ahead = np.diff(run.x) * (1.0 if run.x[-1] >= run.x[0] else -1.0)  # along the travel, noise not folded
    off = ahead - 0.5 * (run.v[1:] + run.v[:-1]) * np.diff(run.t)
    return 1.4826 * float(np.median(np.abs(off - np.median(off)))) / np.sqrt(2.0)


def off_station(run, track):
    """Why the stand that ends ``run`` is at no stop of ``track`` ('' where it is within
    :data:`STATION_TOLERANCE_M` plus three standard deviations of the positions' noise of one)."""
    name, at = min(track.stops.items(), key=lambda stop: abs(stop[1] - run.x[-1]))
    tolerance = STATION_TOLERANCE_M + 3.0 * position_noise(run)
    if abs(run.x[-1] - at) <= tolerance:
        return ""
    return (f"the run ends at {run.x[-1]:.0f} m, {abs(run.x[-1] - at):.0f} m from the nearest stop ({name} at "
            f"{at:.0f} m, tolerance {tolerance:.0f} m): a stand between stations (a signal?) or positions offset from "
            "the track's, not a run between the line's stops")


def validate_log(log, track, train, energy_tolerance=0.05, time_tolerance=0.05):
    """One row per run of ``log``: logged and model running time and traction energy, the
    differences, where the model stops, and the status."""
    rows, work_all = [], wheel_work(log)
    line = line_power(log)
    with np.errstate(invalid="ignore", over="ignore"):  # a non-finite logged work (API): its run's drift is NaN
        problem = Problem.from_logs([log], track, train)
    runs, drift = problem.runs, fitted_drifts(problem)  # the runs' drift at the train fitted to the log, as calibrate's
    stage(f"replaying {log.name}", total=len(runs), unit="runs")
    for i, run in enumerate(runs):
        step(i, f"run {run.index}")
        first = int(np.searchsorted(log.t, run.t[0]))
        work = work_all[first:first + len(run.t) - 1]
        logged = float(np.sum(np.maximum(work, 0.0)))
        model = speed_reference(run, train, work)
        model_time, stop, handle_work = handle_replay(run, track, train, log)
        logged_time = float(run.t[-1] - run.t[0])
        row = {"log": log.name, "run": run.index, "from_m": float(run.x[0]), "to_m": float(run.x[-1]),
               "logged_time_s": logged_time, "model_time_s": model_time,
               "time_difference_pct": 100 * (model_time - logged_time) / logged_time,
               "model_stop_error_m": stop - run.distance,
               "logged_traction_kWh": to_kwh(logged), "model_traction_kWh": to_kwh(model),
               "traction_difference_pct": 100 * (model - logged) / logged if logged > 0 else np.nan,
               "model_traction_at_logged_handle_kWh": to_kwh(handle_work), "residual_drift_ratio": drift[i]}
        if line is not None:
            drawn = line[first:first + len(run.t) - 1]
            row["logged_line_traction_kWh"] = to_kwh(float(np.sum(np.maximum(drawn, 0.0) * np.diff(run.t))))
            row["model_line_traction_kWh"] = to_kwh(model / train.traction_efficiency)
        reasons = []
        if not logged > 0:  # a NaN difference would pass every tolerance
            reasons.append("no traction logged in this run: no energy to compare")
        elif not abs(row["traction_difference_pct"]) <= 100 * energy_tolerance:  # NaN too (an infinite log)
            reasons.append(f"traction energy {signed(row['traction_difference_pct'], 1)} % off the log")
        if not run.stands:  # no logged running time: the time is not compared
            row["time_difference_pct"] = np.nan
            reasons.append(f"the log ends while the train moves (at {run.x[-1]:.0f} m, {run.v[-1]:.1f} m/s): "
                           "no running time to compare")
        elif not abs(row["time_difference_pct"]) <= 100 * time_tolerance:
            sampled = float(np.median(np.diff(log.t)))  # a stand is seen to within a sample at each end
            known = (f" (the log samples every {sampled:g} s: a stand is seen within a sample at each end, so its "
                     f"running time is known to within about {2 * sampled:g} s, {200 * sampled / logged_time:.1f} %)" if 2 * sampled > 0.5 * time_tolerance * logged_time else "")
            reasons.append(f"running time {signed(row['time_difference_pct'], 1)} % off the log under the logged handle"
                           + known)
        if drift[i] > MAX_STRUCTURE:
            reasons.append(f"{drift_reason(drift[i])} at the train fitted to this log: no mass and running resistance "
                           "replay the logged speed from the logged work along the logged positions (positions "
                           "offset from the track's, or another line?)")
        overspeed = over_limit(run.t, run.x, run.v, track)
        if overspeed:
            reasons.append(overspeed)
        if run.stands and off_station(run, track):
            reasons.append(off_station(run, track))
        if run.stands:  # the log's last position is a stop: where the model stops is compared
            row["stop_tolerance_m"] = stop_tolerance(run, track, train, log, stop)
            if abs(row["model_stop_error_m"]) > row["stop_tolerance_m"]:
                where = "short of" if row["model_stop_error_m"] < 0 else "past"
                reasons.append(f"under the logged handle the model stops {abs(row['model_stop_error_m']):.1f} m {where} "
                               f"the logged stop (tolerance {row['stop_tolerance_m']:.1f} m): its running time is not "
                               "the logged run's")
        row["status"], row["reason"] = ("flagged", "; ".join(reasons)) if reasons else ("ok", "")
        rows.append(row)
    step(len(runs))
    return pd.DataFrame(rows)
