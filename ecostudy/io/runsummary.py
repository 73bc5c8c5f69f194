"""One run's ``summary.json`` as typed, named results: what the API and the command line read.

``summary.json`` stays the file (its layout is built in ``analysis.summary`` and written by
``report.files``); :meth:`RunSummary.from_dict` reads that layout into these dataclasses, whose
field names carry their units as the file's keys do (``traction_energy_kWh``, ``stop_error_m``).
A reader writes ``run.facts.traction_energy_kWh``, not ``run.summary["traction_energy_kWh"]``:
a misspelt attribute is an error mypy and the interpreter name, a misspelt key is not.
"""
from dataclasses import dataclass, field
from typing import Any, Mapping, Optional

from ecostudy.core.simulate import missed_points, within_tolerances
from ecostudy.core.defaults import SLOWEST
from ecostudy.core.status import (ADHESION_USE, OK, TOLERANCES, Status, calibrated, flagged, from_checks, part, past,
                                  solver_check, solver_part, worst)
from ecostudy.core.units import number, signed


# summary.json: how Ipopt ended the all-out run a run's time was taken from (a supplement over it),
# written only when that was not optimal
ALL_OUT_SOLVER = "all_out_solver_status"
# summary.json: the longest running time [s] a mixed objective with no arrival window could choose
# (``ocp.problem.slowest_time``: the crawl guard of a running time asked), its bound on T; a run at it
# (within AT_CAP, relative) is flagged: its weights would have it crawl further
TIME_CAP = "time_cap_s"
AT_CAP = 1e-6


def status_parts(summary: Mapping[str, Any], das: Optional[Mapping[str, Any]] = None,
                 calibration_reason: str = "") -> dict[str, Status]:
    """The statuses one run's status is made of, by the ``summary.json`` field each is read from:
    how Ipopt ended (``solver.status``), the re-simulation (``verification``: its errors within
    their tolerances, each timing point kept), the train's calibration (its file's
    ``calibration_reason``: :func:`~ecostudy.core.status.calibrated`), the all-out run a supplement's
    time was taken from (:data:`ALL_OUT_SOLVER`) and the driver advice as driven (``das``: the
    advice's block, as ``das.status`` records it). :func:`run_status` is their worst: a run's status
    as ``ecostudy solve`` writes it, and as a saved summary must say it."""
    block = summary["verification"]
    checks = {"not re-simulated": False} if block is None else {  # its errors, each timing point missed by name
        f"re-simulation outside tolerance ({Verification.from_dict(block).errors})": within_tolerances(block),
        **{f"re-simulated, {missed}": False for missed in missed_points(block.get("windows") or ())}}
    parts = {"solver.status": from_checks(solver_check(str(summary["solver"]["status"]))),  # joined as one
             "verification": from_checks(checks), "train calibration": calibrated(calibration_reason)}
    if ALL_OUT_SOLVER in summary:  # the all-out run its running time was taken from
        parts[ALL_OUT_SOLVER] = solver_part("the all-out run", str(summary[ALL_OUT_SOLVER]))
    cap = summary.get(TIME_CAP)
    if cap is not None:  # the longest time the mixed objective's weights could choose: there, they would crawl
        parts[TIME_CAP] = OK if float(summary["running_time_s"]) < (1 - AT_CAP) * float(cap) else flagged(
            f"the mixed objective's weights take the running time to its cap, {cap:.1f} s ({SLOWEST:g} times the fastest "
            "possible run's, kinematic envelope): the train would crawl; weigh time more, or give an arrival window")
    if das is not None:  # the driver advice as driven: a run of this command too
        parts["das.status"] = part(f"driver advice {das['method']}", Status.parse(str(das["status"])))
    return parts


def run_status(summary: Mapping[str, Any], das: Optional[Mapping[str, Any]] = None,
               calibration_reason: str = "") -> Status:
    """``ok`` when Ipopt proved optimality (of the all-out run too, where the running time is a
    supplement over it), the independent re-simulation agrees, the driver advice (``das``, when asked
    for) keeps the stop, the time and the limits as driven, and the train is not one of a
    calibration that was flagged; else ``flagged`` with what did not pass (:func:`status_parts`)."""
    return worst(status_parts(summary, das, calibration_reason).values())


# Keys as ecostudy before the one naming rule (ecostudy.core.columns) wrote them: a folder written
# then is still read.
PREVIOUS = {"overspeed_max_kmh": "max_overspeed_kmh", "wall_s": "seconds",
            "constraint_violation_max": "max_constraint_violation"}


def current(data: Mapping[str, Any]) -> dict[str, Any]:
    """``data`` (a block of ``summary.json``, its tolerances too) with every key under its current
    name (:data:`PREVIOUS`), as the checks of a saved run compare it."""
    old = {previous: now for now, previous in PREVIOUS.items()}
    return {old.get(k, k): current(v) if k == "tolerances" and isinstance(v, Mapping) else v for k, v in data.items()}


def _get(data: Mapping[str, Any], key: str) -> Any:
    """``data[key]``, or the value under its previous name (:data:`PREVIOUS`)."""
    return data[key] if key in data or key not in PREVIOUS else data[PREVIOUS[key]]


def _opt(data: Mapping[str, Any], key: str) -> Optional[float]:
    value = data.get(key, data.get(PREVIOUS.get(key, key)))
    return None if value is None else float(value)


@dataclass(frozen=True)
class SolverRun:
    """How Ipopt ended on the run's NLP (``summary.json`` block ``solver``)."""

    status: str                       # "optimal", or the termination Ipopt reported
    iterations: int
    wall_s: float                     # the solve stage's wall time [s]
    constraint_violation_max: Optional[float]

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "SolverRun":
        return cls(status=str(data["status"]), iterations=int(data["iterations"]), wall_s=float(_get(data, "wall_s")),
                   constraint_violation_max=_opt(data, "constraint_violation_max"))


@dataclass(frozen=True)
class Verification:
    """The independent re-simulation of the run's handles against the optimum (block
    ``verification``, ``core.simulate.verify``): ``passed`` when every error is within its
    tolerance and every timing window is kept."""

    passed: bool
    arrival_time_error_s: float
    stop_error_m: float
    energy_error_pct: float
    overspeed_max_kmh: float
    simulated_running_time_s: float
    simulated_traction_energy_kWh: float
    simulated_net_energy_kWh: float
    windows_kept: tuple[bool, ...] = ()
    net_energy_error_pct: float | None = None  # [% of the traction work]; None in runs saved without it
    adhesion_use_max: float | None = None  # largest share of mu(v) m_adh g asked; None: a train without the limit
    windows: tuple[dict[str, Any], ...] = ()  # each timing point's check (core.simulate.window_checks)

    @property
    def windows_said(self) -> str:
        """Each timing point kept or missed with the re-simulated passing time and speed, as the
        screen prints them beside :attr:`errors`: ``timing point at 500 m kept (40.00 s, 55.00 km/h)``."""
        return "; ".join(f"timing point at {w['distance_m']:g} m {'kept' if w['kept'] else 'MISSED'} "
                         f"({w['simulated_time_s']:.2f} s, {w['simulated_speed_kmh']:.2f} km/h)" for w in self.windows)

    @property
    def errors(self) -> str:
        """The re-simulation's errors as the run's status and the screen print them (the net energy's
        where it was measured)."""
        net = "" if self.net_energy_error_pct is None else \
            f", net energy {_error(self.net_energy_error_pct, 'net_energy_error_pct')} %"
        grip = "" if self.adhesion_use_max is None else \
            f", adhesion use {_beyond(self.adhesion_use_max, ADHESION_USE, f'{self.adhesion_use_max:.3f}')} of mu(v) m_adh g"
        return (f"arrival {_error(self.arrival_time_error_s, 'arrival_time_error_s')} s, stop "
                f"{_error(self.stop_error_m, 'stop_error_m')} m, energy {_error(self.energy_error_pct, 'energy_error_pct')} %"
                f"{net}, overspeed {_beyond(self.overspeed_max_kmh, TOLERANCES['overspeed_max_kmh'], number(self.overspeed_max_kmh))} km/h"
                f"{grip}")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Verification":
        return cls(passed=bool(data["passed"]), arrival_time_error_s=float(data["arrival_time_error_s"]),
                   stop_error_m=float(data["stop_error_m"]), energy_error_pct=float(data["energy_error_pct"]),
                   overspeed_max_kmh=float(_get(data, "overspeed_max_kmh")),
                   simulated_running_time_s=float(data["simulated_running_time_s"]),
                   simulated_traction_energy_kWh=float(data["simulated_traction_energy_kWh"]),
                   simulated_net_energy_kWh=float(data["simulated_net_energy_kWh"]),
                   windows_kept=tuple(bool(w["kept"]) for w in data.get("windows") or ()),
                   windows=tuple(dict(w) for w in data.get("windows") or ()),
                   net_energy_error_pct=_opt(data, "net_energy_error_pct"),
                   adhesion_use_max=_opt(data, "adhesion_use_max"))


@dataclass(frozen=True)
class RegimeRun:
    """One stretch of one driving regime (MA, CR, CO, CR2, MB, RB) [m from the departure]."""

    regime: str
    start_m: float
    end_m: float

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "RegimeRun":
        return cls(regime=str(data["regime"]), start_m=float(data["start_m"]), end_m=float(data["end_m"]))


@dataclass(frozen=True)
class PontryaginCheck:
    """The costate check of the regimes (Farooqi 2018 eq. 2.17; eq. 7.4 for net energy), block
    ``pontryagin``: the share of the distance whose regime agrees with psi = lambda / v, and the
    stretches that disagree."""

    agreement_pct: float
    conditions: str
    disagreements: tuple[RegimeRun, ...]

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "PontryaginCheck":
        return cls(agreement_pct=float(data["agreement_pct"]), conditions=str(data.get("conditions", "Farooqi 2018, eq. 2.17")),
                   disagreements=tuple(RegimeRun.from_dict(d) for d in data.get("disagreements") or ()))


@dataclass(frozen=True)
class DasSummary:
    """The driver advice of a run (block ``das``): a DAS method's driven advice against the ATO
    optimum; ``bound_kWh``, ``gap_pct``, ``search_s`` and ``oa_iterations`` of the MINLP only."""

    method: str                        # round, phases or minlp
    traction_energy_kWh: Optional[float]  # None: the advice failed (``status``)
    net_energy_kWh: Optional[float]
    gap_to_ato_pct: Optional[float]    # on the quantity the ATO run minimised
    gap_to_ato_on_time_pct: Optional[float]  # with a late arrival charged at the marginal energy
    mode_changes: Optional[int]
    arrival_error_s: Optional[float]   # None: the advice stood more than the tolerance off its stop
    stop_error_m: Optional[float]
    status: str                        # as a driven run: ok, or flagged with the reasons
    solver: Optional[str] = None       # how the advice was made, e.g. "optimal, re-simulated"
    overspeed_max_kmh: Optional[float] = None
    bound_kWh: Optional[float] = None
    gap_pct: Optional[float] = None
    search_s: Optional[float] = None
    oa_iterations: Optional[int] = None
    no_gap: str = ""                   # why there is no gap to ATO ('' where there is one)
    note: str = ""                     # why the advice is dearer than ATO, where its braking levels are why

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "DasSummary":
        oa = data.get("oa_iterations")
        changes = data.get("mode_changes")
        return cls(method=str(data["method"]), traction_energy_kWh=_opt(data, "traction_energy_kWh"),
                   net_energy_kWh=_opt(data, "net_energy_kWh"), gap_to_ato_pct=_opt(data, "gap_to_ato_pct"),
                   gap_to_ato_on_time_pct=_opt(data, "gap_to_ato_on_time_pct"),
                   mode_changes=None if changes is None else int(changes), arrival_error_s=_opt(data, "arrival_error_s"),
                   stop_error_m=_opt(data, "stop_error_m"), status=str(data["status"]),
                   solver=None if data.get("solver") is None else str(data["solver"]),
                   overspeed_max_kmh=_opt(data, "overspeed_max_kmh"),
                   bound_kWh=_opt(data, "bound_kWh"), gap_pct=_opt(data, "gap_pct"), search_s=_opt(data, "search_s"),
                   oa_iterations=None if oa is None else int(oa), no_gap=str(data.get("no_gap") or ""),
                   note=str(data.get("note") or ""))


@dataclass(frozen=True)
class RunSummary:
    """One solved run, typed: what was solved, its times and energies, how Ipopt ended, the
    regimes, the costate check, the re-simulation and the driver advice (all from ``summary.json``;
    SI or the unit its name carries)."""

    track: str
    train: str
    from_stop: str
    to_stop: str
    distance_m: float
    points: int                        # K, the grid nodes
    objective: str                     # energy, net_energy, time or mixed
    running_time_s: float
    traction_energy_kWh: float
    traction_energy_J_per_kg: float
    braking_energy_kWh: float
    regenerated_energy_kWh: float
    net_energy_kWh: float
    top_speed_kmh: float
    all_out_time_s: Optional[float]    # when the all-out run was solved on the way
    marginal_energy_kWh_per_s: Optional[float]  # dE/dT at the optimum (energy objectives)
    regime_sequence: str               # e.g. "MA CR CO MB"
    regimes: tuple[RegimeRun, ...]
    solver: SolverRun
    pontryagin: Optional[PontryaginCheck]
    verification: Optional[Verification]  # None: not re-simulated
    das: Optional[DasSummary] = None
    distance_shares: Mapping[str, float] = field(default_factory=dict)  # regime -> share of the distance [-]
    time_cap_s: Optional[float] = None  # a mixed run with no arrival window: the longest time it could choose

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "RunSummary":
        """The typed run of a ``summary.json`` mapping (a run's ``summary``, or the file read back)."""
        regimes = data.get("regimes") or {}
        pm, ver, das = data.get("pontryagin"), data.get("verification"), data.get("das")
        return cls(track=str(data["track"]), train=str(data["train"]), from_stop=str(data["from"]),
                   to_stop=str(data["to"]), distance_m=float(data["distance_m"]), points=int(data["points"]),
                   objective=str(data["objective"]), running_time_s=float(data["running_time_s"]),
                   traction_energy_kWh=float(data["traction_energy_kWh"]),
                   traction_energy_J_per_kg=float(data["traction_energy_J_per_kg"]),
                   braking_energy_kWh=float(data["braking_energy_kWh"]),
                   regenerated_energy_kWh=float(data["regenerated_energy_kWh"]),
                   net_energy_kWh=float(data["net_energy_kWh"]), top_speed_kmh=float(data["top_speed_kmh"]),
                   all_out_time_s=_opt(data, "all_out_time_s"),
                   marginal_energy_kWh_per_s=_opt(data, "marginal_energy_kWh_per_s"),
                   regime_sequence=str(regimes.get("sequence", "")),
                   regimes=tuple(RegimeRun.from_dict(r) for r in regimes.get("runs") or ()),
                   solver=SolverRun.from_dict(data["solver"]),
                   pontryagin=None if not pm else PontryaginCheck.from_dict(pm),
                   verification=None if ver is None else Verification.from_dict(ver),
                   das=None if not das else DasSummary.from_dict(das),
                   distance_shares={str(k): float(v) for k, v in (regimes.get("distance_shares") or {}).items()},
                   time_cap_s=_opt(data, TIME_CAP))


def _error(value: float, name: str) -> str:
    """A re-simulation error with its sign, three decimals, or as many more as show it beyond its
    tolerance (:data:`core.status.TOLERANCES`): a stop 1.0004 m off reads -1.0004, not -1.000."""
    text = _beyond(value, TOLERANCES[name], signed(value, 3))
    return text if text.startswith(("-", "+")) else "+" + text


def _beyond(value: float, tolerance: float, within: str) -> str:
    """``within`` (the value as written where it is within ``tolerance``), or the value with as many
    decimals as show it beyond (:func:`core.status.past`, from three)."""
    return within if abs(value) <= tolerance else past(value, tolerance, 3, "f")
