"""`ecostudy check`: the Pontryagin check of a saved result, as its own optimum or for another time."""
from pathlib import Path

from ecostudy.analysis.pontryagin import check_profile
from ecostudy.analysis.regimes import all_out_check
from ecostudy.analysis.saved import rejudged
from ecostudy.core.errors import InputError, problem
from ecostudy.io.results import load_result
from ecostudy.ocp.problem import capped_limits


AGREES = 95.0  # [%] of the distance: a profile that obeys the conditions this far is the optimum checked
# the saved marginal energy against the one fitted at the profile, where it agrees (AGREES): within this
# share of it and this floor [kWh/s]; measured at most 2.8 % apart (10 runs of K = 40 and 200 on the
# shipped tracks and trains, energy and net energy)
MARGINAL_SHARE, MARGINAL_FLOOR = 0.1, 1e-3


def check_result(result_dir, running_time=None):
    """:func:`check_profile` of an `ecostudy solve` output folder (inputs.json, summary.json, profile.csv),
    with ``run_status``: the saved run's status judged again (``analysis.saved.rejudged``: its own
    status, and its profile re-simulated against its unchanged track and train) and that
    re-simulation's block, ``resimulated``.

    A net-energy run is checked against eq. 7.4; energy and all-out runs against eq. 2.17.
    """
    saved = load_result(result_dir)
    took = float(saved.trajectory.dt.sum())
    if running_time is not None and running_time < took - 1e-6:
        raise InputError(problem("command line", "--time", f"the saved run takes {took:.2f} s: it cannot be the "
                                 f"optimum for arriving by {running_time:g} s"))
    judged = rejudged(saved, result_dir)
    if saved.summary.get("objective") == "time" and running_time is None:  # its own question: the fastest run
        return {**all_out_report(judged.case, saved.trajectory), "run_status": str(judged.status),
                "resimulated": judged.verification}
    objective = "net_energy" if saved.summary.get("objective") == "net_energy" else "energy"
    report = check_profile(judged.track, judged.train, saved.inputs, saved.trajectory,
                           running_time, objective=objective, where=Path(result_dir) / "profile.csv", case=judged.case)[0]
    said, fitted = saved.summary.get("marginal_energy_kWh_per_s"), report["marginal_energy_kWh_per_s"]
    if (said is not None and fitted is not None and report["agreement_pct"] >= AGREES
            and not abs(said - fitted) <= MARGINAL_SHARE * abs(fitted) + MARGINAL_FLOOR):
        raise InputError(problem(Path(result_dir) / "summary.json", "marginal_energy_kWh_per_s", f"{said!r}, but the "
                                 f"multipliers fitted at the profile give {fitted:.4g} kWh/s: an edited file? solve again"))
    return {**report, "run_status": str(judged.status), "resimulated": judged.verification}


def all_out_report(case, trajectory):
    """:func:`~ecostudy.analysis.regimes.all_out_check` of an all-out run's profile, as its own optimum:
    the fastest run. Its energy costate is no question to ask of it (its arrival multiplier is a
    degenerate problem's: the eq. 2.17 check gave 100 % at K = 100 and 300, 37.9 % at K = 200 on the metro)."""
    _, v, dt, ft, fb = trajectory
    own = float(dt.sum())
    report = all_out_check(case.train, case.nodes, capped_limits(case), v, ft, fb)
    return {**report, "method": "regimes of the minimum-time run read off the profile (no costate)",
            "stationarity_residual": None, "profile_running_time_s": own, "marginal_energy_kWh_per_s": None,
            "checked_as": f"all-out run (full traction, the speed limit or full braking) for {own:.2f} s (its own time)"}
