"""The cascade mass-point train of Zhang & Zhuan eq. 1, stepped in time: every car at its own position
(so each feels its own grade), joined by couplers with stiffness and damping.

    m_i dv_i/dt = u_i + f_in,i-1 - f_in,i - f_a,i        f_a,i = m_i (c0 + c1 v_i + c2 v_i^2) + f_p(p_i)
    f_in,i = k (p_i - p_i+1 - l_i) + d (v_i - v_i+1)      l_i = (L_i + L_i+1) / 2, the coupled spacing

f_p is the grade force and the curve resistance (Roeckl's formula, as for TTOBench; ``curves=False``
leaves curves out), each averaged over car i's length (what a car spanning a change feels, and a
right-hand side continuous in position: a point reading makes every car's crossing of a grade change
a jump the stiff integrator must step through, 7 s per 20 s step on the shipped route against
0.1-0.2 s). Roeckl's formula jumps by 43 % at 300 m radius (its two fits), so on curves of constant
radius the plant averages the curve force, not the curvature: a car entering a 250 m curve felt that
jump half-way in (a 7 km line with a 250 m curve: 51.7 CPU s against 1.8 s for its 27 samples);
on clothoids it reads the formula at the car's mean curvature. p_i is the travel position of car i's centre (the
head car first), u_i its effort: traction or dynamic braking for a locomotive, pneumatic braking
(<= 0) for a wagon, clipped at every instant to the car's envelope at its own speed; every brake acts
as friction (:meth:`CascadePlant.applied`). The couplers make the system stiff (k/m about 160 1/s^2,
d/m about 23 1/s for the ore train), so the step uses scipy's BDF with the banded Jacobian sparsity.
Recorded: in-train forces (at the end and the largest over the step) and the works of the
locomotives (traction, dynamic brake) and of the wagons' brakes, apart.

Two in-train effects of TrainDy-class tools are switchable where the consist gives their data (off:
the paper's plant): ``air_brake`` (heavyhaul.airbrake: the wagons' brake forces delayed along the
train and lagged) and ``draft_gear`` (heavyhaul.draftgear: slack and loading/unloading stiffness in
place of the linear coupler; its hysteresis loss is a named term); so are the locomotives'
``notches`` (:meth:`CascadePlant.levels`: each step's request rounded to the nearest notch, notch k
of N applying k/N of the envelope at the locomotive's speed throughout the step). The forces of every coupler at
every integrator point are kept in ``history`` for the metrics (largest draft and buff, run-ins,
rainflow).
"""
from typing import NamedTuple, Optional

import numpy as np
from scipy.integrate import solve_ivp
from scipy.sparse import lil_matrix

from ecostudy.core.adhesion import curtius_kniffler
from ecostudy.core.grid import Profile
from ecostudy.core.physics import GRAVITY, roeckl_force
from ecostudy.heavyhaul import draftgear
from ecostudy.heavyhaul.airbrake import BrakePipe, signal_delays

# relative tolerance 1e-6 (absolute 0.1 mm, 1e-6 m/s): against 1e-10 a 20 s step of the ore train
# climbing onto a grade ends within 0.3 mm/s and 0.2 kN of in-train force, in 54 steps instead of 958
# (0.11 s against 2.4 s); tests of conservation pass a tighter ``rtol``
RTOL, ATOL_POSITION, ATOL_SPEED, ATOL_WORK = 1e-6, 1e-4, 1e-6, 1.0
# with draft gear slack, every contact is resolved (about 0.2 s each, hundreds per sample): rtol 1e-4
# (tolerances scaled alike) halves the cost against 1e-6; measured on the ore train (a 20 s pull and a
# 20 s wagon braking, air brakes on): the same largest force (577.3 kN), mean speed within 0.4 mm/s,
# the draft gear's loss within 0.2 %, the energy balance within 0.01 % of traction (docs/heavyhaul.md)
SLACK_RTOL = 1e-4
# c0 opposes the motion: sign(v) rounded over 1 cm/s, else cars starting from rest (or swinging
# through 0) chatter on the jump and the integrator stalls (a 20 s step from rest did not finish
# in 300 s); the rounding is below 1 % of c0 above 0.07 m/s
STANDSTILL_SPEED = 0.01


def friction(speeds):
    """sign(v) rounded over :data:`STANDSTILL_SPEED`: the share of a friction force (c0, a brake) that
    acts on a car at ``speeds`` [m/s] (0 standing, -1 to 1)."""
    return speeds / np.sqrt(speeds * speeds + STANDSTILL_SPEED ** 2)
ENVELOPE_SPEED = 1e-9  # [m/s]: the envelopes read a standing or reversing car at this speed (no power / 0)
QUADRATURES = 8  # works of traction, dynamic brakes, wagon brakes, then the five LOSSES


class CascadeState(NamedTuple):
    positions: np.ndarray   # travel position of every car's centre [m], the head car first
    speeds: np.ndarray      # [m/s]
    time: float = 0.0       # [s]
    brakes: Optional[np.ndarray] = None     # the wagons' air-brake forces [N] (air_brake on; None: none applied)
    commanded: Optional[np.ndarray] = None  # the efforts commanded over the last step [N] (air_brake on)
    sent: tuple = ()  # ((time [s], wagons' command [N]), ...): the newest every wagon sees, then those still travelling


class CascadeStep(NamedTuple):
    state: CascadeState
    coupler_forces: np.ndarray   # f_in at the end of the step [N], tension positive
    largest_coupler_force: float  # max |f_in| over the integrator's points in the step [N]
    traction_work: float         # locomotives [J]
    dynamic_brake_work: float    # locomotives [J]
    wagon_brake_work: float      # pneumatic brakes of the wagons [J]
    speed_excess: float = 0.0    # largest (fastest car's speed - the train's limit at the head) over the step [m/s]
    losses: tuple = (0.0,) * 5  # work against running resistance, curves, grades; coupler damping, draft gear [J]
    adhesion: tuple = (0.0,) * 5  # the largest adhesion use over the step (CascadePlant.adhesion_use)
    levels: Optional[np.ndarray] = None  # the notch levels held over the step (CascadePlant.levels; None: notches off)


LOSSES = ("running_resistance", "curve_resistance", "grade", "coupler_damping", "draft_gear")  # CascadeStep.losses


class Closing(NamedTuple):
    """The most compressed coupling so far, by its compression over its limit: the smaller of its
    draft gears' travel (:attr:`CascadePlant.travel`) and its coupled spacing l_i."""

    compression: float = 0.0  # how much shorter than l_i the two cars' centres came [m] (> 0 compressed)
    coupler: int = 0          # which (0: behind the head car)
    time: float = 0.0         # when [s]
    spacing: float = np.inf   # its l_i [m]: compressed more, the cars' centres pass each other
    limit: float = np.inf     # min(travel, l_i) [m]: compressed more, the gears are solid (or the cars pass)


class CascadePlant:
    """One consist (:class:`ecostudy.core.types.Consist`) on one segment (its gradient profile)."""

    def __init__(self, consist, segment, curves=True, rtol=None, adhesion=False, air_brake=False, draft_gear=False,
                 notches=False):
        self.consist, self.segment, self.curves = consist, segment, curves
        self.rtol = rtol if rtol is not None else SLACK_RTOL if draft_gear else RTOL
        self.adhesion = adhesion  # cap each locomotive's traction and dynamic braking at mu(v) m g (curtius_kniffler)
        for name, on in (("air_brake", air_brake), ("draft_gear", draft_gear), ("notches", notches)):
            if on and getattr(consist, name) is None:
                raise ValueError(f"the consist '{consist.name}' gives no {name} data")
        self.air_brake = consist.air_brake if air_brake else None
        self.gear = consist.draft_gear if draft_gear else None
        self.notches = consist.notches if notches else None
        self.delays = signal_delays(consist, self.air_brake.signal_speed) if air_brake else None
        self.history = []  # per step: (times [s], coupler forces [N] (points, couplers)) at the integrator's points
        self.n = consist.cars
        self.spacing = 0.5 * (consist.length[:-1] + consist.length[1:])
        # a coupling closes this far before its draft gears are solid: their travel (+ half the slack, the draft gear on)
        self.travel = consist.draft_gear_travel + (0.5 * self.gear.slack if self.gear is not None else 0.0)
        self.limit = np.minimum(self.travel, self.spacing)
        self.closest = Closing(spacing=float(self.spacing[0]) if self.n > 1 else np.inf,  # most compressed (:meth:`closing`)
                               limit=float(self.limit[0]) if self.n > 1 else np.inf)
        self.loco = np.array([k == "locomotive" for k in consist.kinds])
        self.traction_limits = self._limits(consist.traction)
        self.dynamic_limits = self._limits(consist.dynamic_brake)
        self.jac_sparsity = self._sparsity()
        k = segment.curvature
        # Roeckl's force per kg on each piece of constant curvature: its mean over a car's length is
        # continuous in position where the formula jumps (clothoids: None, the mean curvature's force)
        self.curve_force = None if k.slopes is not None else Profile(k.starts, roeckl_force(1.0, k.values))

    @staticmethod
    def _limits(envelopes):
        """(max force [N], max power [W]) per car of force-power envelopes (0 force where none)."""
        if any(e is not None and e.kind != "force_power" for e in envelopes):
            raise ValueError("the cascade plant takes force-power envelopes (a consist file's)")
        return (np.array([e.max_force if e is not None else 0.0 for e in envelopes]),
                np.array([e.max_power if e is not None else np.inf for e in envelopes]))

    def initial(self, head=0.0, speed=0.0, time=0.0):
        """Every coupler at its free length, the head car's centre at ``head`` [m], all at ``speed``."""
        positions = head - np.concatenate([[0.0], np.cumsum(self.spacing)])
        return CascadeState(positions, np.full(self.n, float(speed)), time)

    def quasi_static(self, head, speed, requested, time=0.0, sweeps=3):
        """The state in which every car accelerates alike under ``requested`` efforts: each coupler
        carries the sum of (effort - resistance - m a) of the cars ahead, a the common acceleration
        (a train that has run a while in the same notch); the grade is re-read after each sweep."""
        state = self.initial(head, speed, time)
        c = self.consist
        for _ in range(sweeps):
            net = self.applied(np.asarray(requested, float), state.speeds) - self.resistance(state.positions, state.speeds)
            force = np.cumsum(net - c.mass * net.sum() / c.mass.sum())[:-1]
            stretch = force / c.stiffness if self.gear is None else draftgear.extension(force, self.gear)
            positions = head - np.concatenate([[0.0], np.cumsum(self.spacing + stretch)])
            state = CascadeState(positions, state.speeds, time)
        return state

    def coupler_parts(self, positions, speeds):
        """(elastic, hysteresis, damping) parts of f_in,i [N]: the linear coupler's stiffness times
        extension, 0, damping times closing speed; or the draft gear's (heavyhaul.draftgear)."""
        c = self.consist
        x, rate = positions[:-1] - positions[1:] - self.spacing, speeds[:-1] - speeds[1:]
        if self.gear is None:
            return c.stiffness * x, np.zeros_like(x), c.damping * rate
        return draftgear.forces(x, rate, self.gear, c.damping)

    def coupler_forces(self, positions, speeds):
        """f_in,i [N] of every coupler, tension positive."""
        return sum(self.coupler_parts(positions, speeds))

    def running(self, speeds):
        """Running resistance [N] of every car, opposing the motion."""
        c = self.consist
        c0, c1, c2 = c.resistance.T
        return c.mass * (c0 * friction(speeds) + c1 * speeds + c2 * speeds * np.abs(speeds))

    def resistance(self, positions, speeds):
        """f_a,i [N]: running resistance (opposing the motion) and the grade at each car's own position."""
        return self.running(speeds) + self.fixed_forces(positions)

    def grade_curve(self, positions):
        """(grade, curve) forces [N] of every car, over its length, at ``positions``."""
        c = self.consist
        grade = c.mass * GRAVITY * self.segment.gradient.mean_over(positions, c.length)
        if not self.curves:
            return grade, np.zeros_like(grade)
        if self.curve_force is not None:
            return grade, c.mass * self.curve_force.mean_over(positions, c.length)
        return grade, roeckl_force(c.mass, self.segment.curvature.mean_over(positions, c.length))

    def fixed_forces(self, positions):
        """f_p,i [N]: the grade and curve forces of every car, over its length, at ``positions``."""
        return sum(self.grade_curve(positions))

    def stored_energy(self, state):
        """Kinetic energy of the cars plus the couplers' elastic energy [J]."""
        c = self.consist
        extension = state.positions[:-1] - state.positions[1:] - self.spacing
        elastic = (0.5 * c.stiffness * extension ** 2 if self.gear is None
                   else draftgear.potential(extension, self.gear))
        return 0.5 * float(np.dot(c.mass, state.speeds ** 2)) + float(np.sum(elastic))

    def envelopes(self, speeds):
        """(lowest, highest) effort of every car at its speed [N]: traction; dynamic plus pneumatic brake."""
        dynamic, upper = self.motor_envelopes(speeds)
        return -(dynamic + self.consist.pneumatic_brake), upper

    def motor_envelopes(self, speeds):
        """(dynamic brake [N, >= 0], traction [N]) of every car at its speed (0 where it has none)."""
        speeds = np.maximum(speeds, ENVELOPE_SPEED)
        upper = np.minimum(self.traction_limits[0], self.traction_limits[1] / speeds)
        dynamic = np.minimum(self.dynamic_limits[0], self.dynamic_limits[1] / speeds)
        if self.adhesion:
            grip = np.where(self.loco, self.grip(speeds), np.inf)
            upper, dynamic = np.minimum(upper, grip), np.minimum(dynamic, grip)
        return dynamic, upper

    def levels(self, requested, speeds):
        """The notch every locomotive takes for a step from ``speeds`` [m/s] (None: notches off): its
        request clipped to its envelope, as a share of the traction (or dynamic-brake) envelope at its
        speed, rounded to the nearest of k / N (k = 0..N, N the consist's traction or dynamic-brake
        notches); signed (dynamic braking negative), NaN for a wagon. A locomotive's own pneumatic
        brake, if the consist gives one, is not applied with notches on (only its dynamic-brake notch)."""
        if self.notches is None:
            return None
        dynamic, upper = self.motor_envelopes(speeds)
        u = np.clip(requested, -dynamic, upper)
        share = np.where(u >= 0, u / np.where(upper > 0, upper, np.inf), u / np.where(dynamic > 0, dynamic, np.inf))
        count = np.where(u >= 0, self.notches.traction, self.notches.dynamic_brake)
        return np.where(self.loco, np.rint(share * count) / count, np.nan)

    def grip(self, speeds):
        """mu(v) m g of every car at its speed [N] (Curtius & Kniffler's dry rail): what a locomotive's
        traction or dynamic brake can transmit; 0 for a wagon (it has no motor)."""
        return np.where(self.loco, curtius_kniffler(speeds) * self.consist.mass * GRAVITY, 0.0)

    def adhesion_use(self, times, positions, speeds, requested, levels=None):
        """The most any locomotive asked of its wheels over the integrator's points (``times`` [s];
        ``positions``, ``speeds`` (cars, points)): (|u| / mu(v) m g [-], the efforts as applied, clipped
        to the envelope at the car's speed, v that speed as the envelope reads it; when [s]; the head
        [m]; that locomotive's speed [m/s] and effort [N], traction positive). At most 1 with
        ``adhesion`` on."""
        if not self.loco.any():
            return (0.0,) * 5
        v = speeds.T
        u = self.applied(requested, v, levels)[:, self.loco]
        use = np.abs(u) / np.maximum(self.grip(np.maximum(v, ENVELOPE_SPEED))[:, self.loco], 1.0)  # as envelopes
        k, j = np.unravel_index(np.argmax(use), use.shape)
        head = positions[0, k] + 0.5 * self.consist.length[0]
        return float(use[k, j]), float(times[k]), float(head), float(v[k][self.loco][j]), float(u[k, j])

    def efforts(self, requested, speeds, levels=None):
        """The requested efforts u_i [N] clipped to each car's envelope at its speed; with notch
        ``levels`` (:meth:`levels`) a locomotive's effort is its level times its traction (or
        dynamic-brake) envelope at its speed (capped by the grip with ``adhesion`` on)."""
        u = np.clip(requested, *self.envelopes(speeds))
        if levels is None:
            return u
        dynamic, upper = self.motor_envelopes(speeds)
        return np.where(self.loco, np.where(levels >= 0, levels * upper, levels * dynamic), u)

    def applied(self, requested, speeds, levels=None, brakes=None):
        """The efforts u_i [N] as they act on cars at ``speeds`` [m/s]: :meth:`efforts`, the wagons'
        air-brake forces ``brakes`` in place of theirs when given; every brake (an effort below 0: a
        locomotive's dynamic brake, a wagon's pneumatic brake) is a friction force, :func:`friction`
        times its size: it opposes the motion, never drives a car (a train rolling back is braked, not
        pushed back), and holds a standing car against up to its size."""
        u = self.efforts(requested, speeds, levels)
        if brakes is not None:
            u = np.where(self.loco, u, brakes)
        return np.where(u < 0, u * friction(speeds), u)

    def derivatives(self, y, requested, brakes=None, levels=None):
        """d/dt of (positions, speeds, works); ``brakes`` the wagons' air-brake forces now [N];
        ``levels`` the locomotives' notches (:meth:`levels`)."""
        n, c = self.n, self.consist
        p, v = y[:n], y[n:2 * n]
        u = self.applied(requested, v, levels, brakes)
        elastic, hysteresis, damping = self.coupler_parts(p, v)
        fin = elastic + hysteresis + damping
        running = self.running(v)
        grade, curve = self.grade_curve(p)
        net = u - running - grade - curve
        net[1:] += fin
        net[:-1] -= fin
        power = u * v
        traction = np.sum(np.maximum(power, 0.0)[self.loco])
        dynamic = np.sum(np.maximum(-power, 0.0)[self.loco])
        wagons = np.sum(np.maximum(-power, 0.0)[~self.loco])
        closing = v[:-1] - v[1:]
        return np.concatenate([v, net / c.mass, [traction, dynamic, wagons, running @ v, curve @ v, grade @ v,
                                                 damping @ closing, hysteresis @ closing]])

    def _sparsity(self):
        n = self.n
        s = lil_matrix((2 * n + QUADRATURES, 2 * n + QUADRATURES))
        for i in range(n):
            s[i, n + i] = 1  # dp/dt = v
            for j in (i - 1, i, i + 1):
                if 0 <= j < n:
                    s[n + i, j] = 1
                    s[n + i, n + j] = 1
        # the works' rows are left out: pure quadratures (nothing depends on them), and rows that
        # depend on every speed would make the finite-difference Jacobian cost one evaluation per car
        return s.tocsr()

    def step(self, state, requested, dt):
        """Advance ``state`` by ``dt`` [s] with the efforts ``requested`` [N per car] held."""
        n = self.n
        requested = np.asarray(requested, float)
        y0 = np.concatenate([state.positions, state.speeds, np.zeros(QUADRATURES)])
        scale = self.rtol / RTOL
        atol = np.concatenate([np.full(n, ATOL_POSITION * scale), np.full(n, ATOL_SPEED * scale),
                               np.full(QUADRATURES, ATOL_WORK)])
        pipe, levels = self.brake_pipe(state, requested, dt), self.levels(requested, state.speeds)
        t0 = state.time
        # scipy's finite-difference Jacobian grows its step tenfold each time a column's difference
        # is too small to trust, without bound: a coupler in its slack (draft_gear: a flat force)
        # overflows it after a few hundred Jacobians, and numpy warns ("overflow / invalid value
        # encountered in multiply", 170 times on a 5 km run). The trial is discarded there, and the
        # step's accuracy is the integrator's error control; a state that is not finite is refused below
        with np.errstate(over="ignore", invalid="ignore"):
            sol = solve_ivp(lambda t, y: self.derivatives(y, requested, None if pipe is None else pipe.at(t - t0),
                                                          levels),
                            (t0, t0 + dt), y0, method="BDF", rtol=self.rtol, atol=atol, jac_sparsity=self.jac_sparsity)
        if not sol.success or not np.all(np.isfinite(sol.y)):
            raise RuntimeError(f"cascade plant: integration failed ({sol.message if not sol.success else 'a state not finite'})")
        p, v, works = sol.y[:n, -1], sol.y[n:2 * n, -1], sol.y[2 * n:, -1]
        forces = np.array([self.coupler_forces(sol.y[:n, k], sol.y[n:2 * n, k]) for k in range(sol.y.shape[1])])
        self.history.append((sol.t, forces.astype(np.float32)))
        self.closing(sol.t, sol.y[:n])
        heads = sol.y[0] + 0.5 * self.consist.length[0]
        excess = float(np.max(np.max(sol.y[n:2 * n], axis=0) - self.segment.limit(heads)))
        brakes, commanded, sent = (None, None, ()) if pipe is None else (pipe.at(dt), pipe.current,
                                                                         self._sent(state, pipe.current, t0 + dt))
        return CascadeStep(CascadeState(p, v, t0 + dt, brakes, commanded, sent), forces[-1], float(np.abs(forces).max()),
                           *map(float, works[:3]), excess, tuple(map(float, works[3:])),
                           self.adhesion_use(sol.t, sol.y[:n], sol.y[n:2 * n], requested, levels), levels)

    def closing(self, times, positions):
        """Keep in :attr:`closest` the most compressed coupling at ``times`` [s] (``positions``
        (cars, points) [m]) if more so, relative to its limit (:class:`Closing`), than the one kept."""
        if self.n < 2:
            return
        share = (self.spacing[:, None] - (positions[:-1] - positions[1:])) / self.limit[:, None]
        j, k = np.unravel_index(np.argmax(share), share.shape)
        if share[j, k] > self.closest.compression / self.closest.limit:  # 0 / inf: none kept yet
            self.closest = Closing(float(share[j, k] * self.limit[j]), int(j), float(times[k]), float(self.spacing[j]),
                                   float(self.limit[j]))

    def holding_brakes(self, positions, creep):
        """The wagons' brake forces [N, <= 0; 0 for a locomotive] that hold the train standing at
        ``positions`` (a driver's hill start applies what holds, not the full brake): every wagon the
        same share of its envelope, the share whose brakes, acting as :func:`friction` rounds them,
        balance the grade, curve and running resistance pulling the train back at a creep of ``creep``
        [m/s] (the least brake under which it creeps no faster; more holds it slower); the whole
        brake if that is not enough, none where nothing pulls it back."""
        standing = np.zeros(self.n)
        pull = float(self.resistance(positions, standing).sum())
        lowest = np.where(self.loco, 0.0, self.envelopes(standing)[0])
        return lowest * float(np.clip(pull / (friction(creep) * max(-lowest.sum(), 1.0)), 0.0, 1.0))

    def hold(self, state, dt, creep):
        """A standing train held on its brakes for ``dt`` [s] (a driver's hill start): every car stands
        where it is; with ``air_brake`` on the wagons' brakes are what holds it at a creep under
        ``creep`` [m/s] (:meth:`holding_brakes`, seen by every wagon), so the next :meth:`step`
        releases them through the pipe (delay and tau_r)."""
        forces = self.coupler_forces(state.positions, np.zeros(self.n))
        brakes = None if self.air_brake is None else self.holding_brakes(state.positions, creep)
        self.history.append((np.array([state.time, state.time + dt]), np.array([forces, forces], np.float32)))
        standing = CascadeState(state.positions, np.zeros(self.n), state.time + dt, brakes, brakes)
        return CascadeStep(standing, forces, float(np.abs(forces).max(initial=0.0)), 0.0, 0.0, 0.0,
                           float(np.max(-self.segment.limit(np.atleast_1d(state.positions[0] + 0.5 * self.consist.length[0])))))

    def brake_pipe(self, state, requested, dt):
        """The wagons' brakes over a step from ``state`` (None: air_brake off): the command is the
        request clipped to each wagon's envelope (speed-independent)."""
        if self.air_brake is None:
            return None
        wagons = np.where(self.loco, 0.0, self.efforts(requested, state.speeds))
        forces = np.zeros(self.n) if state.brakes is None else state.brakes
        (_, previous), *flight = self._seen(state, state.time)
        return BrakePipe(forces, previous, wagons, self.delays, self.air_brake,
                         [(state.time - t, u) for t, u in flight])

    def _seen(self, state, now, also=()):
        """The commands sent (``state.sent`` and ``also``) from the newest every wagon sees at ``now``
        [s] on: ((time, command), ...)."""
        sent = [*(state.sent or [(-np.inf, np.zeros(self.n) if state.commanded is None else state.commanded)]), *also]
        late = self.delays[~self.loco].max(initial=0.0)
        first = max([i for i, (t, _) in enumerate(sent) if t + late <= now] or [0])
        return tuple(sent[first:])

    def _sent(self, state, command, end):
        """``state.sent`` with ``command`` sent at the step's start, from the newest every wagon sees at ``end``."""
        return self._seen(state, end, [(state.time, command)])
