"""One verified run between two stops: prepare, solve, then tables, regimes, the Pontryagin check
and the re-simulation. ``solve_run`` is the library entry point behind ``ecostudy solve``.
"""
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Optional

import numpy as np
import pandas as pd

from ecostudy.analysis import pontryagin, regimes
from ecostudy.analysis.summary import run_summary
from ecostudy.analysis.tables import handles, tabulate
from ecostudy.core.defaults import RUN_POINTS
from ecostudy.core.errors import SolverError
from ecostudy.core.simulate import verify
from ecostudy.core.status import Judged, Status
from ecostudy.core.types import Timing, Train, Trajectory, source_file
from ecostudy.core.units import KWH, number
from ecostudy.io.results import COSTATE_OBJECTIVES
from ecostudy.io.runsummary import ALL_OUT_SOLVER, TIME_CAP, RunSummary, run_status
from ecostudy.ocp import space
from ecostudy.ocp.problem import (
    all_out,
    capped_guess,
    check_arrival,
    check_energy_weight,
    check_feasible,
    check_not_crawling,
    check_windows,
    prepare,
    slowest_time,
    solve_once,
    stage,
    warm_guess,
)


# a run this close to the all-out time [relative] is the all-out run: its arrival multiplier is a
# degenerate problem's (118 kWh/s on the metro's 10.95 kWh run at supplement 0, 5.66 at +0.1 %, K = 300), no
# trade-off of energy against time, so it has no marginal energy (as the all-out run itself)
AT_ALL_OUT = 1e-6


class Request(NamedTuple):
    """What a run was solved for, as its ``inputs.json`` records it (``analysis.saved.run_inputs``):
    the files its track and train were read from (``io.documents.source_file``: None for one built
    in code), the timing and the mixed objective's weights (the timing windows: ``RunResult.windows``)."""

    track_file: Optional[tuple[str, str]]
    train_file: Optional[tuple[str, str]]
    timing: Timing
    weights: tuple


@dataclass(repr=False)  # the repr is one line (:meth:`line`), not the profile's thousand rows
class RunResult(Judged):
    """A solved, analysed and verified run: the profile table (display units), the summary
    (``summary.json``), the grid, the handle per interval, the re-simulated trace and the SI
    :class:`Trajectory` and the timing points on the way it was solved for (``windows``: the
    case's, :class:`~ecostudy.core.types.Window` s)."""

    profile: pd.DataFrame
    summary: dict
    segment: object
    train: Train
    nodes: np.ndarray
    handle: np.ndarray
    trace: object = None
    stages: dict = field(default_factory=dict)
    das: Any = None  # das.advice.DasRun when a DAS method was asked for
    trajectory: Optional[Trajectory] = None  # the run in SI arrays: read these, not the display table
    request: Optional[Request] = None  # what :func:`solve_run` was asked (None: a point a front re-solved)
    windows: tuple = ()  # the timing points on the way (the case's): the ATO run and any advice are judged on them

    @property
    def facts(self) -> RunSummary:
        """The run's summary typed (times, energies, solver, regimes, checks, driver advice): read
        ``facts.traction_energy_kWh``, not ``summary["traction_energy_kWh"]``."""
        return RunSummary.from_dict(self.summary)

    @property
    def status(self) -> Status:
        """``ok`` when Ipopt proved optimality (of the all-out run too, where the running time is a
        supplement over it: :data:`ALL_OUT_SOLVER`), the independent re-simulation agrees, the
        driver advice (when asked for) keeps the stop, the time and the limits as driven and the
        train is not one of a calibration that was flagged (:func:`~ecostudy.core.status.calibrated`);
        else ``flagged`` with what did not pass."""
        return run_status(self.summary, None if self.das is None else self.das.summary,  # not summary["das"]:
                          self.train.calibration_reason)  # a study may put a table row there

    def line(self) -> str:
        """The run in a few words: stops, distance, K, objective, running time and energies (its
        repr adds the status)."""
        s = self.facts
        return (f"{s.from_stop} -> {s.to_stop}, {s.distance_m:.0f} m, K = {s.points}, {s.objective}: "
                f"{s.running_time_s:.2f} s, traction {s.traction_energy_kWh:.3f} kWh, net {number(s.net_energy_kWh)} kWh")

    def __repr__(self) -> str:
        return f"RunResult({self.line()}; {self.status})"


def solve_run(track, train, from_stop, to_stop, timing=Timing(), objective="energy", points=RUN_POINTS,
              weights=(1.0, 1.0), warm_start=None, options=None, verify_result=True, windows=(),
              written=None, structure=None):
    """Energy-optimal (or all-out, or mixed) run between two stops, verified by simulation.

    Parameters
    ----------
    timing : Timing  running time [s], supplement over the all-out time [-], or window [s].
    objective : str  ``energy``, ``net_energy``, ``time`` (all-out) or ``mixed``.
    points : int  Grid nodes K.
    warm_start : RunResult, optional  Start Ipopt from this earlier result.
    windows : sequence of core.types.Window  Timing points on the way (earliest/latest, speed bounds).
    written, structure : ocp.problem.Written and the key naming this run's model but its timing
        (track, train, stops, grid, weights): re-solve a model written for an earlier run.
    """
    stages = {}
    case = prepare(track, train, from_stop, to_stop, points, stages, windows)
    check_windows(case)
    if objective == "mixed":
        check_energy_weight(case, weights)
    target, window, t_allout, fastest = timing.running_time, timing.window, None, None
    latest = target if target is not None else (window[1] if window else None)
    check_not_crawling(latest, case)
    check_arrival(case, target if target is not None else (window[0] if window else None), latest)
    # the time the mixed weights choose: not past the crawl (a time weight of 1e-9 against 1 chose 27 h)
    cap = slowest_time(case) if objective == "mixed" and latest is None else None
    if objective == "time" or timing.supplement is not None or (latest is not None and latest < 0.97 * case.estimate):
        t_allout, m, fastest = all_out(case, stages, options)
        outcome = fastest
        if timing.supplement is not None:
            target = t_allout * (1 + timing.supplement)
        check_feasible(latest, t_allout)

    if objective != "time":
        if warm_start is not None:
            guess = warm_guess(warm_start, case)
        else:
            guess = capped_guess(case, target or (window[1] if window else case.estimate * 1.1))
        kw = ({"running_time": target} if target is not None else {"window": window} if window else
              {"window": (0.0, cap)} if cap is not None else {})
        m, outcome = solve_once(case, guess, objective, stages, options, written, structure, weights=weights, **kw)
        if not outcome.usable:
            if latest is not None and t_allout is None:
                t_allout, _, _ = all_out(case, stages, options)
                check_feasible(latest, t_allout)
            raise SolverError(f"Ipopt failed ({outcome.status}) after {outcome.iterations} iterations; "
                              "try more --points or a longer running time")
    result = finish(case, m, outcome, stages, objective, t_allout, verify_result)
    if timing.supplement is not None and outcome is not fastest and not fastest.optimal:  # its time is a supplement over it
        result.summary[ALL_OUT_SOLVER] = fastest.status
    if cap is not None:  # a run at it is flagged (io.runsummary.status_parts)
        result.summary[TIME_CAP] = cap
    result.request = Request(source_file(track), source_file(train), timing, tuple(weights))
    return result


def with_all_out(summary, t_allout):
    """``summary`` with the all-out time ``t_allout`` [s] (None: not known, left as it is), and no
    marginal energy when its run is at that time (:data:`AT_ALL_OUT`)."""
    if t_allout is not None:
        summary["all_out_time_s"] = t_allout
        if summary["running_time_s"] <= t_allout * (1 + AT_ALL_OUT):
            summary["marginal_energy_kWh_per_s"] = None
    return summary


def finish(case, m, outcome, stages, objective, t_allout=None, verify_result=True):
    """Tables, regimes and verification of a solved model: the :class:`RunResult`."""
    train, segment, nodes = case.train, case.segment, case.nodes
    with stage(stages, "tables"):
        v, dt, ft, fb, _ = space.solution_arrays(m)
        u = handles(train, v, ft, fb)
        profile, totals = tabulate(train, nodes, v, dt, ft, fb)
        labels = regimes.labelled(train, v, ft, fb, objective)
        costate = None
        if objective in COSTATE_OBJECTIVES:  # psi = lambda / v of eq. 2.17 (7.4) from Ipopt's multipliers
            psi = pontryagin.ipopt_psi(m, nodes, train, objective)
            costate = {"method": "Ipopt multipliers of the speed recursion",
                       "conditions": ("Farooqi 2018, eq. 7.4 (regeneration credited)" if objective == "net_energy"
                                      else "Farooqi 2018, eq. 2.17"),
                       **pontryagin.costate_check(train, nodes, v, ft, fb, labels, psi, objective)}
            profile["costate_ratio"] = np.append(psi, np.nan)
        marginal = space.marginal_energy(m) if objective in COSTATE_OBJECTIVES else None
    verification, trace = None, None
    if verify_result:
        with stage(stages, "verify"):
            verification, trace = verify(segment, train, nodes, u, totals["running_time_s"],
                                         totals["traction_energy_kWh"] * KWH, case.windows,
                                         net_energy=totals["net_energy_kWh"] * KWH)
    summary = with_all_out(run_summary(case, totals, objective, t_allout, marginal, labels, costate,
                                     outcome, verification, stages), t_allout)
    return RunResult(profile, summary, segment, train, nodes, u, trace, stages,
                     trajectory=Trajectory(nodes, v, dt, ft, fb), windows=tuple(case.windows))
