"""The DAS methods by name (``round``, ``phases``, ``minlp``) and their table columns."""
from ecostudy.core.errors import EcostudyError
from ecostudy.das.advice import das_phases, das_round
from ecostudy.das.minlp import das_minlp

DAS_COLUMNS = ("method", "traction_energy_kWh", "net_energy_kWh", "gap_to_ato_pct", "gap_to_ato_on_time_pct",
               "mode_changes", "arrival_error_s", "stop_error_m", "status")


def das_columns(result, method, points=None, time_limit=60.0):
    """``das_`` columns of a table row for a DAS run of ``result``; a failed run is recorded, not raised."""
    try:
        block = das_run(result, method, points, time_limit).summary
    except EcostudyError as exc:
        block = {"method": method, "status": f"failed: {exc}"}
    row = {f"das_{k}": block.get(k) for k in DAS_COLUMNS}
    arrival = block.get("arrival_error_s")
    row["das_running_time_s"] = None if arrival is None else result.summary["running_time_s"] + arrival
    return row


def das_run(result, method="round", points=None, time_limit=60.0):
    """The :class:`~ecostudy.das.advice.DasRun` of method ``round``, ``phases`` or ``minlp`` for an ATO ``result``."""
    if method == "round":
        return das_round(result)
    if method == "phases":
        return das_phases(result, points)
    if method == "minlp":
        return das_minlp(result, points, time_limit)
    raise ValueError(f"unknown DAS method {method!r}")
