"""One run between two stops: build, solve, verify, tabulate. Stage times are recorded.

``solve_run`` is the library entry point behind ``ecostudy solve``.
"""
import time
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Hashable, Iterator, MutableMapping, NamedTuple, Protocol, Sequence

import numpy as np

from ecostudy.core import kinematics
from ecostudy.core.defaults import SLOWEST
from ecostudy.core.errors import FieldError, InfeasibleError, SolverError, TooFastError, WeightError
from ecostudy.core.grid import Segment, drop_idle_power, make_grid, make_segment, node_limits
from ecostudy.core.types import Track, Train, Trajectory, Window
from ecostudy.core.units import FloatArray, apart, to_kmh
from ecostudy.ocp import session
from ecostudy.ocp import space
from ecostudy.ocp.solver import Model
from ecostudy.ocp.space import Guess

Stages = MutableMapping[str, float]  # seconds per stage (and the Ipopt iterations) of a run


class Solved(Protocol):
    """Any earlier result a warm start reads: its trajectory in SI."""

    @property
    def trajectory(self) -> Trajectory: ...


@contextmanager
def stage(stages: Stages, name: str) -> Iterator[None]:
    t0 = time.perf_counter()
    yield
    stages[name] = stages.get(name, 0.0) + time.perf_counter() - t0


@dataclass
class Case:
    """One segment prepared for solving: profiles, grid, node limits and the fastest envelope."""

    track: Track
    train: Train
    segment: Segment
    nodes: np.ndarray
    limits: np.ndarray
    envelope: np.ndarray   # fastest speeds on the grid [m/s] (kinematics.envelope_speeds)
    estimate: float        # running time of that envelope [s], close to the all-out time
    windows: tuple[Window, ...] = ()  # core.types.Window timing points, each on a node
    idle_power: tuple[str, ...] = ()  # the envelopes whose power limit never binds here, dropped from ``train``


def prepare(track: Track, train: Train, from_stop: str, to_stop: str, points: int, stages: Stages | None = None,
            windows: Sequence[Window] = ()) -> Case:
    """Segment between two stops, grid of ``points`` nodes, limits and the fastest envelope. A power
    limit that never binds on the segment is left out of the case's train (``grid.drop_idle_power``):
    every formulation built from the case (space, time-domain, phases, blocked) then has no row for it."""
    with stage(stages if stages is not None else {}, "grid"):
        segment = make_segment(track, train, from_stop, to_stop)
        train, idle = drop_idle_power(segment, train, "the optimisation")
        nodes = make_grid(segment, points, extra=[w.distance for w in windows])
        limits = node_limits(segment, nodes)
        envelope = kinematics.envelope_speeds(segment, train, nodes, limits)
    return Case(track, train, segment, nodes, limits, envelope, kinematics.running_time(envelope, nodes),
                tuple(windows), idle)


def build(case: Case, guess: Guess, objective: str, stages: Stages, weights: tuple[float, float] = (1.0, 1.0),
          **timing: Any) -> Model:
    """The Pyomo model of ``case`` (``space.build_model``, built with the cyclic GC paused)."""
    with stage(stages, "build"):
        time_ref = max(kinematics.running_time(np.asarray(guess[0], float), case.nodes), 1.0)
        return space.build_model(case.segment, case.train, case.nodes, case.limits, guess,
                                       objective=objective, time_ref=time_ref, weights=weights,
                                       windows=case.windows, **timing)


def record(stages: Stages, outcome: session.Outcome, nl_seconds: float = 0.0) -> None:
    """Add one solve's NL-write and Ipopt times and iterations to ``stages``."""
    stages["nl_write"] = stages.get("nl_write", 0.0) + nl_seconds
    stages["solve"] = stages.get("solve", 0.0) + outcome.seconds
    stages["iterations"] = stages.get("iterations", 0) + outcome.iterations


class Written:
    """Written NLPs kept by structure for re-use: a solve that differs from an earlier one only in
    its running time (or window) and starting point changes the bounds of T and the start of the
    written model instead of building and writing it again (the NL write once per model
    structure). The caller names the structure (``key``): everything that changes the model but
    the timing (track, train, stops, grid, objective, weights). The ``size`` latest are kept."""

    def __init__(self, size: int = 4) -> None:
        self.size = size
        self.models: OrderedDict[Hashable, tuple[Model, session.Session]] = OrderedDict()

    def get(self, key: Hashable) -> tuple[Model, session.Session] | None:
        if key in self.models:
            self.models.move_to_end(key)
        return self.models.get(key)

    def put(self, key: Hashable, model: Model, nlp: session.Session) -> None:
        self.models[key] = (model, nlp)
        while len(self.models) > self.size:
            self.models.popitem(last=False)


def solve_once(case: Case, guess: Guess, objective: str, stages: Stages, options: session.Options | None,
               written: Written | None = None, key: Hashable | None = None,
               **timing: Any) -> tuple[Model, session.Outcome]:
    """Build, write and solve; or, with ``written`` holding ``key``, re-solve its written model
    from ``guess`` with this timing (no build, no NL write)."""
    kept = written.get((key, objective)) if written is not None and key is not None else None
    if kept is None:
        m = build(case, guess, objective, stages, **timing)
        nlp = session.Session(m)
        outcome = nlp.solve(options)
        record(stages, outcome, nlp.nl_seconds)
        if written is not None and key is not None:
            written.put((key, objective), m, nlp)
        return m, outcome
    m, nlp = kept
    with stage(stages, "build"):
        lo, hi = space.timing_bounds(timing.get("running_time"), timing.get("window"))
        nlp.set_bounds(m.T, lo, hi)
        nlp.set_start_values(*space.start_point(m, guess), clip=False)  # as a new model starts
    outcome = nlp.solve(options)
    record(stages, outcome)
    return m, outcome


def guess_from_speeds(case: Case, speeds: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(v, dt, F_T, F_B) on the grid realising ``speeds``: Ipopt's starting point."""
    dt = kinematics.interval_times(np.maximum(speeds, 5e-4), case.nodes)  # no infinite first/last step
    ft, fb = kinematics.forces_for(speeds, case.segment, case.train, case.nodes)
    return speeds, dt, ft, fb


def capped_guess(case: Case, running_time: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Fastest envelope capped at one cruise speed so that it takes ``running_time``."""
    return guess_from_speeds(case, kinematics.capped_speeds(case.envelope, case.nodes, running_time))


def warm_guess(previous: Solved, case: Case) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Starting point interpolated from a previous result's trajectory (speed vs position)."""
    run = previous.trajectory
    speeds = np.minimum(np.interp(case.nodes, run.nodes, run.v), case.limits)
    speeds[0] = speeds[-1] = 0.0
    return guess_from_speeds(case, speeds)


def all_out(case: Case, stages: Stages, options: session.Options | None = None) -> tuple[float, Model, session.Outcome]:
    """Minimum running time on this grid [s], the solved model and Ipopt's outcome."""
    m, outcome = solve_once(case, guess_from_speeds(case, case.envelope), "time", stages, options)
    if not outcome.usable and case.windows and outcome.status in ("infeasible", "restoration_failed"):
        points = ", ".join(f"{w.distance:.0f} m" for w in case.windows)
        # the windows passed the fastest envelope's check (``check_windows``): the grid may be too coarse
        raise FieldError(f"infeasible on this grid of {len(case.nodes)} nodes: no run on it keeps the timing "
                         f"windows at {points} from {case.segment.from_stop} (Ipopt: {outcome.status}), though "
                         "the fastest envelope does: try more points", "windows")
    if not outcome.usable:
        raise SolverError(f"Ipopt could not find the all-out run ({outcome.status})")
    return float(np.sum(space.solution_arrays(m)[1])), m, outcome


def capped_limits(case: Case) -> FloatArray:
    """The speed limit at each node [m/s] with every timing window's speed cap (``max_speed``) on its node."""
    limits = case.limits.copy()
    for w in case.windows:
        if w.max_speed is not None:
            k = space.window_node(case.nodes, w.distance)
            limits[k] = min(limits[k], w.max_speed)
    return limits


def _fastest_passing(case: Case) -> tuple[list[int], FloatArray, FloatArray]:
    """The windows' nodes, and the fastest envelope (with every window's speed cap) and its clock [s]."""
    index = [space.window_node(case.nodes, w.distance) for w in case.windows]
    fastest = kinematics.envelope_speeds(case.segment, case.train, case.nodes, capped_limits(case))
    return index, fastest, kinematics.clock(fastest, case.nodes)


def check_windows(case: Case, margin: float = 0.02) -> None:
    """Refuse at once a timing window no run can keep: passing later than ``latest`` even on the
    fastest envelope (with every window's speed cap), or a minimum speed above that envelope.
    Within ``margin`` of these bounds the NLP decides (the envelope is an explicit estimate)."""
    if not case.windows:
        return
    index, fastest, passing = _fastest_passing(case)
    for i, (k, w) in enumerate(zip(index, case.windows)):
        if w.latest is not None and w.latest < (1 - margin) * passing[k]:
            raise FieldError(f"infeasible: the fastest run passes {w.distance:.0f} m from "
                             f"{case.segment.from_stop} at {passing[k]:.1f} s (window: by {w.latest:.1f} s)",
                             f"windows[{i}].latest_s")
        if w.min_speed is not None and w.min_speed > (1 + margin) * fastest[k]:
            raise FieldError(f"infeasible: at {w.distance:.0f} m from {case.segment.from_stop} the train "
                             f"reaches at most {to_kmh(fastest[k]):.1f} km/h (window: at least "
                             f"{to_kmh(w.min_speed):.1f} km/h)", f"windows[{i}].min_speed_kmh")
    order = sorted(range(len(case.windows)), key=lambda i: case.windows[i].distance)  # as the run passes them
    check_times_reachable([Passing(case.windows[i].distance, f"the timing point at {case.windows[i].distance:g} m",
                                   case.windows[i].earliest, case.windows[i].latest, float(passing[index[i]]), 0.0,
                                   (f"windows[{i}].earliest_s", f"windows[{i}].latest_s")) for i in order], margin)


def check_arrival(case: Case, earliest: float | None, latest: float | None, margin: float = 0.02) -> None:
    """Refuse, before solving, an arrival (not before ``earliest``, not after ``latest`` [s]; None: not
    bounded) that a timing window on the way contradicts: a window's earliest passing plus the fastest
    run from there to the stop (less ``margin`` of it, as :func:`check_windows`) after the latest
    arrival; or an arrival so long after a window's latest passing that the rest of the run would crawl
    (over :data:`SLOWEST` times the fastest envelope's time from the window to the stop, as
    :func:`check_not_crawling` for the whole run). A :class:`TooFastError`: the arrival time is refused
    where it was given, the window named in the line (the windows among themselves: :func:`check_windows`)."""
    if not case.windows:
        return
    index, _, passing = _fastest_passing(case)
    for k, w in zip(index, case.windows):  # from a point passed by its latest time, the rest crawled
        rest = float(passing[-1] - passing[k])
        if earliest is not None and w.latest is not None and earliest - w.latest > SLOWEST * rest:
            raise TooFastError(f"the timing point at {w.distance:g} m (passed by {w.latest:g} s) and the arrival at "
                               f"{case.segment.to_stop} (not before {earliest:g} s) leave at least "
                               f"{earliest - w.latest:g} s for the last {case.segment.distance - w.distance:g} m, over "
                               f"{SLOWEST:g} times the fastest run's {rest:.1f} s there: the train would crawl")
    if latest is None:
        return
    order = sorted(range(len(case.windows)), key=lambda i: case.windows[i].distance)
    passings = [Passing(case.windows[i].distance, f"the timing point at {case.windows[i].distance:g} m",
                        case.windows[i].earliest, None, float(passing[index[i]]), 0.0, ("", "")) for i in order]
    arrival = Passing("arrival", f"the arrival at {case.segment.to_stop}", earliest, latest, float(passing[-1]), 0.0,
                      ("", ""))
    try:
        check_times_reachable([*passings, arrival], margin)
    except FieldError as exc:
        raise TooFastError(exc.problems) from None


class Passing(NamedTuple):
    """A time a run keeps on its way (a timing point, a departure, an arrival), for
    :func:`check_times_reachable`: ``place`` (two at one place are passed together), ``what`` it is
    (as a line names it), ``earliest`` and ``latest`` [s] (None: not bounded), the ``fastest``
    clock there [s since the start: on the fastest-speed envelope, which no run beats], the least
    ``dwells`` since the start [s] and the ``fields`` of its earliest and latest time."""

    place: Hashable
    what: str
    earliest: float | None
    latest: float | None
    fastest: float
    dwells: float
    fields: tuple[str, str]


def check_times_reachable(passings: Sequence[Passing], margin: float = 0.0) -> None:
    """Refuse, in one line naming both, two times no run can keep (``passings`` in the order a run
    passes them): the latest time of the later one less the earliest of the earlier one must leave
    the fastest run between them (less ``margin`` of it: within that the NLP decides) plus the least
    dwells in between; two at one place are held to each other both ways. The worst pair is said."""
    worst: tuple[float, Passing, float, Passing, float, float, float] | None = None
    for i, a in enumerate(passings):
        for j, b in enumerate(passings):
            if a.earliest is None or b.latest is None or not (j > i or (j != i and b.place == a.place)):
                continue
            need, dwelt = (1 - margin) * (b.fastest - a.fastest), b.dwells - a.dwells
            short = need + dwelt - (b.latest - a.earliest)
            if short > 1e-6 and (worst is None or short > worst[0]):
                worst = (short, a, a.earliest, b, b.latest, need, dwelt)
    if worst is not None:
        _, a, lo, b, hi, need, dwelt = worst
        between = ("one place is passed at one time" if b.place == a.place else
                   f"the fastest run between them takes {need:.0f} s" + (f" and the dwells {dwelt:g} s" if dwelt > 0 else ""))
        raise FieldError(f"infeasible: {a.what} (not before {lo:g} s) and {b.what} (not after {hi:g} s) leave {hi - lo:g} "
                         f"s; {between}", ", ".join(dict.fromkeys((a.fields[0], b.fields[1]))))


def least_energy_weight(case: Case) -> float:
    """The least ratio w_e / w_t of the mixed objective w_t T + w_e E / Ms [s, J/kg] that prices energy
    as the all-out run's regularisation does (:data:`space.TIME_REGULARISATION` of the energy scale per
    running time, the fastest envelope's): below it energy is worth less to the NLP than that run's
    tie-break, the run is the fastest with traction and braking at once (the metro at K = 100, weights
    1,1e-6: 71.73 s, 12.346 kWh, re-simulated -12 %)."""
    return space.TIME_REGULARISATION * case.estimate * case.train.static_mass / space.energy_reference(case.train,
                                                                                                      case.segment)


def check_energy_weight(case: Case, weights: tuple[float, float]) -> None:
    """Refuse mixed ``weights`` (w_t, w_e) whose ratio is under :func:`least_energy_weight`."""
    least = least_energy_weight(case)
    if weights[1] < least * weights[0]:
        raise WeightError(f"an energy weight {weights[1] / weights[0]:.3g} times the time weight is below the "
                          f"{least:.2g} that prices energy on this train and line as the all-out run does: the run "
                          "would be the fastest one, with traction and braking at once; use objective time, or "
                          "raise the energy weight")


def slowest_time(case: Case) -> float:
    """The longest running time [s] solved: :data:`SLOWEST` times the fastest envelope's."""
    return SLOWEST * case.estimate


def check_not_crawling(latest: float | None, case: Case) -> None:
    """Refuse, before solving, a running time (or a window's latest arrival) over :func:`slowest_time`:
    its energy optimum crawls and fails its re-simulation."""
    if latest is not None and latest > slowest_time(case):
        raise TooFastError(crawling(f"{latest:.6g} s", case.estimate))


def crawling(asked: str, fastest: float) -> str:
    """Why a time ``asked`` over :data:`SLOWEST` times the fastest envelope's ``fastest`` [s] is refused:
    that envelope's time is named as such, not as the all-out NLP's (71.6 s beside its 71.7 s at K = 100)."""
    return (f"{asked} is over {SLOWEST:g} times the fastest possible run's {fastest:.1f} s (kinematic envelope): the "
            "train would crawl")


# a running time this far under the fastest envelope's (the grid's fastest speeds, no NLP) no run keeps:
# refused before any NLP is solved; nearer, the NLPs say it (an all-out NLP may run slightly faster)
ENVELOPE_MARGIN = 0.01


def under_envelope(asked: float, fastest: float) -> bool:
    """Whether ``asked`` [s] is under the fastest envelope's ``fastest`` [s] by more than :data:`ENVELOPE_MARGIN`."""
    return asked < (1 - ENVELOPE_MARGIN) * fastest


ALL_OUT_MARGIN = 1e-6  # a running time this much (relative) under the all-out run's is the all-out run's


def check_feasible(latest: float | None, t_allout: float) -> None:
    """Refuse a running time below the all-out run's (by more than :data:`ALL_OUT_MARGIN`), both shown
    with the digits that tell them apart."""
    if latest is not None and latest < t_allout * (1 - ALL_OUT_MARGIN):
        fastest, asked = apart(t_allout, latest)
        raise TooFastError(f"infeasible: the fastest possible run takes {fastest} s (asked for {asked} s)")


