"""Re-solving one built space-domain model from any state, towards any terminal condition.

A controller on board re-plans many times per trip from wherever the train is. Writing the NL
file is the dearest stage of a solve (docs/benchmarks.md), so a movable model
(:func:`ecostudy.ocp.space.build_model` with ``movable=True``) is written once on the whole grid
and every re-plan changes bounds only:

- the start (x0, v0, t0): intervals already run get the share w_k = 0 (then the speed and time
  recursions give v_k+1 = v_k and dt_k = 0, their forces are held at 0), the interval holding x0
  the share of it still to run, the others 1; the speed at node 0 is v0 and the clock t0;
- the terminal condition at the end of the grid: a speed range (a stop is [0, 0]) and the
  arrival time, fixed or a window.

The multiplied-through recursions (``space.define_dynamics``) are what make a zero share regular.
The DAS phases NLP (``ocp.phases.build(movable=True)``) re-plans the same way by sector shares
(:func:`set_phases_start`).
"""
import math
from typing import Any, NamedTuple, Sequence

import numpy as np

from ecostudy.core.errors import InputError, finite_number, problem
from ecostudy.core.grid import interval_of
from ecostudy.core.status import OVERSPEED_TOLERANCE_KMH, Judged, Status, from_checks, solver_check
from ecostudy.core.types import State, Train
from ecostudy.core.units import KMH, FloatArray, to_kwh
from ecostudy.ocp import space
from ecostudy.ocp.phases import Layout
from ecostudy.ocp.problem import Case, Stages, build, capped_guess
from ecostudy.ocp.session import Options, Outcome, Session
from ecostudy.ocp.solver import Model, Var


def off_segment(position: float, end: float) -> str | None:
    """Why a start ``position`` [m] is not on a segment ``end`` [m] long, else None."""
    if not 0.0 <= position < end:
        return f"the position {position:.1f} m is not on the segment [0, {end:.1f}) m"
    return None


def _on_segment(position: float, end: float) -> None:
    why = off_segment(position, end)
    if why is not None:
        raise InputError(problem("arguments", "state", why))


def start_interval(nodes: FloatArray, position: float) -> tuple[int, float]:
    """(k, share): the interval holding ``position`` [m] and the share of it still to run."""
    _on_segment(position, nodes[-1])
    k = interval_of(nodes, position)
    return k, float((nodes[k + 1] - position) / (nodes[k + 1] - nodes[k]))


def _start_speeds(m: Model, first: int, speed: float,
                  ceiling: FloatArray | None = None) -> tuple[list[Var], list[float], list[float]]:
    """(variables, lows, highs) of the node speeds but the last (the terminal condition's):
    node 0 is the measured ``speed``; nodes up to ``first`` (already run, or the start itself)
    may carry it even above the limit behind; the others keep their limits, lifted to
    ``ceiling[k]`` where given."""
    variables: list[Var] = []
    lows: list[float] = []
    highs: list[float] = []
    for k in range(len(m.K) - 1):
        lo, hi = m.base_bounds["v"][k]
        if k <= first:
            lo, hi = (speed, speed) if k == 0 else (0.0, max(hi, speed))
        elif ceiling is not None:
            hi = max(hi, float(ceiling[k]))
        variables.append(m.v[k])
        lows.append(lo)
        highs.append(hi)
    return variables, lows, highs


def set_start(session: Session, m: Model, nodes: FloatArray, state: State, train: Train | None = None) -> None:
    """Bounds of a movable model for a run starting at ``state`` (:class:`State`, SI). With the
    ``train`` given, speed limits ahead that the measured speed cannot meet even under full
    braking are lifted to the speed braking reaches there."""
    k, rest = start_interval(nodes, state.position)
    behind = [j for j in getattr(m, "window_nodes", []) if j <= k]
    if behind:
        raise InputError(problem("arguments", "state", f"a timing window at {nodes[behind[0]]:.0f} m lies behind the "
                                 f"start at {state.position:.1f} m: drop the windows already passed"))
    n = len(nodes) - 1
    shares = np.ones(n)
    shares[:k], shares[k] = 0.0, rest
    # a measured speed above a limit ahead that even full braking cannot meet in time: the limit
    # there is lifted to what braking reaches (as a soft overspeed would be), so a plan exists
    reach = None
    if train is not None:
        braking = 0.9 * train.braking.force(max(state.speed, 0.0)) / (train.mass * m.mass_scale.ub)
        reach = np.sqrt(np.maximum(state.speed ** 2 - 2 * braking * np.maximum(nodes - state.position, 0.0), 0.0))
    variables, lows, highs = _start_speeds(m, k, state.speed, reach)
    variables, lows, highs = [m.t0] + variables, [state.time] + lows, [state.time] + highs
    for name in ("ft", "fb", "fr"):
        if name in m.base_bounds:
            var = getattr(m, name)
            for j in range(n):
                variables.append(var[j])
                lows.append(0.0)
                highs.append(m.base_bounds[name][j][1] if j >= k else 0.0)
    variables += [m.w[j] for j in range(n)]
    lows += shares.tolist()
    highs += shares.tolist()
    session.set_many_bounds(variables, lows, highs)
    session.set_start_values([m.v[j] for j in range(k + 1)] + [m.dt[j] for j in range(k)],
                             [state.speed] * (k + 1) + [0.0] * k)


def set_phases_start(session: Session, m: Model, layout: Layout, state: State) -> None:
    """Bounds of a movable phases NLP (``ocp.phases.build(movable=True)``) for a run from ``state``:
    the sectors behind it filled to share 0 (their phases length 0, the speed carried through
    unchanged), the sector holding it to the share still to run."""
    secs = layout.sectors
    _on_segment(state.position, secs[-1].end)
    s0 = next(s for s, sec in enumerate(secs) if state.position < sec.end)
    shares = [0.0] * s0 + [(secs[s0].end - state.position) / secs[s0].length] + [1.0] * (len(secs) - s0 - 1)
    first = next(q for q, (s, _) in enumerate(layout.phases) if s >= s0) * layout.substeps  # first node of s0
    variables, lows, highs = _start_speeds(m, first, state.speed)
    session.set_many_bounds([m.t0] + [m.share[s] for s in m.S] + variables,
                            [state.time] + shares + lows, [state.time] + shares + highs)
    behind = [q for q, (s, _) in enumerate(layout.phases) if s < s0]
    session.set_start_values([m.L[q] for q in behind] + [m.v[k] for k in range(first + 1)],
                             [0.0] * len(behind) + [state.speed] * (first + 1))


def set_end(session: Session, m: Model, speed: tuple[float, float] = (0.0, 0.0),
            arrival: float | Sequence[float] | None = None) -> None:
    """Terminal speed range [m/s] at the end of the grid, and the arrival time [s] on the clock of
    the start: a number (exact) or (earliest, latest); None leaves the arrival as it is. For the
    space-domain and the phases NLP alike."""
    variables: list[Var] = [m.v[len(m.K) - 1]]
    lows: list[float | None] = [speed[0]]
    highs: list[float | None] = [speed[1]]
    if arrival is not None:
        if isinstance(arrival, (int, float, np.integer, np.floating)):
            lo = hi = float(arrival)
        else:
            lo, hi = arrival
        variables.append(m.T)
        lows.append(lo)
        highs.append(hi)
    session.set_many_bounds(variables, lows, highs)


def set_mass(session: Session, m: Model, scale: float) -> None:
    """The train's mass (inertial and static) as ``scale`` times the model's, e.g. from an estimator."""
    session.set_bounds(m.mass_scale, scale, scale)


class PlanArrays(NamedTuple):
    """A re-plan on the whole grid: node speeds, interval times, forces [N] and shares still to run;
    ``segment``: 'from -> to' of the case planned."""

    nodes: np.ndarray
    v: np.ndarray
    dt: np.ndarray
    ft: np.ndarray
    fb: np.ndarray
    shares: np.ndarray
    start_time: float
    outcome: Outcome
    segment: str = ""
    limits: np.ndarray | None = None  # the speed limit at each node [m/s] (None: not judged against them)
    start_limit: float = math.inf     # the speed limit where it starts [m/s]


class Plan(PlanArrays, Judged):
    """A re-plan (:class:`PlanArrays`) that says in a line where it starts, where it ends, the
    traction still to do and its status: ``ok`` when Ipopt proved it optimal and it keeps the speed
    limits, else ``flagged`` with why (Ipopt's end; :func:`overspeeds`). A plan is not re-simulated: a
    run is, :attr:`ecostudy.analysis.single.RunResult.status`."""

    @property
    def time(self) -> FloatArray:
        """Clock at every node [s] (nodes already run sit at the start time)."""
        return self.start_time + np.concatenate([[0.0], np.cumsum(self.dt)])

    @property
    def traction_energy(self) -> float:
        """Traction work still to do [J]: sum F_T w ds over the intervals ahead."""
        return float(np.sum(self.ft * self.shares * np.diff(self.nodes)))

    @property
    def start(self) -> State:
        """The state it planned from: the position the shares still to run give, the speed at node 0, the clock."""
        k = int(np.argmax(self.shares > 0.0))
        position = self.nodes[k + 1] - self.shares[k] * (self.nodes[k + 1] - self.nodes[k])
        return State(float(position), float(self.v[0]), float(self.start_time))

    @property
    def status(self) -> Status:
        return from_checks({**solver_check(self.outcome.status), **{reason: False for reason in overspeeds(self)}})

    def line(self) -> str:
        """The plan in a few words (its repr adds the status)."""
        s = self.start
        return (f"{self.segment + ', ' if self.segment else ''}from {s.position:.1f} m at {s.speed:.2f} m/s, clock "
                f"{s.time:.2f} s: arrival at {self.nodes[-1]:.0f} m, {self.v[-1]:.2f} m/s, clock {self.time[-1]:.2f} s, "
                f"traction still to do {to_kwh(self.traction_energy):.3f} kWh")

    def __repr__(self) -> str:  # a line, not the arrays
        return f"Plan({self.line()}; {self.status})"


def _kmh(speed: float) -> str:
    return f"{round(speed / KMH, 1):g}"


def overspeeds(plan: Plan) -> list[str]:
    """Where a plan runs over the speed limit by more than :data:`OVERSPEED_TOLERANCE_KMH`, in words:
    a start over the limit where it is and how far it brakes to get back under ('starts 64.0 km/h
    over the 80 km/h limit at 400 m; braking back under it by 980 m'), and each stretch ahead over
    its limits ('9.9 km/h over the 60 km/h limit at 950-980 m'). A start over the limit is one the train
    should not be in; from it, and from a start that cannot brake down to a limit ahead in time,
    the plan follows what full braking reaches (:func:`set_start`): over the limit, so said."""
    if plan.limits is None:
        return []
    start = plan.start
    k = int(np.argmax(plan.shares > 0.0))  # the interval holding the start: nodes ahead from k + 1
    nodes, excess = plan.nodes[k + 1:], (plan.v[k + 1:] - plan.limits[k + 1:]) / KMH
    over = excess > OVERSPEED_TOLERANCE_KMH
    reasons = []
    first = (start.speed - plan.start_limit) / KMH
    if first > OVERSPEED_TOLERANCE_KMH:
        n = int(np.argmin(over)) if not over.all() else len(over)  # the stretch over the limit from the start on
        back = f"braking back under it by {nodes[n]:.0f} m" if n < len(over) else "over it to the end"
        reasons.append(f"starts {first:.1f} km/h over the {_kmh(plan.start_limit)} km/h limit at {start.position:.0f} "
                       f"m; {back}")
        over[:n] = False
    edges = np.flatnonzero(np.diff(np.concatenate([[0], over.astype(int), [0]])))
    stretches = list(zip(edges[::2], edges[1::2]))
    worst = [a + int(np.argmax(excess[a:b])) for a, b in stretches]
    reasons += [f"{excess[w]:.1f} km/h over the {_kmh(plan.limits[k + 1 + w])} km/h limit at {nodes[a]:.0f}-"
                f"{nodes[b - 1]:.0f} m" for (a, b), w in zip(stretches[:3], worst)]
    if len(stretches) > 3:
        reasons.append(f"and over it at {len(stretches) - 3} more stretches")
    return reasons


def check_plan_request(state: Any, end_speed: Any, arrival: Any, mass_scale: Any, distance: float = math.inf) -> None:
    """Refuse a re-plan's arguments that no plan answers, one line each naming the argument: a
    state that is not a :class:`State` of finite numbers (speed and clock at least 0) on the segment
    ``distance`` [m] long, an end speed
    that is not a (lowest, highest) pair of speeds [m/s], an arrival that is not a time or an
    (earliest, latest) pair [s] after the state's clock, a mass scale that is not a positive number."""
    where, lines = "arguments", []
    if not isinstance(state, State):
        lines.append(problem(where, "state", f"a State(position, speed, time) in m, m/s and s, not {state!r}"))
    elif not all(finite_number(x) for x in (state.position, state.speed, state.time)) or state.speed < 0 or state.time < 0:
        lines.append(problem(where, "state", f"finite numbers, the speed and clock at least 0, not {state}"))
    elif (why := off_segment(state.position, distance)) is not None:
        lines.append(problem(where, "state", why))
    pair = isinstance(end_speed, (tuple, list)) and len(end_speed) == 2 and all(finite_number(x) for x in end_speed)
    if not pair or not 0 <= end_speed[0] <= end_speed[1]:
        lines.append(problem(where, "end_speed", f"a (lowest, highest) pair of speeds [m/s], 0 <= lowest <= "
                             f"highest, not {end_speed!r}"))
    times = [arrival] if finite_number(arrival) else list(arrival) if isinstance(arrival, (tuple, list)) else None
    if times is None or len(times) not in (1, 2) or not all(finite_number(x) for x in times) or times[0] > times[-1] \
            or times[0] < 0:
        lines.append(problem(where, "arrival", f"a time or an (earliest, latest) pair [s], at least 0, not {arrival!r}"))
    elif isinstance(state, State) and finite_number(state.time) and times[-1] <= state.time:
        lines.append(problem(where, "arrival", f"the latest arrival {times[-1]:g} s is not after the state's clock "
                             f"{state.time:g} s"))
    if not finite_number(mass_scale) or mass_scale <= 0:
        lines.append(problem(where, "mass_scale", f"the train's mass over the model's, a number above 0, not "
                             f"{mass_scale!r}"))
    if lines:
        raise InputError(lines)


class Replanner:
    """One prepared case (``ocp.problem.prepare``) as a movable model, written once.

    ``solve(state, end_speed, arrival)`` re-plans from ``state`` (default: standstill at the
    departure, clock 0) by bounds alone, warm-started from the previous plan (``last``).
    """

    def __init__(self, case: Case, running_time: float | None = None, window: tuple[float, float] | None = None,
                 objective: str = "energy", options: Options | None = None, stages: Stages | None = None) -> None:
        self.case, self.options, self.stages = case, options, stages if stages is not None else {}
        timing: dict[str, Any] = {"running_time": running_time} if running_time is not None else {"window": window}
        latest = running_time if running_time is not None else window[1] if window is not None else None
        if latest is None:
            raise InputError("a re-planner needs a running time or an arrival window")
        guess = capped_guess(case, latest)
        self.model = build(case, guess, objective, self.stages, movable=True, **timing)
        self.session = Session(self.model)
        self.stages["nl_write"] = self.stages.get("nl_write", 0.0) + self.session.nl_seconds
        self.arrival = f"at {latest:.2f} s" if window is None else f"in [{window[0]:.2f}, {window[1]:.2f}] s"
        self.timing = (latest, latest) if running_time is not None else (float(window[0]), float(window[1]))  # type: ignore[index]
        self.objective, self.plans = objective, 0
        self.last: Plan | None = None

    def __repr__(self) -> str:  # what it plans for and its last plan's status, not the model
        seg, n = self.case.segment, self.plans
        return (f"Replanner({seg.from_stop} -> {seg.to_stop}, {seg.distance:.0f} m, K = {len(self.case.nodes)}, "
                f"{self.objective}, arrival {self.arrival}; "
                + (f"{n} plan{'s' if n != 1 else ''}, the last {self.last.status})" if self.last else "no plan yet)"))

    def solve(self, state: State = State(), end_speed: tuple[float, float] = (0.0, 0.0),
              arrival: float | Sequence[float] | None = None, options: Options | None = None,
              mass_scale: float | None = None) -> Plan:
        """A plan from ``state`` (:class:`State`, SI) to the stop, arriving at ``arrival`` (a time or
        (earliest, latest) [s] on the state's clock; None: the re-planner's own running time or window)
        with a speed in ``end_speed`` [m/s] there, for a train of ``mass_scale`` times the model's mass
        (None: the model's). Nothing is kept from one call to the next but the warm start: the same
        call gives the same plan. A bad argument is one line naming it (``InputError``)."""
        arrival = self.timing if arrival is None else arrival
        mass_scale = 1.0 if mass_scale is None else mass_scale
        check_plan_request(state, end_speed, arrival, mass_scale, float(self.case.nodes[-1]))
        m, nodes = self.model, self.case.nodes
        set_mass(self.session, m, float(mass_scale))
        set_start(self.session, m, nodes, state, self.case.train)
        set_end(self.session, m, end_speed, arrival)
        outcome = self.session.solve({**(self.options or {}), **(options or {})})
        v, dt, ft, fb, _ = space.solution_arrays(m)
        shares = np.array([m.w[k].value for k in m.I])
        seg = self.case.segment
        self.plans, self.last = self.plans + 1, Plan(nodes, v, dt, ft, fb, shares, float(m.t0.value), outcome,
                                                     f"{seg.from_stop} -> {seg.to_stop}", self.case.limits,
                                                     float(seg.limit(state.position)))
        return self.last
