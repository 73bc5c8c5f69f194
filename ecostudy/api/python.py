"""The Python API's own objects: :func:`solve`, :func:`pareto` and :func:`replanner`, and their
results :class:`Solution` and :class:`Front` (re-exported by :mod:`ecostudy.api`).

A bad argument is refused before anything is solved with one :class:`~ecostudy.core.errors.InputError`
(``api.InputError``) whose lines name it: ``arguments: running_time: must be more than 0.0, not -5``.
"""
import numbers
from dataclasses import dataclass

import pandas as pd

from ecostudy.analysis.export import fixed_step
from ecostudy.analysis.single import RunResult, solve_run
from ecostudy.api.arguments import spelled
from ecostudy.api.outcome import shown
from ecostudy.core.defaults import FRONT_POINTS, RUN_POINTS
from ecostudy.core.errors import FieldError, InfeasibleError, InputError, TooFastError, finite_number, problem
from ecostudy.core.status import Judged, Status
from ecostudy.core.types import Timing, Track, Train, Window
from ecostudy.core.units import PERCENT
from ecostudy.io.folder import headline
from ecostudy.io.incode import built_problems
from ecostudy.io.loaders import chosen_stops
from ecostudy.io.runsummary import RunSummary
from ecostudy.ocp.problem import all_out, check_feasible, check_not_crawling, prepare
from ecostudy.ocp.restart import Replanner
from ecostudy.report.files import MAX_EXPORT_ROWS, write_run
from ecostudy.report.html import fragment
from ecostudy.studies.cases import refuse_mixed_fixed, refuse_mixed_weights
from ecostudy.studies.options import OBJECTIVES, check_options, checked_pair
from ecostudy.studies.pareto import sweep

WHERE = "arguments"  # what a refusal names instead of a file: ``arguments: points: ...``
ARGUMENTS = {"time": "running_time", "supplement": "supplement_percent", "supplement_max": "supplement_max_percent"}
ENERGIES = ("energy", "net_energy")  # what the points of a front minimise
FRONT_SHOWN = ["running_time_s", "supplement_pct", "traction_energy_kWh", "net_energy_kWh", "status"]


@dataclass(repr=False)
class Solution(Judged):
    """One solved and verified run."""

    run: RunResult

    def __repr__(self) -> str:
        return f"Solution({self.run.line()}; {self.status})"

    def _repr_html_(self) -> str:  # a notebook cell: the line, the status, the summary's values
        values = {k: v for k, v in self.summary.items() if not isinstance(v, (dict, list))}
        return fragment(f"Solution({self.run.line()})", str(self.status), values=values)

    @property
    def status(self) -> Status:
        """``ok``, or ``flagged`` with the reason (Ipopt not optimal, the re-simulation outside its
        tolerance, the driver advice off): :attr:`RunResult.status`."""
        return self.run.status

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

    def every(self, time_step_s=None, distance_step_m=None) -> pd.DataFrame:
        """The run every ``time_step_s`` seconds or every ``distance_step_m`` metres, the arrival the
        last row: ``ecostudy export``'s table (``analysis.export.fixed_step``) without a folder."""
        given = {n: v for n, v in (("time_step_s", time_step_s), ("distance_step_m", distance_step_m)) if v is not None}
        if len(given) != 1:
            raise InputError(problem(WHERE, "time_step_s/distance_step_m", "give one of them"))
        (name, step), = given.items()
        span = float(self.trajectory.time[-1] if time_step_s is not None else self.trajectory.nodes[-1])
        if not (isinstance(step, numbers.Real) and float(step) > 0 and span / float(step) <= MAX_EXPORT_ROWS):
            raise InputError(problem(WHERE, name, f"must be a number of at least {span / MAX_EXPORT_ROWS:.2g} (at "
                                     f"most {MAX_EXPORT_ROWS:,} rows), not {step!r}"))
        return fixed_step(self.trajectory, self.run.handle, time_step_s, distance_step_m)

    def plot(self, path=None):
        """Speed, gradient and handle against distance: a figure, or a PNG written to ``path``."""
        from ecostudy.report.plots import speed_plot
        return speed_plot(self.run, path)

    def save(self, out_dir, plot=True):
        """The folder ``ecostudy solve`` writes (inputs.json, profile.csv, summary.json, the figures,
        report.html) into ``out_dir``, which ``ecostudy check`` and ``export`` read; refused as the
        command refuses its ``--out`` (``report.files.write_run``), and for a run of a track or train
        built in code, which names no file to check it against."""
        return write_run(self.run, out_dir, plot)


@dataclass(repr=False)
class Front(Judged):
    """Energy against running time: one row per point (its ``status`` with the reason), and the
    runs themselves (each a :class:`Solution`)."""

    table: pd.DataFrame
    runs: list

    def head(self) -> str:
        s = self.runs[0].facts if self.runs else None
        return f"{len(self.table)} points" + (f", {s.from_stop} -> {s.to_stop}" if s else "")

    def __repr__(self) -> str:
        words = self.table.assign(status=[Status.parse(str(s)).kind for s in self.table["status"]])  # reasons: above
        return f"Front({self.head()}; {self.status})\n{shown(words, FRONT_SHOWN, reasons=True)}"

    def _repr_html_(self) -> str:  # a notebook cell: the line, the status, the points with their reasons
        return fragment(f"Front({self.head()})", str(self.status),
                        frame=self.table[[c for c in FRONT_SHOWN if c in self.table]])

    @property
    def status(self) -> Status:
        """The worst of the points' statuses, each reason after the point it belongs to (its row from 1
        and running time: ``flagged: point 1 (71.67 s): Ipopt ended ...; point 4 (90.12 s): ...``;
        :func:`~ecostudy.io.folder.headline`)."""
        return headline({f"point {i + 1}" + (f" ({t:.2f} s)" if finite_number(t) else ""): Status.parse(str(s))
                         for i, (t, s) in enumerate(zip(self.table["running_time_s"], self.table["status"]))},
                        "front.table lists each")

    def plot(self, path=None):
        from ecostudy.report.plots import pareto_plot
        return pareto_plot(self.table, path, self.runs[0].facts.train)


def _timing(running_time, supplement_percent, window):
    given = [x is not None for x in (running_time, supplement_percent, window)]
    if sum(given) > 1:
        raise InputError(problem(WHERE, "running_time/supplement_percent/window", "give one of them"))
    check_options(where=WHERE, spelled=ARGUMENTS, time=running_time, supplement=supplement_percent)
    if window is not None:
        try:
            earliest, latest = window
        except (TypeError, ValueError):
            raise InputError(problem(WHERE, "window", f"expected (earliest, latest) [s], not {window!r}"))
        window = checked_pair(earliest, latest, "window", ordered=True, where=WHERE)
    return Timing(running_time=running_time, window=window,
                  supplement=None if supplement_percent is None else supplement_percent * PERCENT)


def _check(objective, track=None, train=None, objectives=OBJECTIVES, **values):
    """Refuse a ``track`` or ``train`` that is not one (a path, a dict: load it first) or whose
    fields a file would be refused for (built or changed in code: :func:`~ecostudy.io.incode.built_problems`),
    an ``objective`` not among ``objectives`` and the numeric ``values``
    (:data:`~ecostudy.studies.options.OPTION_RANGES`' names, each required) that are None or out of
    range, naming the arguments."""
    lines = [problem(WHERE, name, f"a {kind.__name__} (api.load_{name}(path), or api.{name}_from_dict), not "
                                  f"{type(given).__name__} {given!r:.60}")
             for name, kind, given in (("track", Track, track), ("train", Train, train))
             if given is not None and not isinstance(given, kind)]
    if objective not in objectives:
        lines.append(problem(WHERE, "objective", f"expected one of {', '.join(objectives)}, not {objective!r}"))
    lines += [problem(WHERE, ARGUMENTS.get(name, name), "must be a number, not None") for name, value in values.items()
              if value is None]
    if not lines:
        lines = built_problems(train, track)
    if lines:
        raise InputError(lines)
    check_options(where=WHERE, spelled=ARGUMENTS, **values)


def _check_windows(windows, distance):
    """Refuse timing ``windows`` that are not :class:`Window` s of finite numbers strictly between the
    stops ``distance`` [m] apart, earliest <= latest and min_speed <= max_speed, at least 0 (the
    NLP raised Pyomo's errors on them), naming the window."""
    if isinstance(windows, Window) or not isinstance(windows, (list, tuple)):
        raise InputError(problem(WHERE, "windows", f"a list of Window, not {type(windows).__name__}"))
    lines = []
    for i, w in enumerate(windows):
        if not isinstance(w, Window):
            lines.append(problem(WHERE, f"windows[{i}]", f"a Window(distance, earliest, latest, min_speed, max_speed) "
                                 f"in m, s and m/s, not {type(w).__name__}"))
            continue
        values = [w.distance, w.earliest, w.latest, w.min_speed, w.max_speed]
        if not all(v is None or (finite_number(v) and v >= 0)
                   for v in values):
            lines.append(problem(WHERE, f"windows[{i}]", f"finite numbers at least 0, not {w}"))
        elif not 0 < w.distance < distance:
            lines.append(problem(WHERE, f"windows[{i}].distance", f"{w.distance:g} m is not strictly between the "
                                 f"stops (0 to {distance:g} m)"))
        elif (w.earliest is not None and w.latest is not None and w.earliest > w.latest) or (
                w.min_speed is not None and w.max_speed is not None and w.min_speed > w.max_speed):
            lines.append(problem(WHERE, f"windows[{i}]", f"earliest after latest or min_speed above max_speed: {w}"))
    if lines:
        raise InputError(lines)


def _weights(weights, objective):
    """The mixed objective's (w_t, w_e): ``weights`` (None: (1, 1)) two finite numbers >= 0, not both 0,
    given for ``objective`` mixed only (as ``ecostudy solve --weights``)."""
    if weights is None:
        return 1.0, 1.0
    if objective != "mixed":
        raise InputError(problem(WHERE, "weights", "weigh time against energy of objective 'mixed' only"))
    try:
        w_t, w_e = weights
    except (TypeError, ValueError):
        raise InputError(problem(WHERE, "weights", f"expected (time, energy) weights, not {weights!r}"))
    return checked_pair(w_t, w_e, "weights", nonnegative=True, where=WHERE)


def _named(exc, timing):
    """A timing no run meets (:class:`TooFastError`), named by the argument that set it."""
    field = ("running_time" if timing.running_time is not None else "supplement_percent"
             if timing.supplement is not None else "window")
    return InfeasibleError([problem(WHERE, field, p) for p in exc.problems])


@spelled
def solve(track, train, from_stop=None, to_stop=None, running_time=None, supplement_percent=None, window=None,
          objective="energy", points=RUN_POINTS, windows=(), weights=None):
    """The energy-optimal run (``objective`` ``energy``, ``net_energy``, ``time`` or ``mixed``)
    between two stops (default: the first and the last), for a running time [s], a supplement
    over the all-out time [%] or an arrival window (earliest, latest) [s]; verified by simulation.
    ``objective="time"`` is the all-out run (no timing); ``mixed`` weighs time against energy with
    ``weights`` (w_t [1/s], w_e [kg/J]; default (1, 1)), refused as ``ecostudy solve --weights`` is."""
    timing = _timing(running_time, supplement_percent, window)
    _check(objective, track, train, points=points)
    timed = any(x is not None for x in (running_time, supplement_percent, window))
    if objective == "time" and timed:  # it would be ignored
        raise InputError(problem(WHERE, "objective", "'time' finds the fastest run: it takes no running_time, "
                                 "supplement_percent or window"))
    refuse_mixed_fixed(objective, "running_time" if running_time is not None else
                       "supplement_percent" if supplement_percent is not None else None, WHERE, "objective")
    weights = _weights(weights, objective)
    refuse_mixed_weights(objective, weights, timed, WHERE, ("weights", "weights"))
    if objective in ("energy", "net_energy") and not timed:  # the optimum would crawl for days
        raise InputError(problem(WHERE, "running_time", "give running_time, supplement_percent or window (or "
                                 "objective='time' for the all-out run)"))
    from_stop, to_stop = chosen_stops(track, from_stop, to_stop, WHERE)
    _check_windows(windows, abs(track.stops[to_stop] - track.stops[from_stop]))
    try:
        return Solution(solve_run(track, train, from_stop, to_stop, timing, objective=objective, points=points,
                                  windows=windows, weights=weights))
    except TooFastError as exc:
        raise _named(exc, timing) from None
    except FieldError as exc:  # a window on the way no run keeps
        raise exc.in_file(WHERE) from None


@spelled
def pareto(track, train, from_stop=None, to_stop=None, count=20, supplement_max_percent=40.0, points=FRONT_POINTS,
           objective="energy", workers=1):
    """Energy against running time from the all-out run to ``supplement_max_percent`` over it."""
    _check(objective, track, train, ENERGIES, count=count, supplement_max=supplement_max_percent, points=points,
           workers=workers)
    from_stop, to_stop = chosen_stops(track, from_stop, to_stop, WHERE)
    table, runs = sweep(track, train, from_stop, to_stop, count=count, supplement_max=supplement_max_percent * PERCENT,
                        points=points, objective=objective, workers=workers)
    return Front(table, [Solution(r) for r in runs])


@spelled
def replanner(track, train, from_stop=None, to_stop=None, running_time=None, window=None, points=FRONT_POINTS,
              objective="energy"):
    """A :class:`~ecostudy.ocp.restart.Replanner`: one model re-solved from any :class:`State`; a
    running time (or window) no run from the departure meets is refused first, as :func:`solve` refuses it."""
    timing = _timing(running_time, None, window)
    _check(objective, track, train, points=points)
    if running_time is None and window is None:
        raise InputError(problem(WHERE, "running_time", "a re-planner needs a running time or an arrival window"))
    if objective == "time" and running_time is not None:  # the running time fixes the arrival: nothing to minimise
        raise InputError(problem(WHERE, "objective", "'time' plans the earliest arrival in a window: it takes no "
                                 "running_time"))
    from_stop, to_stop = chosen_stops(track, from_stop, to_stop, WHERE)
    case = prepare(track, train, from_stop, to_stop, points)
    latest = running_time if running_time is not None else timing.window[1]
    try:
        check_not_crawling(latest, case)
        if latest < 0.97 * case.estimate:  # as solve_run: below the envelope's time, the all-out run decides
            check_feasible(latest, all_out(case, {})[0])
    except TooFastError as exc:
        raise _named(exc, timing) from None
    return Replanner(case, running_time=running_time, window=timing.window, objective=objective)
