"""Farooqi 2018's shrinking-horizon move-blocking FHOCP (eqs. 4.9, 4.18, 4.19, 4.31) as one movable
time-domain NLP, written once and re-solved from every sample by bounds alone.

On absolute samples i = 0 .. k_f (sample time T_s) the states are the position s_i and speed v_i;
the handle is held over blocks of L samples aligned to absolute multiples of L (eq. 4.8, see
``control/blocking.py``): u_i = u+_b - u-_b with b = floor(i / L), u+ and u- in [0, 1].

    s_i+1 - s_i = w_i T_s (v_i + v_i+1) / 2
    (v_i+1 - v_i) M / T_s = w_i (F_T,max u+_b - F_B,max u-_b - R_D(v_i, v_i+1) - G(s_mid))

with the envelopes and the Davis term R_D as trapezoidal means over the step; the braking, resisting
and grade forces are multiplied by ``physics.moving_share(v_i + v_i+1)``, which is 0 for a step
that starts and ends at a stand: a train that stops before k_f waits there (the brakes hold it)
instead of being driven below v = 0. The grade and curve force G of each step and the speed bound of each node are those along the positions the last
solve predicted (held by bounds, :func:`update_profile`), not functions of s inside the NLP: a
position-dependent step function made every solve 1-10 s (measured; docs/closed_loop.md). This is eq. 4.1 with the
trapezoid instead of forward Euler: at T_s = 0.38 s forward Euler's position error alone is
v dv / 2, decimetres per step while accelerating, which the plant would report as a disturbance.

Moving the start to sample k and state (s, v) changes bounds only: the steps already run get the
share w_i = 0 (their states equal the measured one) and the blocks already run are held at 0. The
terminal set X_f = {(x_f, 0)} is kept through Delta(x, X_f) = max(|s_kf - x_f|, 1 s * v_kf) <= gamma
(metres; the speed scaled by one second, the distance it would run on in a second). The objective
is (alpha J + omega gamma) / J_ref with J = sum w_i T_s F_T,i vbar_i in kJ (eq. 4.4 with forces in
kN) and alpha, omega variables fixed by bounds, so the nominal (gamma = 0), the two steps of the
relaxed strategy (alpha = 0, omega = 1; then alpha = 1, gamma <= its minimum) and the
multi-objective one (alpha = 1, omega) are the same NL file.
"""
from typing import Any

import numpy as np
import pyomo.environ as pyo

from ecostudy.core.grid import warn_unmodelled
from ecostudy.core.kinematics import clock, point_resistance
from ecostudy.core.physics import Envelope, davis_resistance, interval_resistance, moving_share
from ecostudy.core.types import State
from ecostudy.core.units import FloatArray
from ecostudy.ocp.problem import Case
from ecostudy.ocp.session import Options, Outcome, Session
from ecostudy.ocp.solver import Model, Var
from ecostudy.ocp.space import gc_paused
from ecostudy.ocp.timedomain import FORCE_SCALE


def time_guess(case: Case, speeds_on_nodes: FloatArray, kf: int, ts: float) -> tuple[FloatArray, FloatArray]:
    """(s, v) on the samples from a speed profile on the space grid, stretched to k_f T_s."""
    v = np.maximum(speeds_on_nodes, 1e-3)
    t = clock(v, case.nodes)
    t *= kf * ts / t[-1]
    ti = np.arange(kf + 1) * ts
    s = np.interp(ti, t, case.nodes)
    vi = np.interp(ti, t, speeds_on_nodes)
    vi[0] = vi[-1] = 0.0
    return s, vi


def handle_guess(case: Case, s: FloatArray, v: FloatArray, ts: float, block: int) -> FloatArray:
    """The handle per block that the speed profile (s, v) on the samples needs (mean over the block)."""
    train = case.train
    vm = 0.5 * (v[:-1] + v[1:])
    need = train.mass * np.diff(v) / ts + davis_resistance(vm, *train.davis) + point_resistance(
        case.segment, train, np.clip(0.5 * (s[:-1] + s[1:]), 0.0, case.segment.distance))
    u = np.where(need >= 0, need / train.traction.force(vm), need / train.braking.force(vm))
    blocks = np.arange(len(u)) // block
    return np.clip(np.bincount(blocks, u) / np.bincount(blocks), -1.0, 1.0)


@gc_paused
def build_blocked(case: Case, ts: float, kf: int, block: int, guess: tuple[FloatArray, FloatArray],
                  margin: float = 0.1) -> Model:
    """The FHOCP on samples 0..k_f with blocks of ``block`` samples; ``guess`` = (s, v) on them."""
    train, seg = case.train, case.segment
    warn_unmodelled(seg, "the SBPC time-domain NLP")
    n, nb = kf, (kf - 1) // block + 1
    m = pyo.ConcreteModel(name="sbpc")
    m.K, m.I, m.B = pyo.RangeSet(0, n), pyo.RangeSet(0, n - 1), pyo.RangeSet(0, nb - 1)
    s0, v0 = guess
    m.block, m.margin, m.s_top, m.ts = block, margin, seg.distance + 200.0, ts
    m.s = pyo.Var(m.K, bounds=(0.0, m.s_top), initialize=lambda m, i: float(s0[i]))
    m.v = pyo.Var(m.K, bounds=(0.0, float(np.max(case.limits))), initialize=lambda m, i: float(v0[i]))
    u0 = handle_guess(case, s0, v0, ts, block)
    m.up = pyo.Var(m.B, bounds=(0.0, 1.0), initialize=lambda m, b: max(float(u0[b]), 0.0))
    m.um = pyo.Var(m.B, bounds=(0.0, 1.0), initialize=lambda m, b: max(-float(u0[b]), 0.0))
    m.w = pyo.Var(m.I, bounds=(1.0, 1.0), initialize=1.0)
    m.grade = pyo.Var(m.I, initialize=0.0)  # G per step [kN], held by bounds (update_profile)
    m.gamma = pyo.Var(bounds=(0.0, 0.0), initialize=0.0)
    m.alpha = pyo.Var(bounds=(1.0, 1.0), initialize=1.0)
    m.omega = pyo.Var(bounds=(0.0, 0.0), initialize=0.0)
    mass = train.mass / FORCE_SCALE
    davis = tuple(c / FORCE_SCALE for c in train.davis)

    def mean(envelope: Envelope, i: int) -> Any:
        return 0.5 * (envelope.smooth_force(m.v[i]) + envelope.smooth_force(m.v[i + 1])) / FORCE_SCALE

    m.ft = pyo.Expression(m.I, rule=lambda m, i: mean(train.traction, i) * m.up[i // block])
    m.fb = pyo.Expression(m.I, rule=lambda m, i: mean(train.braking, i) * m.um[i // block])
    m.kinematics = pyo.Constraint(m.I, rule=lambda m, i: m.s[i + 1] - m.s[i] == m.w[i] * 0.5 * ts * (m.v[i] + m.v[i + 1]))

    def dynamics(m: Model, i: int) -> Any:
        resist = interval_resistance(m.v[i], m.v[i + 1], davis, m.grade[i])
        held = moving_share(m.v[i] + m.v[i + 1])  # a standstill: the train may wait at the stop
        return (m.v[i + 1] - m.v[i]) * mass / ts == m.w[i] * (m.ft[i] - held * (m.fb[i] + resist))

    m.dynamics = pyo.Constraint(m.I, rule=dynamics)
    m.reach_hi = pyo.Constraint(expr=m.s[n] - seg.distance <= m.gamma)
    m.reach_lo = pyo.Constraint(expr=seg.distance - m.s[n] <= m.gamma)
    m.stand = pyo.Constraint(expr=m.v[n] * 1.0 <= m.gamma)  # 1 s: speed as the distance run on in a second
    m.step_work = pyo.Expression(m.I, rule=lambda m, i: m.w[i] * ts * m.ft[i] * 0.5 * (m.v[i] + m.v[i + 1]))  # kJ
    m.work = pyo.Expression(expr=sum(m.step_work[i] for i in m.I))
    m.work_ref = max(train.traction.peak * seg.distance * 0.1 / 1e3, 1.0)  # kJ, the scale of J
    # alpha multiplies each step's work, not their sum: ASL sizes the Hessian by the product terms of
    # the objective, and alpha times the whole sum made it dense (172 595 entries for 825 variables)
    m.objective = pyo.Objective(expr=(sum(m.alpha * m.step_work[i] for i in m.I) + m.omega * m.gamma) / m.work_ref)
    m.case = case
    m.profile = profile_along(case, np.asarray(s0, float), np.asarray(v0, float), ts, margin)
    return m


def profile_along(case: Case, s: FloatArray, v: FloatArray, ts: float, margin: float) -> tuple[FloatArray, FloatArray]:
    """(grade force per step [kN], speed bound per node [m/s]) along predicted positions ``s``:
    the grade and curve force averaged over each step's span, and at each node the lowest limit
    within the distance run in a step either side (a restriction is met before it is reached)."""
    seg, train = case.segment, case.train
    s = np.clip(s, 0.0, seg.distance)
    frac = np.linspace(0.0, 1.0, 5)
    spans = s[:-1, None] + (s[1:] - s[:-1])[:, None] * frac
    grade = point_resistance(seg, train, spans.ravel()).reshape(spans.shape).mean(axis=1) / FORCE_SCALE
    reach = np.maximum(v, 1.0) * ts
    around = np.clip(s[:, None] + reach[:, None] * np.linspace(-1.0, 1.0, 5), 0.0, seg.distance)
    bound = seg.limit(around.ravel()).reshape(around.shape).min(axis=1) - margin
    return grade, np.maximum(bound, 0.5)


def update_profile(m: Model) -> None:
    """Move the grade and the speed bounds to the positions the last solve predicts."""
    s = np.array([pyo.value(m.s[i]) for i in m.K])
    v = np.array([pyo.value(m.v[i]) for i in m.K])
    m.profile = profile_along(m.case, s, v, m.ts, m.margin)


def set_blocked_start(session: Session, m: Model, k: int, state: State) -> None:
    """Bounds for a solve from sample ``k`` at ``state`` (position, speed), with the grade and the
    speed bounds of the last predicted positions (:func:`update_profile`)."""
    n = len(m.I)
    grade, bound = m.profile
    s = float(np.clip(state.position, 0.0, m.s_top))
    v = max(float(state.speed), 0.0)
    variables: list[Var] = []
    lows: list[float | None] = []
    highs: list[float | None] = []
    for i in range(n):
        variables += [m.w[i], m.grade[i]]
        lows += [0.0 if i < k else 1.0, float(grade[i])]
        highs += [0.0 if i < k else 1.0, float(grade[i])]
    for i in range(n + 1):
        past = i <= k
        variables += [m.s[i], m.v[i]]
        lows += [s if past else 0.0, v if past else 0.0]
        highs += [s if past else m.s_top, v if past else float(bound[i])]
    for b in m.B:
        gone = (b + 1) * m.block <= k
        variables += [m.up[b], m.um[b]]
        lows += [0.0, 0.0]
        highs += [0.0 if gone else 1.0, 0.0 if gone else 1.0]
    session.set_many_bounds(variables, lows, highs)
    session.set_start_values([m.s[i] for i in range(k + 1)] + [m.v[i] for i in range(k + 1)], [s] * (k + 1) + [v] * (k + 1))


def set_objective(session: Session, m: Model, alpha: float, omega: float, gamma_max: float | None) -> None:
    """The objective's weights and the terminal distance allowed (``gamma_max`` None: any)."""
    session.set_many_bounds([m.alpha, m.omega, m.gamma], [alpha, omega, 0.0], [alpha, omega, gamma_max])


def handle_at(m: Model, k: int) -> float:
    """The handle the solved model applies at sample ``k``."""
    b = min(k // m.block, len(m.B) - 1)
    return float(pyo.value(m.up[b]) - pyo.value(m.um[b]))


class Blocked:
    """The simultaneous program above behind the interface SBPC drives (``ocp.condensed.Condensed``
    is the other): ``start(k, state)``, ``solve(alpha, omega, gamma_max)``, ``gamma``, ``follow()``,
    ``handle(k)``; one model and NL file for the whole trip, each solve warm from the last."""

    def __init__(self, case: Case, ts: float, kf: int, block: int, guess: tuple[FloatArray, FloatArray],
                 options: Options) -> None:
        self.model = build_blocked(case, ts, kf, block, guess)
        self.session, self.options = Session(self.model), options

    def start(self, k: int, state: State) -> None:
        set_blocked_start(self.session, self.model, k, state)

    def solve(self, alpha: float, omega: float, gamma_max: float | None) -> Outcome:
        set_objective(self.session, self.model, alpha, omega, gamma_max)
        return self.session.solve(self.options)

    @property
    def gamma(self) -> float:
        return float(self.model.gamma.value)

    def follow(self) -> None:
        update_profile(self.model)

    def handle(self, k: int) -> float:
        return handle_at(self.model, k)

    def handles(self, k: int) -> FloatArray:
        """The handles of samples k .. k_f - 1 (one read of the block values)."""
        m = self.model
        u = np.array([pyo.value(m.up[b]) - pyo.value(m.um[b]) for b in m.B], dtype=float)
        handles: FloatArray = u[np.minimum(np.arange(k, len(m.I)) // m.block, len(u) - 1)]
        return handles
