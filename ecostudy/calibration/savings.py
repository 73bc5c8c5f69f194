"""Savings against the logged driving: per run between stops, the energy-optimal driving of the
calibrated train for the logged running time (:func:`ecostudy.analysis.single.solve_run`, verified
by the plant) against the traction energy the log used, with the calibration's uncertainty
carried through as a band: the optimum solved again for parameter sets drawn from the fit's
covariance (normal, seeded), the band their lowest and highest saving.
"""
from dataclasses import replace

import numpy as np
import pandas as pd

from ecostudy.analysis.single import solve_run
from ecostudy.calibration.fit import train_with
from ecostudy.calibration.replay import prepare, wheel_work
from ecostudy.core.progress import stage, step
from ecostudy.core.defaults import FRONT_POINTS
from ecostudy.core.errors import InfeasibleError, SolverError
from ecostudy.core.status import failed, flagged, worst
from ecostudy.core.types import Timing
from ecostudy.core.units import to_kwh


def parameter_draws(calibration, count, seed=0):
    """``count`` trains with parameters drawn from the calibration's estimate and covariance."""
    if not calibration.free or count <= 0:
        return []
    rng = np.random.default_rng(seed)
    mean = np.array([calibration.theta[n] for n in calibration.free])
    draws = rng.multivariate_normal(mean, calibration.covariance, size=count, method="eigh")
    return [train_with(calibration.train, dict(calibration.theta, **dict(zip(calibration.free, np.maximum(d, 0.0)))))
            for d in draws]


def savings(log, track, calibration, draws=8, points=FRONT_POINTS, seed=0):
    """One row per run of ``log``: logged time and traction energy, the calibrated optimum's, the
    saving [%] and its band over ``draws`` parameter draws, and its status: the optimum's (solver
    and re-simulation, :attr:`RunResult.status`), flagged too when a draw of the band is not ok."""
    trains = parameter_draws(calibration, draws, seed)
    work, rows, runs = wheel_work(log), [], prepare(log, track, calibration.train)
    stage(f"savings {log.name}", total=len(runs) * (1 + len(trains)), unit="solves")
    for i, run in enumerate(runs):
        step(i * (1 + len(trains)), f"run {run.index}")
        first = int(np.searchsorted(log.t, run.t[0]))
        logged = float(np.sum(np.maximum(work[first:first + len(run.t) - 1], 0.0)))
        timing = Timing(running_time=float(run.t[-1] - run.t[0]))
        if not run.stands:  # no logged running time to the next stop: nothing to optimise for
            rows.append(_no_optimum(log, run, timing, logged, flagged(
                f"the log ends while the train moves (at {run.x[-1]:.0f} m, {run.v[-1]:.1f} m/s): no running time "
                "to optimise for")))
            continue
        here = replace(track, stops=dict(track.stops, _departure=float(run.x[0]), _arrival=float(run.x[-1])))
        try:
            best = solve_run(here, calibration.train, "_departure", "_arrival", timing, points=points)
        except (InfeasibleError, SolverError) as exc:  # one run without an optimum does not stop the others
            rows.append(_no_optimum(log, run, timing, logged,
                                    failed(f"{exc}: the calibrated train cannot drive the logged time")))
            continue
        energies, statuses = [best.summary["traction_energy_kWh"]], [best.status]
        step(i * (1 + len(trains)) + 1, f"run {run.index}")
        for n, train in enumerate(trains):
            try:
                drawn = solve_run(here, train, "_departure", "_arrival", timing, points=points, warm_start=best)
            except (InfeasibleError, SolverError) as exc:
                statuses.append(flagged(f"parameter draw {n + 1}: {exc}"))
                continue
            energies.append(drawn.summary["traction_energy_kWh"])
            statuses.append(drawn.status if drawn.ok else flagged(f"parameter draw {n + 1}: {drawn.status.reason}"))
            step(i * (1 + len(trains)) + len(statuses), f"run {run.index}")
        saving = [100 * (to_kwh(logged) - e) / to_kwh(logged) for e in energies]
        verified = best.summary["verification"] or {}
        rows.append({"log": log.name, "run": run.index, "from_m": float(run.x[0]), "to_m": float(run.x[-1]),
                     "running_time_s": timing.running_time, "logged_traction_kWh": to_kwh(logged),
                     "optimal_traction_kWh": energies[0], "saving_pct": saving[0],
                     "saving_low_pct": min(saving), "saving_high_pct": max(saving), "draws": len(energies) - 1,
                     "verified": bool(verified.get("passed", False)), "status": str(worst(statuses))})
    return pd.DataFrame(rows)


def _no_optimum(log, run, timing, logged, status):
    """A savings row of a run without an optimum: its logged time and energy, and why."""
    return {"log": log.name, "run": run.index, "from_m": float(run.x[0]), "to_m": float(run.x[-1]),
            "running_time_s": timing.running_time, "logged_traction_kWh": to_kwh(logged),
            "optimal_traction_kWh": np.nan, "saving_pct": np.nan, "saving_low_pct": np.nan,
            "saving_high_pct": np.nan, "draws": 0, "verified": False, "status": str(status)}
