"""One train's run between two stops on a common clock: the time-domain model (Farooqi 2018 eq. 8.1).

Several trains meet only in time (a shared substation, a leader ahead), so their runs are
written on one clock with a fixed step dt. On steps j = 0..n of one segment (n dt = the
segment's running time, departure and arrival fixed by the timetable):

    s_{j+1} - s_j = dt (v_j + v_{j+1}) / 2                                  (position, trapezoid)
    (v_{j+1} - v_j) / dt = (F_T,j - F_B,j - R_D(v_j, v_{j+1}) - G_j) / M       (speed, eq. 8.1)

with R_D the trapezoidal mean of the Davis resistance and G_j the gradient and curve force of the
segment averaged over the step, (Phi(s_{j+1}) - Phi(s_j)) / (s_{j+1} - s_j) with Phi the integral of
the force over s, its steps smoothed over about ``width`` metres (the only way a position-dependent
force enters a smooth NLP; ``physics.step_integral``, ``physics.interval_mean``: a step stood on
takes the force at its point). The mean, not the force at the step's middle: a step whose middle
lies near a gradient change would otherwise feel one side's force over the whole step. Speed limits
become a continuous piecewise-linear bound L(s) that is never above the train-length limit of the space grid: it ramps down over ``ramp`` metres before a
restriction and up over ``ramp`` metres after it ends. Envelopes hold as in ``ocp/space.py``
(at both step ends; of its lean cuts, a power limit left out where it never binds and the regenerative
force taken as the braking force where the regenerative envelope covers the braking one; else
F_R <= F_B under its own envelope); forces are in kN.

The electrical power at the pantograph in step j [kW] is
p_j = F_T,j vbar_j / eta_T - eta_R F_R,j vbar_j, vbar_j = (v_j + v_{j+1}) / 2 (Farooqi 2018 eq. 7.3).
"""
from dataclasses import dataclass
from typing import Any, NamedTuple, Optional, Sequence

import numpy as np
import pyomo.environ as pyo

from ecostudy.core.kinematics import point_resistance
from ecostudy.core.physics import (interval_mean, interval_resistance, smooth_table, smooth_table_slope, step_integral,
                                   table_coefficients)
from ecostudy.core.units import FloatArray, Numeric
from ecostudy.ocp import space
from ecostudy.ocp.problem import Case, Solved
from ecostudy.ocp.solver import Model

FORCE_SCALE = space.FORCE_SCALE
# the lean cuts of ``ocp.space`` a leg makes: not ``mid_power``, which moved a network leg's energy by
# 1.3 % on 0.5 s steps (bench/bench_size.py --case leg), over the 0.1 % allowed for a cut
CUTS = ("one_brake", "idle_power")


@dataclass
class Leg:
    """One train's run between two stops: departure step, steps and the space-grid case."""

    case: Case            # the prepared segment (grid, limits, envelope)
    start: int            # departure step on the common clock
    steps: int            # running time / dt
    dt: float
    line_start: float     # line position of the departure stop [m]
    direction: float      # +1 or -1 along the line

    @property
    def running_time(self) -> float:
        return self.steps * self.dt


def grade_steps(case: Case) -> tuple[FloatArray, FloatArray]:
    """(cuts, values): the gradient + curve force [N] of the segment as a step function of s, one value
    per piece between consecutive cuts (0, every gradient or curve change, the distance)."""
    seg = case.segment  # what the legs leave out is said where the study is read (studies.network.expand_network)
    cuts = np.unique(np.concatenate([[0.0], seg.breakpoints(), [seg.distance]]))
    force = np.asarray(point_resistance(seg, case.train, 0.5 * (cuts[:-1] + cuts[1:])), float)
    return cuts, force


def limit_profile(case: Case, ramp: float, dt: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """(positions, speeds) of a continuous piecewise-linear bound never above the node limits.

    The bound holds at the time steps only, and near a change a train covers at most
    lead = (higher limit) dt metres in one step, so the bound is down ``lead`` before a
    restriction and rises ``lead`` after its end: the straight line between two steps then
    never crosses the true limit.
    """
    x, lim = case.nodes, case.limits
    xs: list[float] = [0.0]
    vs: list[float] = [lim[0]]
    for k in range(1, len(x)):
        if lim[k] == lim[k - 1]:
            continue
        lead = max(lim[k], lim[k - 1]) * dt
        if lim[k] < lim[k - 1]:  # a restriction starts at x[k]
            b = max(x[k] - lead, xs[-1])
            a = max(b - ramp, xs[-1])
            xs += [a, b]
            vs += [vs[-1], lim[k]]
        else:  # a restriction ends at x[k-1]
            a = min(x[k - 1] + lead, case.segment.distance)
            xs += [a, min(a + ramp, case.segment.distance)]
            vs += [lim[k - 1], lim[k]]
    xs.append(case.segment.distance)
    vs.append(lim[-1])
    x_out, v_out = np.array(xs), np.array(vs)
    keep = np.concatenate([[True], np.diff(x_out) > 1e-9])
    return x_out[keep], v_out[keep]


ONE_HANDLE = 1e-3  # [kN^2] F_T F_B at most this: traction and braking never together (a complementarity)


def relax_one_handle(b: Model, bound: float = ONE_HANDLE) -> bool:
    """Set the bound of a leg's one-handle rows (:func:`add_leg`) to ``bound`` [kN^2]; False where
    the leg has none. A larger bound relaxes the complementarity (Scholtes' regularisation)."""
    rows = getattr(b, "one_handle", None)
    if rows is None or not len(rows):
        return False
    for j, row in rows.items():
        row.set_value(b.ft[j] * b.fb[j] <= bound)
    return True


@space.gc_paused
def add_leg(m: Model, name: str, leg: Leg, guess: Sequence[Sequence[float] | FloatArray] | None = None,
            width: float = 2.0, ramp: float = 20.0, limit_margin: float = 0.1,
            one_handle: bool | Sequence[bool] | FloatArray = True, cuts: Sequence[str] = CUTS) -> Model:
    """Add one leg as a block ``m.<name>`` with variables s, v, ft, fb, fr and expression p [kW].

    ``guess``: (s, v) arrays on the leg's steps, optionally followed by (F_T, F_B, F_R) per step
    [N]; else a trapezoidal speed profile. ``one_handle``: forbid traction and braking together,
    at every step (True), none (False) or the steps where a boolean array per step is True.
    ``cuts``: the lean cuts of ``ocp.space`` to make (``time_step`` has no meaning here).
    """
    case, train, n, dt = leg.case, leg.case.train, leg.steps, leg.dt
    b = pyo.Block()
    m.add_component(name, b)
    b.K = pyo.RangeSet(0, n)
    b.I = pyo.RangeSet(0, n - 1)
    top = float(np.max(case.limits))
    b.s = pyo.Var(b.K, bounds=(0.0, case.segment.distance))
    b.v = pyo.Var(b.K, bounds=(0.0, top))
    for var, value in ((b.s[0], 0.0), (b.v[0], 0.0), (b.s[n], case.segment.distance), (b.v[n], 0.0)):
        var.fix(value)
    speeds = np.linspace(0.0, top, 101)
    one_brake = "one_brake" in cuts and space.regeneration_covers_braking(train, speeds)
    b.ft, b.fb, fr = (pyo.Var(b.I, bounds=(0.0, top)) for top in _force_tops(train))
    b.fr = pyo.Reference(b.fb) if one_brake else fr
    set_start(b, leg, guess)
    mass = train.mass
    changes, grade_force = grade_steps(case)
    g_coef = step_integral(changes, grade_force / FORCE_SCALE, 0.25 * width)  # its integral over s
    lx, lv = limit_profile(case, ramp, dt)
    l_coef = table_coefficients(lx, lv, 0.25 * width)

    def kinematics(b: Model, j: int) -> Any:
        return b.s[j + 1] - b.s[j] == 0.5 * dt * (b.v[j] + b.v[j + 1])

    def dynamics(b: Model, j: int) -> Any:
        davis = interval_resistance(b.v[j], b.v[j + 1], train.davis, 0.0) / FORCE_SCALE
        grade = interval_mean(b.grade_integral[j], b.grade_integral[j + 1], b.s[j + 1] - b.s[j],
                              smooth_table_slope(0.5 * (b.s[j] + b.s[j + 1]), g_coef, 0.25 * width))
        return (b.v[j + 1] - b.v[j]) * (mass / FORCE_SCALE) / dt == b.ft[j] - b.fb[j] - davis - grade

    def limit(b: Model, j: int) -> Any:
        return b.v[j] <= smooth_table(b.s[j], l_coef, 0.25 * width) - limit_margin

    # one handle: traction and braking never together. A discounted traction cost (rules 7.7 and
    # 7.11) would otherwise buy "free" traction and sell it back as regenerated braking; where doing
    # both cannot pay (the caller's ``one_handle`` mask) the constraint, a complementarity, is left out
    held = np.broadcast_to(np.asarray(one_handle, bool), (n,))
    if held.any():
        b.one_handle = pyo.Constraint([j for j in range(n) if held[j]], rule=lambda b, j: b.ft[j] * b.fb[j] <= ONE_HANDLE)
    b.grade_integral = pyo.Expression(b.K, rule=lambda b, k: smooth_table(b.s[k], g_coef, 0.25 * width))
    b.kinematics = pyo.Constraint(b.I, rule=kinematics)
    b.dynamics = pyo.Constraint(b.I, rule=dynamics)
    b.limit = pyo.Constraint(pyo.RangeSet(1, n - 1), rule=limit)
    space.define_envelopes(b, train, train.regeneration is not None, speeds, cuts)
    if train.regeneration is None:
        b.fr.fix(0.0)
    eta_t, eta_r = train.traction_efficiency, train.regeneration_efficiency
    b.vbar = pyo.Expression(b.I, rule=lambda b, j: 0.5 * (b.v[j] + b.v[j + 1]))
    b.traction_kw = pyo.Expression(b.I, rule=lambda b, j: b.ft[j] * b.vbar[j] / eta_t)
    b.regen_kw = pyo.Expression(b.I, rule=lambda b, j: eta_r * b.fr[j] * b.vbar[j])
    b.p = pyo.Expression(b.I, rule=lambda b, j: b.traction_kw[j] - b.regen_kw[j])
    return b


def _force_tops(train: Any) -> tuple[float, float, float]:
    """Peaks of a leg's traction, braking and regenerative forces [kN]: their variables' upper bounds."""
    regen_top = min(train.regeneration.max_force, train.braking.peak) / FORCE_SCALE if train.regeneration else 0.0
    return train.traction.peak / FORCE_SCALE, train.braking.peak / FORCE_SCALE, regen_top


def set_start(b: Model, leg: Leg, guess: Sequence[Sequence[float] | FloatArray] | None = None) -> None:
    """Set the free variables of a leg block (:func:`add_leg`) to a start: ``guess``, (s, v) arrays on
    the leg's steps, optionally followed by (F_T, F_B, F_R) per step [N] (each force at most its peak);
    else a trapezoidal speed profile and no force. ``add_leg`` starts its block here; a solved block
    set back here starts again where a block built from the same ``guess`` would."""
    n = leg.steps
    s0, v0 = guess[:2] if guess is not None else _trapezoid(leg.case, n, leg.dt)
    given = guess[2:5] if guess is not None and len(guess) >= 5 else None
    forces = [np.asarray(f) / FORCE_SCALE for f in given] if given is not None else [np.zeros(n)] * 3
    for var, values in ((b.s, s0), (b.v, v0)):
        for j in b.K:
            if not var[j].fixed:
                var[j].set_value(float(values[j]))
    own = [b.ft, b.fb] + ([] if b.fr.is_reference() else [b.fr])  # F_R may be F_B itself (``one_brake``)
    for var, f, top in zip(own, forces, _force_tops(leg.case.train)):
        for j in b.I:
            if not var[j].fixed:
                var[j].set_value(min(float(f[j]), top))


def _trapezoid(case: Case, n: int, dt: float) -> tuple[FloatArray, FloatArray]:
    """A feasible-looking start: accelerate, hold, brake, with the area equal to the distance."""
    t = np.arange(n + 1) * dt
    total = n * dt
    ramp = 0.25 * total
    v_top = case.segment.distance / (total - ramp)
    v = np.minimum(np.minimum(t, total - t) / ramp, 1.0) * v_top
    s = np.concatenate([[0.0], np.cumsum(0.5 * dt * (v[:-1] + v[1:]))])
    s = np.minimum(s * (case.segment.distance / s[-1]), case.segment.distance)  # not past it by rounding
    return s, v


class LegRun(NamedTuple):
    """A solved leg on its clock steps: distance and speed per step boundary, forces and the
    electrical power per step [m, m/s, N, N, N, W] (p < 0: regenerating)."""

    s: np.ndarray
    v: np.ndarray
    ft: np.ndarray
    fb: np.ndarray
    fr: np.ndarray
    p: np.ndarray
    notes: Optional[dict[str, Any]] = None  # what the local-optimum guards did (``network.legs.solve_leg``)


def net_forces(b: Model) -> None:
    """Take the common part out of traction and braking at every step of a solved leg block
    (where no one-handle constraint held them apart, the optimum may keep a little of both where
    it costs nothing): the same net force, the regenerated share at most the braking force (also
    where Ipopt left it above by its tolerance)."""
    for j in b.I:
        ft, fb = pyo.value(b.ft[j]), pyo.value(b.fb[j])
        common = min(ft, fb)
        b.ft[j].set_value(ft - common)
        b.fb[j].set_value(fb - common)
        if not b.fr[j].fixed:  # also within the solver's tolerance on F_R <= F_B
            b.fr[j].set_value(min(pyo.value(b.fr[j]), fb - common))


def leg_arrays(b: Model) -> LegRun:
    """The :class:`LegRun` of a solved leg block, traction and braking netted (:func:`net_forces`)."""
    net_forces(b)
    s = np.array([pyo.value(b.s[j]) for j in b.K])
    v = np.array([pyo.value(b.v[j]) for j in b.K])
    ft, fb, fr = (np.array([pyo.value(x[j]) for j in b.I]) * FORCE_SCALE for x in (b.ft, b.fb, b.fr))
    p = np.array([pyo.value(b.p[j]) for j in b.I]) * 1e3
    return LegRun(s, v, ft, fb, fr, p)


def guess_from_space(result: Solved, leg: Leg) -> tuple[FloatArray, FloatArray]:
    """(s, v) on the leg's steps from a space-domain run of the same segment (its time profile)."""
    t, x = result.trajectory.time, result.trajectory.nodes
    scale = leg.running_time / t[-1]
    tj = np.arange(leg.steps + 1) * leg.dt / scale
    s = np.interp(tj, t, x)
    v = np.gradient(s, leg.dt)
    v[0] = v[-1] = 0.0
    return s, np.clip(v, 0.0, None)
