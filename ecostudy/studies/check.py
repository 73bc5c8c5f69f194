"""`ecostudy check`: the Pontryagin check of a saved result, as its own optimum or for another time."""
from pathlib import Path

from ecostudy.analysis.pontryagin import check_profile
from ecostudy.analysis.saved import rejudged
from ecostudy.core.errors import InputError, problem
from ecostudy.io.results import load_result


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
    objective = "net_energy" if saved.summary.get("objective") == "net_energy" else "energy"
    report = check_profile(judged.track, judged.train, saved.inputs, saved.trajectory,
                           running_time, objective=objective, where=Path(result_dir) / "profile.csv", case=judged.case)[0]
    said, fitted = saved.summary.get("marginal_energy_kWh_per_s"), report["marginal_energy_kWh_per_s"]
    if (said is not None and fitted is not None and report["agreement_pct"] >= AGREES
            and not abs(said - fitted) <= MARGINAL_SHARE * abs(fitted) + MARGINAL_FLOOR):
        raise InputError(problem(Path(result_dir) / "summary.json", "marginal_energy_kWh_per_s", f"{said!r}, but the "
                                 f"multipliers fitted at the profile give {fitted:.4g} kWh/s: an edited file? solve again"))
    return {**report, "run_status": str(judged.status), "resimulated": judged.verification}
