"""The train as a plant: the same physics functions as the NLP, integrated over time.

A :class:`Plant` is one train on one segment with its *true* parameters (:class:`Truth`, as
multiples of the model's: mass, running resistance, traction and braking envelopes), so a
controller planning with the nominal train can be run against a train that is not its model.

- :meth:`Plant.step` advances a :class:`~ecostudy.core.types.State` by ``dt`` under one control
  (a handle u in [-1, 1], or :class:`Cruise`) and an additive acceleration disturbance [m/s^2];
  the step integrates piecewise (DOP853), restarting at every gradient or curve change and where
  the train comes to a stand.
- :meth:`Plant.drive` drives a whole trip under a handle per grid interval (switching by
  position): the independent verification of every optimum (:mod:`ecostudy.core.simulate`).
- :class:`Noise` draws acceleration noise and measurement noise from one seeded generator.

Standing trains are not pushed backwards by resistance; work is accumulated at the wheel.
"""
from bisect import bisect_right
from dataclasses import dataclass, replace
from typing import Any, Callable, NamedTuple, Sequence, TypeAlias

import numpy as np
from scipy.integrate import solve_ivp

from ecostudy.core import adhesion
from ecostudy.core.adhesion import Adhesion
from ecostudy.core.grid import Profile, Segment
from ecostudy.core.kinematics import point_resistance
from ecostudy.core.physics import acceleration, davis_resistance, line_energy
from ecostudy.core.types import State, Train
from ecostudy.core.units import FloatArray, Numeric

RTOL, ATOL = 1e-8, [1e-6, 1e-8, 1.0, 1.0, 1.0, 1.0]  # state: position, speed, three works, net line energy [J]

Event: TypeAlias = Callable[..., float]  # an event function of solve_ivp: (t, y) -> value


def terminal(event: Event, direction: int) -> Event:
    """``event`` marked for ``solve_ivp``: the integration stops where it crosses zero in ``direction``."""
    setattr(event, "terminal", True)
    setattr(event, "direction", direction)
    return event


RUNAWAY_M = 100.0  # a driven run that has not stopped this far past its stop is ended there (:meth:`Plant.drive`)


@dataclass(frozen=True)
class Truth:
    """The plant's true parameters as multiples of the model's (1: the model itself).

    ``mass`` scales the inertial and the static mass (grade and curve forces with it) and the
    adhesive mass of a train with an adhesion limit, ``resistance`` the Davis terms, ``traction`` and
    ``braking`` the envelopes.
    """

    mass: float = 1.0
    resistance: float = 1.0
    traction: float = 1.0
    braking: float = 1.0

    def adhesion(self, train: Train) -> Adhesion | None:
        """The true train's adhesion limit: the model's law on its adhesive mass times ``mass`` (the
        load on the driven axles grows and shrinks with the train's); None for a train without one."""
        limit = train.adhesion
        return None if limit is None else replace(limit, mass=limit.mass * self.mass)

    def capped(self, train: Train) -> bool:
        """Whether the plant caps the true traction and electric brake at the true train's adhesion
        limit: where it has one and the model's envelopes, capped at the model's limit, could ask
        more of it (a stronger traction, or a lighter train with less grip)."""
        return train.adhesion is not None and (self.traction > 1.0 or self.mass < 1.0)


@dataclass(frozen=True)
class Cruise:
    """Hold ``target`` [m/s]: F = F_R(x, v) + M gain (target - v), clipped to the envelopes. With a
    ``handle``, ``target`` is a ceiling: that handle's forces, or the hold's where its net force is
    the smaller (a driver who keeps to the limit: brakes down a grade there, eases off the traction)."""

    target: float
    gain: float = 1.0
    handle: float | None = None


class Step(NamedTuple):
    """A plant step: the new state and the work done over it at the wheel [J]."""

    state: State
    traction_work: float
    braking_work: float
    regenerated_work: float   # taken by the electric brake, before its efficiency
    stood: float | None = None  # the clock at which the train came to a stand within the step [s]
    overspeed: float = -np.inf  # the largest speed over the limit within the step [m/s] (:meth:`Plant.step`)
    adhesion: float | None = None  # the largest adhesion use at its start and piece ends (:func:`adhesion_use`); None: no limit


@dataclass(frozen=True)
class Noise:
    """Disturbances of a closed loop: acceleration noise [m/s^2] and measurement noise on position
    [m] and speed [m/s] (standard deviations of zero-mean normal draws), from a seeded generator."""

    acceleration: float = 0.0
    position: float = 0.0
    speed: float = 0.0
    seed: int = 0
    period: float = 0.0  # the acceleration noise is held this long [s] (Yazhemsky 2017 §10.1: 1 s); 0: per step
    accelerometer: float = 0.0  # noise of the acceleration reading [m/s^2] (Yazhemsky 2017 §10.3.5, sigma_A)

    def read_acceleration(self, mean: float, rng: np.random.Generator) -> float:
        """The accelerometer's reading of the mean acceleration ``mean`` over the last sample."""
        return mean + (float(rng.normal(0.0, self.accelerometer)) if self.accelerometer else 0.0)

    def generator(self) -> np.random.Generator:
        return np.random.default_rng(self.seed)

    def disturbance(self, rng: np.random.Generator) -> float:
        return float(rng.normal(0.0, self.acceleration)) if self.acceleration else 0.0

    def measure(self, state: State, rng: np.random.Generator) -> State:
        """``state`` as a sensor reports it."""
        dx = float(rng.normal(0.0, self.position)) if self.position else 0.0
        dv = float(rng.normal(0.0, self.speed)) if self.speed else 0.0
        return State(state.position + dx, state.speed + dv, state.time)


def controls_of(handle: Sequence[float] | FloatArray, targets: Sequence[float] | FloatArray | None = None,
                gain: float = 1.0, ceiling: bool = False) -> list["float | Cruise"]:
    """The control of each interval: its handle, or :class:`Cruise` at its target speed where
    ``targets`` (one per interval) is not nan (with ``ceiling``, the handle held at most at it)."""
    handles = [float(u) for u in handle]
    target = [float(x) for x in targets] if targets is not None else [float("nan")] * len(handles)
    return [Cruise(x, gain, u if ceiling else None) if x == x else u for u, x in zip(handles, target)]


def pieces(nodes: FloatArray, handle: Sequence[float] | FloatArray, segment: Segment, jump: float = 1e-3,
           targets: Sequence[float] | FloatArray | None = None) -> FloatArray:
    """Start indices of runs of intervals with (nearly) the same handle, gradient and curvature.

    An adaptive stepper can step straight over a short interval of different control without
    sampling it, so the integration restarts at every such discontinuity (and wherever a cruise
    target speed starts, ends or changes).
    """
    mid, handle = 0.5 * (nodes[:-1] + nodes[1:]), np.asarray(handle, float)
    grade, curve, tunnel = segment.gradient(mid), segment.curvature(mid), segment.tunnel(mid)
    change = ((np.abs(np.diff(handle)) > jump) | (np.diff(grade) != 0) | (np.diff(curve) != 0)
              | (np.diff(tunnel) != 0)
              | (np.sign(handle[1:]) != np.sign(handle[:-1])))
    if targets is not None:
        tgt = np.nan_to_num(np.asarray(targets, float), nan=-1.0)
        change |= np.diff(tgt) != 0
    return np.concatenate([[0], np.nonzero(change)[0] + 1])


class Plant:
    """One train on one segment, with true parameters (:class:`Truth`)."""

    def __init__(self, segment: Segment, train: Train, truth: Truth = Truth()) -> None:
        self.segment, self.train, self.truth = segment, train, truth
        self.mass = train.mass * truth.mass
        self.davis = tuple(float(c) * truth.resistance for c in train.davis)
        self.edges = segment.breakpoints()
        # a true train stronger or lighter than its model transmits at most its own mu(v) m_adh g (Truth.capped)
        limit = truth.adhesion(train)
        self.grip = limit.limit if limit is not None and truth.capped(train) else None

    # ------------------------------------------------------------------ forces
    def grade_force(self, x: float) -> float:
        """Gradient and curve force at travel position ``x`` [N] (true static mass)."""
        return float(self.grade_forces(x))

    def grade_forces(self, x: Numeric) -> Numeric:
        """:meth:`grade_force` at each travel position of ``x`` (an array for an array)."""
        return point_resistance(self.segment, self.train, x) * self.truth.mass

    def varying(self, x: float) -> bool:
        """Whether the curvature changes along the piece at travel position ``x`` (a clothoid)."""
        curve = self.segment.curvature
        return curve.slopes is not None and bool(Profile(curve.starts, curve.slopes)(x) != 0)

    def tunnel(self, x: Numeric) -> float:
        """Extra quadratic resistance of a tunnel at travel position ``x`` [N s^2/m^2] (true resistance)."""
        return float(self.tunnels(x))

    def tunnels(self, x: Numeric) -> Numeric:
        """:meth:`tunnel` at each travel position of ``x`` (an array for an array)."""
        return self.segment.tunnel(x) * self.truth.resistance

    def forces(self, v: float, control: "float | Cruise", resist: float) -> tuple[float, float]:
        """(F_T, F_B) [N] of a handle u or a :class:`Cruise` at speed ``v`` with resistance ``resist``."""
        train = self.train
        if isinstance(control, Cruise):
            net = resist + self.mass * control.gain * (control.target - v)
            if control.handle is not None:  # the handle, unless holding the ceiling takes less
                ft, fb = self.forces(v, control.handle, resist)
                if ft - fb <= net:
                    return ft, fb
            return ((min(net, self.traction(v)), 0.0) if net >= 0
                    else (0.0, min(-net, self.truth.braking * train.braking.force(v))))
        ft = control * self.traction(v) if control > 0 else 0.0
        fb = -control * (self.truth.braking * train.braking.force(v)) if control < 0 else 0.0
        if ft > 0.0 and ft - resist > self.mass * train.max_acceleration:  # the traction control's limit
            ft = max(self.mass * train.max_acceleration + resist, 0.0)
        if fb > 0.0 and fb + resist > self.mass * train.max_deceleration:  # the brake control's limit
            fb = max(self.mass * train.max_deceleration - resist, 0.0)
        return ft, fb

    def applied(self, x: FloatArray, v: FloatArray,
                controls: Sequence["float | Cruise"]) -> tuple[FloatArray, FloatArray]:
        """(F_T, F_B) [N] the plant applies at travel positions ``x`` [m] and speeds ``v`` [m/s]
        (arrays) under the control at each: :meth:`forces` with the true resistance there."""
        a, b, c = self.davis
        x = np.clip(x, 0.0, self.segment.distance)
        resist = davis_resistance(v, a, b, c + self.tunnels(x)) + self.grade_forces(x)
        resist = np.broadcast_to(resist, np.shape(v))
        pairs = [self.forces(float(s), u, float(r)) for s, u, r in zip(v, controls, resist)]
        out = np.asarray(pairs, float).reshape(-1, 2)
        return out[:, 0], out[:, 1]

    def traction(self, v: float) -> float:
        """The true traction envelope at speed ``v`` [N]: the model's times ``truth.traction``, at most
        the train's adhesion limit (where it has one)."""
        force = float(self.truth.traction * self.train.traction.force(v))
        return force if self.grip is None else min(force, float(self.grip(v)))

    def electric(self, fb: float, v: float) -> float:
        """The part [N] of the braking force ``fb`` [N] the electric brake takes at speed ``v``
        (:meth:`Train.electric_brake`), at most the true adhesion limit where the plant caps it; the
        friction brake takes the rest."""
        fr = float(self.train.electric_brake(fb, v))
        return fr if self.grip is None else min(fr, float(self.grip(v)))

    def derivatives(self, v: float, ft: float, fb: float, resist: float, disturbance: float = 0.0) -> list[float]:
        """d/dt of (position, speed, traction work, braking work, regenerated work, net line
        energy); the last by :func:`physics.line_energy` per unit distance, times v."""
        # standing stays standing: nothing pulls it, or its brakes (friction) hold what does. Friction
        # never drives a train backwards: a held train that ran on under its brakes past v = 0 (an
        # integrator's step beyond the stop) would roll back across a piece's end it had passed, and
        # the step's event, which sees only the step's ends, would miss that crossing
        if v <= 0.0 and ft - resist + self.mass * disturbance <= fb:
            return [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        train = self.train
        fr = self.electric(fb, v) if fb > 0 else 0.0
        line = line_energy(ft, fr, v, v, train.eta_traction, train.eta_regeneration)
        return [v, acceleration(ft, fb, resist, self.mass) + disturbance, ft * v, fb * v, fr * v, line]

    # ------------------------------------------------------------------ stepping
    def step(self, state: State, control: "float | Cruise", dt: float, disturbance: float = 0.0) -> Step:
        """Advance ``state`` by ``dt`` [s] under ``control`` held constant (a :class:`Step`)."""
        a, b, c = self.davis
        y = [float(state.position), max(float(state.speed), 0.0), 0.0, 0.0, 0.0, 0.0]
        t, t_end = float(state.time), float(state.time) + dt
        stood: float | None = None
        over = -np.inf  # under a held control the speed is monotone within a piece: its largest excess is at an end
        ends = [(y[0], y[1])]  # the start and every piece end: the force jumps at an edge (Cruise, the acceleration cap)
        while t < t_end - 1e-12:
            i = bisect_right(self.edges, y[0] + 1e-9)
            edge = self.edges[i] if i < len(self.edges) else np.inf
            fixed = self.grade_force(y[0] + 1e-9)
            c_x = c + self.tunnel(y[0] + 1e-9)
            varying = self.varying(y[0] + 1e-9)  # on a clothoid the curve force follows the position

            def rhs(_: float, z: Sequence[float]) -> list[float]:
                resist = davis_resistance(z[1], a, b, c_x) + (self.grade_force(z[0]) if varying else fixed)
                ft, fb = self.forces(z[1], control, resist)
                return self.derivatives(z[1], ft, fb, resist, disturbance)

            t_start = t

            def stopped(tt: float, z: Sequence[float]) -> float:
                return z[1] if tt > t_start else 1.0

            def reached(_: float, z: Sequence[float]) -> float:
                return float(z[0] - edge)
            sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=RTOL, atol=ATOL,
                            events=(terminal(stopped, -1), terminal(reached, 1)))
            y, t = sol.y[:, -1].tolist(), float(sol.t[-1])
            if sol.t_events[1].size:
                y[0] = edge  # on the boundary exactly; the next piece has its own grade
            elif sol.t_events[0].size:
                y[1] = 0.0
                if rhs(t, y)[1] <= 0.0:  # at a stand and nothing moves it: it stands out the step
                    stood, t = t, t_end
            over = max(over, self.over_limit(y[0], y[1]))
            ends.append((y[0], y[1]))
        return Step(State(y[0], max(y[1], 0.0), t_end), y[2], y[3], y[4], stood, over, self.ends_use(ends, control))

    def ends_use(self, ends: Sequence[tuple[float, float]], control: "float | Cruise") -> float | None:
        """The largest :func:`adhesion_use` under ``control`` at ``ends`` [(position [m], speed [m/s])],
        each read on both sides of its position (at an edge, the piece it ends and the next); None for a
        train without an adhesion limit (nothing computed)."""
        if self.train.adhesion is None:
            return None
        x = np.clip([p + side for p, _ in ends for side in (-1e-9, 1e-9)], 0.0, self.segment.distance)
        v = [s for _, s in ends for _ in (0, 1)]
        return adhesion_use(self, x, v, [control] * len(v))

    def over_limit(self, position: float, speed: float) -> float:
        """``speed`` less the limit at ``position`` [m/s], the lower of its two sides at a limit's edge
        (``grid.node_limits``' reading): a train that reaches a lower limit's start faster is over it."""
        x = np.clip([position - 1e-9, position + 1e-9], 0.0, self.segment.distance)
        return float(speed - np.min(self.segment.limit(x)))

    # ------------------------------------------------------------------ a whole trip
    def drive(self, nodes: FloatArray, handle: Sequence[float] | FloatArray,
              targets: Sequence[float] | FloatArray | None = None, gain: float = 1.0, max_time: float | None = None,
              initial_speed: float = 0.0, ceiling: bool = False) -> tuple[list[float], float, list[Any]]:
        """Drive ``handle`` (one value per interval of ``nodes``, switching by position) from
        standstill (or ``initial_speed`` [m/s]) until the train stops; ``targets`` (one per interval, nan elsewhere) asks for
        cruise control at that speed there (with ``ceiling``: the handle, held at most at that speed). Returns (position, speed, three works, stop time)
        and the integrator's pieces, restarted at every control, gradient or curve change."""
        segment = self.segment
        a, b, c = self.davis
        handles = [float(u) for u in handle]
        controls = controls_of(handles, targets, gain, ceiling)
        last = len(handles) - 1
        max_time = max_time or 20 * segment.distance + 600
        node_list = nodes.tolist()
        fixed = [0.0, c]  # gradient + curve force [N] and C with the tunnel's: constant within a piece
        span = [0, last]  # a step that overshoots the piece's end must not sample the next piece's control

        def rhs(t: float, y: Sequence[float]) -> list[float]:
            k = min(max(bisect_right(node_list, y[0]) - 1, span[0]), span[1])
            resist = davis_resistance(y[1], a, b, fixed[1]) + fixed[0]
            ft, fb = self.forces(y[1], controls[k], resist)
            return self.derivatives(y[1], ft, fb, resist)

        def stopped(t: float, y: Sequence[float]) -> float:
            return y[1] if t > t_start else 1.0

        starts = pieces(nodes, handles, segment, targets=targets)
        bounds = list(nodes[starts[1:]]) + [segment.distance + RUNAWAY_M]  # past the stop: the runaway guard
        y, t_start = [0.0, max(initial_speed, 1e-9), 0.0, 0.0, 0.0, 0.0], 0.0
        solutions: list[Any] = []  # scipy's OdeResult per piece
        for first, following, x_end in zip(starts, list(starts[1:]) + [last + 1], bounds):
            span[0], span[1] = first, following - 1
            fixed[0] = self.grade_force(0.5 * (nodes[first] + nodes[first + 1]))
            fixed[1] = c + self.tunnel(0.5 * (nodes[first] + nodes[first + 1]))

            def reached(t: float, y: Sequence[float], x_end: float = x_end) -> float:
                return y[0] - x_end
            sol = solve_ivp(rhs, (t_start, max_time), y, method="DOP853", rtol=RTOL, atol=ATOL,
                            events=(terminal(stopped, -1), terminal(reached, 1)), dense_output=True)
            solutions.append(sol)
            y, t_start = sol.y[:, -1].tolist(), float(sol.t[-1])
            if sol.status != 1 or sol.t_events[0].size:  # stopped, or ran out of time
                break
            y[0] = x_end  # land exactly on the boundary (event location is accurate to rounding)
        return y, float(t_start), solutions


def adhesion_use(plant: Plant, positions: Sequence[float] | FloatArray, speeds: Sequence[float] | FloatArray,
                 controls: Sequence["float | Cruise"]) -> float | None:
    """The largest share of the true train's adhesion limit mu(v) m_adh g (:meth:`Truth.adhesion`,
    :mod:`ecostudy.core.adhesion`) that the plant's traction or electric brake asked for at the
    samples: the forces it applies (:meth:`Plant.applied`, :meth:`Plant.electric`) at each position
    [m] and speed [m/s] under the control there (a handle or :class:`Cruise`). The one check of every
    run, re-simulated, driven or stepped (:attr:`Step.adhesion`); None for a train without an adhesion limit."""
    limit = plant.truth.adhesion(plant.train)
    if limit is None:
        return None
    v = np.maximum(np.asarray(speeds, float), 0.0)
    traction, braking = plant.applied(np.asarray(positions, float), v, controls)
    electric = [plant.electric(fb, s) if fb > 0 else 0.0 for fb, s in zip(braking, v)]
    return float(np.max(np.maximum(adhesion.use(limit, v, traction), adhesion.use(limit, v, electric)), initial=0.0))
