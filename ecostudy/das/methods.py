"""The DAS methods by name (``round``, ``phases``, ``minlp``) and their table columns."""
from ecostudy.core.defaults import DAS_TIME_LIMIT_S
from ecostudy.core.errors import EcostudyError
from ecostudy.core.registry import Registry
from ecostudy.core.status import Status, part
from ecostudy.das.advice import das_phases, das_round
from ecostudy.das.minlp import das_minlp

DAS_COLUMNS = ("method", "traction_energy_kWh", "net_energy_kWh", "gap_to_ato_pct", "gap_to_ato_on_time_pct",
               "mode_changes", "arrival_error_s", "stop_error_m", "overspeed_max_kmh", "status", "solver")


def das_columns(result, method, points=None, time_limit=DAS_TIME_LIMIT_S):
    """``das_`` columns of a table row for a DAS run of ``result``; a failed run is recorded, not raised."""
    try:
        block = das_run(result, method, points, time_limit).summary
    except EcostudyError as exc:
        block = {"method": method, "status": f"failed: {exc}"}
    row = {f"das_{k}": block.get(k) for k in DAS_COLUMNS}
    arrival = block.get("arrival_error_s")
    row["das_running_time_s"] = None if arrival is None else result.summary["running_time_s"] + arrival
    return row


def advice_status(row):
    """What the ``das_`` columns of a table row (:func:`das_columns`) add to its case's status: ``ok``,
    or ``flagged`` naming the advice (an advice not kept or not computed; the ATO run stands)."""
    return part(f"driver advice {row['das_method']}", Status.parse(row["das_status"]))


DAS_METHODS: Registry = Registry("DAS method")
DAS_METHODS.register("round", lambda result, points, time_limit: das_round(result),
                     doc="nearest handle level of the ATO optimum (Farooqi 2018, section 4.4)")
DAS_METHODS.register("phases", lambda result, points, time_limit: das_phases(result, points),
                     doc="a fixed mode sequence per sector, phase lengths optimised (Farooqi 2018, Ch. 5)")
DAS_METHODS.register("minlp", das_minlp, doc="the mode of every phase chosen by binaries (outer approximation)")


def das_run(result, method="round", points=None, time_limit=DAS_TIME_LIMIT_S):
    """The :class:`~ecostudy.das.advice.DasRun` of a registered method (:data:`DAS_METHODS`:
    ``round``, ``phases``, ``minlp``) for an ATO ``result``."""
    try:
        build = DAS_METHODS.get(method)
    except KeyError as exc:
        raise ValueError(str(exc.args[0])) from None
    return build(result, points, time_limit)
