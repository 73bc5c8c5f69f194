"""The Python API's own objects: :func:`solve`, :func:`pareto` and :func:`replanner`, and their
results :class:`Solution` and :class:`Front` (re-exported by :mod:`ecostudy.api`)."""
from dataclasses import dataclass

import pandas as pd

from ecostudy.analysis.single import RunResult, solve_run
from ecostudy.core.defaults import FRONT_POINTS, RUN_POINTS
from ecostudy.core.errors import InputError
from ecostudy.core.types import Timing
from ecostudy.core.units import PERCENT
from ecostudy.io.loaders import chosen_stops
from ecostudy.io.runsummary import RunSummary
from ecostudy.ocp.problem import prepare
from ecostudy.ocp.restart import Replanner
from ecostudy.report.files import write_run
from ecostudy.studies.pareto import sweep


@dataclass
class Solution:
    """One solved and verified run."""

    run: RunResult

    @property
    def profile(self):
        """Per grid node: SI columns (``speed_mps``, ``traction_force_N``, ...) beside the display
        columns of ``profile.csv`` (``speed_kmh``, ``traction_force_kN``, ...)."""
        traj = self.run.trajectory
        pad = lambda a: list(a) + [float("nan")]  # noqa: E731  interval values sit on their first node
        si = pd.DataFrame({"speed_mps": traj.v, "traction_force_N": pad(traj.ft), "braking_force_N": pad(traj.fb),
                           "interval_time_s": pad(traj.dt)})
        return pd.concat([self.run.profile, si], axis=1)

    @property
    def summary(self):
        """The ``summary.json`` dict: energies, running time, regimes, solver, verification."""
        return self.run.summary

    @property
    def facts(self) -> RunSummary:
        """The summary typed: ``facts.running_time_s``, ``facts.traction_energy_kWh``, ``facts.solver``,
        ``facts.verification``, ... (units in the names, as in ``summary.json``)."""
        return self.run.facts

    @property
    def verification(self):
        """Re-simulation against the optimum, the ``verification`` block of ``summary.json`` as a
        dict (arrival, stop, energy, overspeed, passed); typed: ``facts.verification``."""
        return self.summary["verification"]

    @property
    def trajectory(self):
        """The run in SI arrays (:class:`~ecostudy.core.types.Trajectory`)."""
        return self.run.trajectory

    def plot(self, path=None):
        """Speed, gradient and handle against distance: a figure, or a PNG written to ``path``."""
        from ecostudy.report.plots import speed_plot
        return speed_plot(self.run, path)

    def save(self, out_dir, plot=True):
        """The files of ``ecostudy solve`` (profile.csv, summary.json, speed.png) into ``out_dir``."""
        return write_run(self.run, out_dir, plot)


@dataclass
class Front:
    """Energy against running time: one row per point, and the runs themselves."""

    table: pd.DataFrame
    runs: list

    def plot(self, path=None):
        from ecostudy.report.plots import pareto_plot
        return pareto_plot(self.table, path, self.runs[0].facts.train)


def _timing(running_time, supplement_percent, window):
    given = [x is not None for x in (running_time, supplement_percent, window)]
    if sum(given) > 1:
        raise InputError("arguments: give one of running_time, supplement_percent, window")
    return Timing(running_time=running_time, window=window,
                  supplement=None if supplement_percent is None else supplement_percent * PERCENT)


def solve(track, train, from_stop=None, to_stop=None, running_time=None, supplement_percent=None, window=None,
          objective="energy", points=RUN_POINTS, windows=()):
    """The energy-optimal run (``objective`` ``energy``, ``net_energy``, ``time`` or ``mixed``)
    between two stops (default: the first and the last), for a running time [s], a supplement
    over the all-out time [%] or an arrival window (earliest, latest) [s]; verified by simulation."""
    from_stop, to_stop = chosen_stops(track, from_stop, to_stop, "arguments")
    return Solution(solve_run(track, train, from_stop, to_stop, _timing(running_time, supplement_percent, window),
                              objective=objective, points=points, windows=windows))


def pareto(track, train, from_stop=None, to_stop=None, count=20, supplement_max_percent=40.0, points=FRONT_POINTS,
           objective="energy", workers=1):
    """Energy against running time from the all-out run to ``supplement_max_percent`` over it."""
    from_stop, to_stop = chosen_stops(track, from_stop, to_stop, "arguments")
    table, runs = sweep(track, train, from_stop, to_stop, count=count, supplement_max=supplement_max_percent * PERCENT,
                        points=points, objective=objective, workers=workers)
    return Front(table, runs)


def replanner(track, train, from_stop=None, to_stop=None, running_time=None, window=None, points=FRONT_POINTS,
              objective="energy"):
    """A :class:`~ecostudy.ocp.restart.Replanner`: one model re-solved from any :class:`State`."""
    from_stop, to_stop = chosen_stops(track, from_stop, to_stop, "arguments")
    return Replanner(prepare(track, train, from_stop, to_stop, points), running_time=running_time, window=window,
                     objective=objective)
