"""Space-domain direct transcription of the train OCP in Pyomo (Farooqi 2018 eq. 2.16, Yazhemsky 2017 eq. 4.1).

On nodes x_0 = 0 < ... < x_N = D with steps ds_k, the variables are the speed v_k [m/s] and
traction and braking forces per interval, in kN (scaling: forces in kN, dynamics per unit mass;
see docs/benchmarks.md).

Dynamics, exact for constant acceleration over an interval, and free of the standstill
singularity of dv/ds = a/v (Yazhemsky 2017 §3.2.1) because they never divide by v:

    (v_{k+1}^2 - v_k^2) / (2 ds_k) = (F_T,k - F_B,k - R_k) / M          (energy form of eq. 2.7)
    dt_k = 2 ds_k / (v_k + v_{k+1})                                        (time, eq. 2.16)

with R_k the trapezoidal mean of the Davis resistance at both nodes plus the gradient and curve
forces of the interval (eq. 2.2).

The NLP is as lean as the problem allows (:data:`CUTS`, each measured in docs/speed.md): the
interval time is an expression of the speeds, not a variable (``time_step``); the regenerative
force is the braking force where the regenerative envelope covers the whole braking envelope
(``one_brake``); a braking or regenerative power limit that never binds is no row
(``idle_power``, as ``core.grid.drop_idle_power`` does for traction). On request (not by default,
:data:`CUTS`), a power limit is one row per interval at its mean speed (v_k + v_{k+1}) / 2, the speed
at which the objective prices the interval's power (``physics.line_energy``), not one at each end
(``mid_power``); a speed-force table holds at both ends of each interval in any case. A movable model
(:mod:`ecostudy.ocp.restart`), whose intervals may be partly run, keeps its interval times as
variables tied by dt_k (v_k + v_{k+1}) = 2 ds_k w_k (an interval already run has w_k = 0 and may
have v_k + v_{k+1} = 0) and a regenerative force of its own (:data:`MOVABLE_CUTS`).
"""
import functools
from typing import Any, Callable, ParamSpec, Sequence, TypeAlias, TypeVar

import numpy as np
import pyomo.core as pyo  # not pyomo.environ: see ocp.solver.prepare
from pyomo.common.gc_manager import PauseGC

from ecostudy.core.kinematics import interval_davis, interval_grade_force, interval_time
from ecostudy.core.physics import interval_resistance, line_energy
from ecostudy.core.physics import Envelope, smooth_table
from ecostudy.core.grid import Segment
from ecostudy.core.types import Train, Window
from ecostudy.core.units import FloatArray, Numeric
from ecostudy.ocp.solver import Model, Var

# a starting point on the grid: (v [m/s] per node, dt [s], F_T [N], F_B [N] per interval)
Guess: TypeAlias = tuple[Sequence[float] | FloatArray, Sequence[float] | FloatArray, Sequence[float] | FloatArray,
                         Sequence[float] | FloatArray]
P = ParamSpec("P")
R = TypeVar("R")

FORCE_SCALE = 1000.0  # [N] per NLP force unit: forces in kN (bench/bench_variants.py measures N)
# multiplier on the speed recursion: 1 = dynamics per unit mass (bench_variants.py measures M)
DYNAMICS_SCALE = 1.0
# weight of traction + braking work in the all-out objective: removes the flat direction of
# simultaneous traction and braking; its effect on the minimum time is measured in the tests
TIME_REGULARISATION = 1e-4
# the cuts of the lean NLP (module docstring) made by default: the exact ones. ``mid_power`` moves
# optima by up to 0.05 % (bench/bench_size.py), but the network studies start their legs from these
# runs, and a leg started from the moved run found another local optimum: +5 % on the 2-train study's
# independent strategy (docs/speed.md). bench/bench_size.py builds with each of ALL_CUTS in turn.
CUTS = ("time_step", "one_brake", "idle_power")
ALL_CUTS = CUTS + ("mid_power",)
MOVABLE_CUTS = ("mid_power", "idle_power")  # the cuts a movable model makes: its envelope rows as any model's


def _bounded(envelope: Envelope) -> float:
    """Upper bound of a force variable [kN]."""
    return envelope.peak / FORCE_SCALE


def energy_reference(train: Train, segment: Segment) -> float:
    """Scale of the energy objectives [J]: a tenth of peak traction over the whole distance."""
    return max(train.traction.peak * segment.distance * 0.1, 1.0)


def regeneration_covers_braking(train: Train, speeds: FloatArray) -> bool:
    """True when the regenerative envelope allows the whole braking force at every admissible
    speed [m/s]: then the regenerative force of a net-energy optimum is the braking force (the
    objective credits it, nothing else limits it), and one variable serves both."""
    return train.regeneration is not None and bool(np.all(
        np.asarray(train.regeneration.force(speeds)) >= np.asarray(train.braking.force(speeds))))


def define_variables(m: Model, nodes: FloatArray, limits: FloatArray, train: Train, guess: Guess,
                     with_regeneration: bool, movable: bool = False, cuts: Sequence[str] = CUTS) -> None:
    """Speeds per node and forces [kN] per interval; the interval times as variables (a movable
    model, or without the ``time_step`` cut) or as expressions of the speeds. Standstill at both
    ends is fixed, or, for a ``movable`` model, held by bounds that :func:`set_start` and
    :func:`set_end` change; a movable model also has the share w_k of each interval still to run
    (bounds 1) and the clock t0 at the start (bounds 0)."""
    n = len(nodes) - 1
    m.K = pyo.RangeSet(0, n)
    m.I = pyo.RangeSet(0, n - 1)
    v0, dt0, ft0, fb0 = guess
    m.v = pyo.Var(m.K, bounds=lambda m, k: (0.0, float(limits[k])), initialize=lambda m, k: float(v0[k]))
    if movable:
        for k in (0, n):
            m.v[k].setlb(0.0)
            m.v[k].setub(0.0)
        m.w = pyo.Var(m.I, bounds=(1.0, 1.0), initialize=1.0)
        m.t0 = pyo.Var(bounds=(0.0, 0.0), initialize=0.0)
        m.mass_scale = pyo.Var(bounds=(1.0, 1.0), initialize=1.0)  # the train's mass over the model's
    else:
        m.v[0].fix(0.0)
        m.v[n].fix(0.0)
    if "time_step" in cuts and not movable:
        ds = np.diff(nodes).tolist()
        m.dt = pyo.Expression(m.I, rule=lambda m, k: interval_time(m.v[k], m.v[k + 1], ds[k]))
    else:
        m.dt = pyo.Var(m.I, bounds=(0.0, None), initialize=lambda m, k: float(dt0[k]))
    m.ft = pyo.Var(m.I, bounds=(0.0, _bounded(train.traction)), initialize=lambda m, k: float(ft0[k]) / FORCE_SCALE)
    m.fb = pyo.Var(m.I, bounds=(0.0, _bounded(train.braking)), initialize=lambda m, k: float(fb0[k]) / FORCE_SCALE)
    if with_regeneration and train.regeneration is None:
        raise ValueError("with_regeneration: the train has no electric brake")
    if with_regeneration and "one_brake" in cuts and not movable and regeneration_covers_braking(
            train, np.linspace(0.0, float(np.max(limits)), 101)):
        m.fr = pyo.Reference(m.fb)  # the same variables: no row, no bound of its own
    elif with_regeneration and train.regeneration is not None:
        top = min(train.regeneration.max_force, train.braking.peak) / FORCE_SCALE
        m.fr = pyo.Var(m.I, bounds=(0.0, top), initialize=lambda m, k: min(float(fb0[k]) / FORCE_SCALE, top))


def start_point(m: Model, guess: Guess) -> tuple[list[Var], list[float]]:
    """(variables, values) that start a re-solve of a written model ``m`` from ``guess`` = (v, dt,
    F_T [N], F_B [N]) exactly as :func:`define_variables` and :func:`define_timing` would have
    started a new one (T within its current bounds); fixed variables (the end speeds) are left
    out, as the NLP has none of them."""
    v0, dt0, ft0, fb0 = guess
    pairs = [(m.v[k], float(v0[k])) for k in m.K if not m.v[k].fixed]
    if m.dt.ctype is pyo.Var:
        pairs += [(m.dt[k], float(dt0[k])) for k in m.I]
    pairs += [(m.ft[k], float(ft0[k]) / FORCE_SCALE) for k in m.I]
    pairs += [(m.fb[k], float(fb0[k]) / FORCE_SCALE) for k in m.I]
    if hasattr(m, "fr") and not is_braking(m):
        top = m.fr[0].ub
        pairs += [(m.fr[k], min(float(fb0[k]) / FORCE_SCALE, top)) for k in m.I]
    lo, hi = m.T.bounds
    pairs.append((m.T, min(max(float(sum(float(x) for x in dt0)), lo), hi if hi is not None else float("inf"))))
    return [p[0] for p in pairs], [p[1] for p in pairs]


def is_braking(m: Model) -> bool:
    """True when the regenerative force of ``m`` is its braking force (the ``one_brake`` cut)."""
    return hasattr(m, "fr") and m.fr.ctype is pyo.Var and m.fr[0] is m.fb[0]


def define_dynamics(m: Model, nodes: FloatArray, segment: Segment, train: Train) -> None:
    """Speed (energy form) recursion and, where the interval times are variables, the time
    recursion, scaled to O(1) residuals."""
    ds = np.diff(nodes).tolist()  # Python floats: numpy scalars make Pyomo expressions slow
    per_kg = [tuple(float(x) / train.mass for x in abc) for abc in zip(*interval_davis(segment, train, nodes))]
    fixed = (interval_grade_force(segment, train, nodes) / train.mass).tolist()
    km, s = float(FORCE_SCALE / train.mass), DYNAMICS_SCALE

    def speed(m: Model, k: int) -> Any:
        # (v1^2 - v0^2) / (2 ds) = w ((F_T - F_B) / M - R(v0, v1) / M)  (physics.interval_resistance);
        # w = 1, or the share of the interval still to run in a movable model (0: already run)
        if hasattr(m, "mass_scale"):  # an estimated mass: inertia and the grade and curve force scale with it
            inertia = m.mass_scale * (m.v[k + 1] ** 2 - m.v[k] ** 2) * (0.5 / ds[k])
            net = interval_resistance(m.v[k], m.v[k + 1], per_kg[k], m.mass_scale * fixed[k]) - km * (m.ft[k] - m.fb[k])
            return s * (inertia + share(m, k, net)) == 0.0
        net = interval_resistance(m.v[k], m.v[k + 1], per_kg[k], fixed[k]) - km * (m.ft[k] - m.fb[k])
        return s * ((m.v[k + 1] ** 2 - m.v[k] ** 2) * (0.5 / ds[k]) + share(m, k, net)) == 0.0

    def time(m: Model, k: int) -> Any:
        return m.dt[k] * (m.v[k] + m.v[k + 1]) / (2 * ds[k]) == share(m, k, 1.0)

    m.speed = pyo.Constraint(m.I, rule=speed)
    if m.dt.ctype is pyo.Var:
        m.time = pyo.Constraint(m.I, rule=time)
    m.running_time = pyo.Expression(expr=sum(m.dt[k] for k in m.I))


def _envelope_constraints(m: Model, name: str, force: Var, envelope: Envelope, mid: bool = False) -> None:
    """force_k <= envelope(v) at both ends of interval k; a power limit, with ``mid``, once at the
    mean speed: F_k (v_k + v_{k+1}) / 2 <= P, one row per interval instead of two."""
    if envelope.kind == "table":
        c0, c1, terms = envelope.smooth_coefficients  # in N; the force variables are in kN
        scaled = (c0 / FORCE_SCALE, c1 / FORCE_SCALE, [(a / FORCE_SCALE, v) for a, v in terms])
        m.add_component(name + "_env", pyo.Expression(
            m.K, rule=lambda m, k: smooth_table(m.v[k], scaled, envelope.width)))
        env = getattr(m, name + "_env")
        m.add_component(name + "_lo", pyo.Constraint(m.I, rule=lambda m, k: force[k] <= env[k]))
        m.add_component(name + "_hi", pyo.Constraint(m.I, rule=lambda m, k: force[k] <= env[k + 1]))
    elif np.isfinite(envelope.max_power):
        pk = envelope.max_power / FORCE_SCALE  # [kW]; force [kN] * speed [m/s] is in kW
        if mid:
            m.add_component(name + "_mid", pyo.Constraint(
                m.I, rule=lambda m, k: force[k] * (m.v[k] + m.v[k + 1]) / (2 * pk) <= 1.0))
            return
        m.add_component(name + "_lo", pyo.Constraint(m.I, rule=lambda m, k: force[k] * m.v[k] / pk <= 1.0))
        m.add_component(name + "_hi", pyo.Constraint(m.I, rule=lambda m, k: force[k] * m.v[k + 1] / pk <= 1.0))


def interval_envelope(envelope: Envelope, v0: Any, v1: Any, cuts: Sequence[str] = CUTS) -> FloatArray:
    """The force limit of intervals between speeds ``v0`` and ``v1`` [m/s] as the NLP binds it [N]
    (numpy arrays): a table the lower of its two ends, a power limit min(F_max, P / v_mean) at the
    mean speed (``mid_power``; else at the lower end too)."""
    if envelope.kind != "table" and "mid_power" in cuts:
        return np.asarray(envelope.force(0.5 * (np.asarray(v0, float) + np.asarray(v1, float))), float)
    return np.asarray(np.minimum(envelope.force(v0), envelope.force(v1)), float)


def define_acceleration_bounds(m: Model, nodes: FloatArray, train: Train) -> None:
    """Net acceleration and deceleration bounds of the train (TTOBench ``max acceleration`` and
    ``max deceleration``, OSRD comfort acceleration), per interval on the recursion's mean
    acceleration: (v_k+1^2 - v_k^2) / (2 ds_k) in [-d_max, a_max] (times the share still to run)."""
    ds = np.diff(nodes).tolist()

    def mean(m: Model, k: int) -> Numeric:
        return (m.v[k + 1] ** 2 - m.v[k] ** 2) * (0.5 / ds[k])

    if np.isfinite(train.max_acceleration):
        a = float(train.max_acceleration)
        m.max_acceleration = pyo.Constraint(m.I, rule=lambda m, k: mean(m, k) <= share(m, k, a))
    if np.isfinite(train.max_deceleration):
        d = float(train.max_deceleration)
        m.max_deceleration = pyo.Constraint(m.I, rule=lambda m, k: -mean(m, k) <= share(m, k, d))


def define_envelopes(m: Model, train: Train, with_regeneration: bool, speeds: FloatArray,
                     lean: Sequence[str] = CUTS) -> None:
    """Traction, braking and regenerative limits F <= F_max(v) (Farooqi 2018, eqs. 2.3-2.4); with the
    ``idle_power`` cut, a power limit that never binds at the admissible ``speeds`` [m/s] is no row
    (``physics.power_never_binds``), with ``mid_power`` a power limit is one row per interval."""
    mid = "mid_power" in lean

    def lean_envelope(envelope: Envelope) -> Envelope:
        return envelope.without_power() if "idle_power" in lean and envelope.idle_power(speeds) else envelope

    _envelope_constraints(m, "traction", m.ft, lean_envelope(train.traction), mid)
    _envelope_constraints(m, "braking", m.fb, lean_envelope(train.braking), mid)
    if with_regeneration and not is_braking(m) and train.regeneration is not None:
        m.regen_share = pyo.Constraint(m.I, rule=lambda m, k: m.fr[k] <= m.fb[k])
        _envelope_constraints(m, "regen", m.fr, lean_envelope(train.regeneration), mid)


def share(m: Model, k: int, expr: Numeric) -> Numeric:
    """``expr`` times the share of interval k still to run (movable models), else ``expr``."""
    return m.w[k] * expr if hasattr(m, "w") else expr


def define_timing(m: Model, time_ref: float, running_time: float | None = None,
                  window: tuple[float, float] | None = None) -> None:
    """Running time T as a variable tied to the interval times; the timing request is its bounds.

    A fixed running time (eq. 2.6 as equality) is T in [t, t], an arrival window (Yazhemsky 2017
    eq. 4.1g) is T in [Tmin, Tmax], all-out leaves T free. Keeping the request in bounds lets a
    sweep change it without writing the NL file again (:class:`ecostudy.ocp.session.Session`).
    """
    lo, hi = timing_bounds(running_time, window)
    start = min(max(pyo.value(m.running_time), lo), hi if hi is not None else float("inf"))
    m.T = pyo.Var(bounds=(lo, hi), initialize=start)
    m.time_ref = time_ref
    clock = m.t0 if hasattr(m, "t0") else 0.0  # a movable model starts at the clock t0
    m.arrival = pyo.Constraint(expr=(m.running_time + clock - m.T) / time_ref == 0.0)


def window_node(nodes: FloatArray, distance: float) -> int:
    """The grid node of a timing point (``core.grid.make_grid`` places one there)."""
    return int(np.argmin(np.abs(nodes - distance)))


def passing_time(m: Model, nodes: FloatArray, distance: float) -> Numeric:
    """Time [s] from departure to the node at ``distance``: the sum of the interval times before it
    (plus the start clock t0 of a movable model)."""
    return sum(m.dt[j] for j in range(window_node(nodes, distance))) + (m.t0 if hasattr(m, "t0") else 0.0)


def define_windows(m: Model, nodes: FloatArray, windows: Sequence[Window], time_ref: float) -> None:
    """Timing points on the way: earliest/latest passing time and speed bounds at a node.

    The time at node k is the sum of the interval times before it; each window has its own node
    (core.grid.make_grid places one there).
    """
    m.windows = pyo.ConstraintList()
    m.window_nodes = [window_node(nodes, w.distance) for w in windows]
    for w in windows:
        k = window_node(nodes, w.distance)
        passing = passing_time(m, nodes, w.distance) / time_ref
        if w.earliest is not None:
            m.windows.add(passing >= w.earliest / time_ref)
        if w.latest is not None:
            m.windows.add(passing <= w.latest / time_ref)
        lo, hi = m.v[k].bounds
        m.v[k].setlb(max(lo, w.min_speed or 0.0))
        m.v[k].setub(min(hi, w.max_speed) if w.max_speed is not None else hi)


def timing_bounds(running_time: float | None = None,
                  window: tuple[float, float] | None = None) -> tuple[float, float | None]:
    """(lower, upper) bounds of T [s] for a fixed running time, a window, or neither."""
    if running_time is not None:
        return (float(running_time), float(running_time))
    if window is not None:
        return (float(window[0]), float(window[1]))
    return (0.0, None)


def define_objective(m: Model, nodes: FloatArray, train: Train, objective: str, weights: tuple[float, float],
                     time_ref: float, energy_ref: float) -> None:
    """Objectives, each divided by a reference so that it is O(1).

    energy      traction work sum F_T,k ds_k (Farooqi 2018 eq. 2.16)
    net_energy  traction work / eta_T - eta_R * regenerated work (Farooqi 2018 eq. 7.3)
    time        running time, plus a small multiple of traction + braking work ("all-out")
    mixed       w_t T + w_e E / Ms (Yazhemsky 2017 eq. 4.1a, energy per unit mass [J/kg]); weights whose
                larger is below 1 scaled up to it (their ratio alone decides the run)
    """
    ds = np.diff(nodes).tolist()
    m.traction_work = pyo.Expression(expr=FORCE_SCALE * sum(share(m, k, ds[k] * m.ft[k]) for k in m.I))
    braking = FORCE_SCALE * sum(share(m, k, ds[k] * m.fb[k]) for k in m.I) / energy_ref
    energy = m.traction_work / energy_ref
    if objective == "energy":
        expr = energy
    elif objective == "net_energy":  # a train without an electric brake regenerates nothing
        def line(k: int) -> Numeric:  # physics.line_energy: constant efficiencies or maps over (speed, force)
            fr = FORCE_SCALE * m.fr[k] if hasattr(m, "fr") else 0.0
            return line_energy(FORCE_SCALE * m.ft[k], fr, 0.5 * (m.v[k] + m.v[k + 1]), ds[k],
                               train.eta_traction, train.eta_regeneration)
        expr = sum(share(m, k, line(k)) for k in m.I) / energy_ref
    elif objective == "time":
        expr = m.T / time_ref + TIME_REGULARISATION * (energy + braking)
    elif objective == "mixed":
        top = max(weights)  # only their ratio matters: the larger scaled up to 1, so the objective stays O(1)
        wt, we = (w / top for w in weights) if top < 1.0 else weights  # (1e-12, 1e-12) stopped far off
        expr = (wt * m.T + we * m.traction_work / train.static_mass) / time_ref
    else:
        raise ValueError(f"unknown objective {objective!r}")
    m.objective = pyo.Objective(expr=expr, sense=pyo.minimize)


def gc_paused(build: Callable[P, R]) -> Callable[P, R]:
    """``build`` with Python's cyclic garbage collector paused: each collection walks every Pyomo
    object made so far (70 % of a space build; a DAS phases build 0.39-1.01 -> 0.13-0.21 s, a
    network leg 0.20 -> 0.045 s). Nothing a build makes is garbage until the model is dropped."""
    @functools.wraps(build)
    def paused(*args: P.args, **kwargs: P.kwargs) -> R:
        with PauseGC():
            return build(*args, **kwargs)
    return paused


@gc_paused
def build_model(segment: Segment, train: Train, nodes: FloatArray, limits: FloatArray, guess: Guess,
                objective: str = "energy", running_time: float | None = None, window: tuple[float, float] | None = None,
                weights: tuple[float, float] = (1.0, 1.0), time_ref: float = 100.0, windows: Sequence[Window] = (),
                movable: bool = False, cuts: Sequence[str] = CUTS) -> Model:
    """Assemble the NLP in named steps; ``guess`` = (v, dt, F_T [N], F_B [N]) on the grid.

    A ``movable`` model can be re-solved from any state and towards any terminal speed and
    arrival window by changing bounds only (:mod:`ecostudy.ocp.restart`); it makes only :data:`MOVABLE_CUTS`.
    ``cuts``: which of :data:`CUTS` to make (all by default)."""
    with_regeneration = objective == "net_energy" and train.regeneration is not None
    lean = tuple(c for c in cuts if not movable or c in MOVABLE_CUTS)
    m = pyo.ConcreteModel(name="ecostudy")
    define_variables(m, nodes, limits, train, guess, with_regeneration, movable, lean)
    define_dynamics(m, nodes, segment, train)
    define_envelopes(m, train, with_regeneration, np.linspace(0.0, float(np.max(limits)), 101), lean)
    define_acceleration_bounds(m, nodes, train)
    define_timing(m, time_ref, running_time, window)
    define_windows(m, nodes, windows, time_ref)
    m.energy_ref = energy_reference(train, segment)  # [J], objective scale
    define_objective(m, nodes, train, objective, weights, time_ref, m.energy_ref)
    m.dual = pyo.Suffix(direction=pyo.Suffix.IMPORT)
    if movable:  # the bounds a re-solve restores (restart.set_start): limits, windows, envelopes
        m.base_bounds = {name: [getattr(m, name)[k].bounds for k in getattr(m, name)]
                         for name in ("v", "ft", "fb", "fr") if hasattr(m, name)}
        m.base_bounds["v"][0] = (0.0, float(limits[0]))
        m.base_bounds["v"][-1] = (0.0, float(limits[-1]))
    return m


def marginal_energy(m: Model) -> float | None:
    """dE/dT [J/s] of a solved fixed-time model: the arrival constraint's multiplier, unscaled.

    Ipopt's y of (sum dt - T) / t_ref = 0 with T fixed gives d(objective)/dT = -y / t_ref; the
    objective is energy / E_ref. Negative: one more second saves energy. None if T is not fixed.
    """
    lo, hi = m.T.bounds
    if lo is None or hi is None or hi - lo > 1e-9 * max(abs(hi), 1.0) or m.arrival not in m.dual:
        return None
    return marginal_energy_of(m.dual[m.arrival], m)


def marginal_energy_of(multiplier: float, m: Model) -> float:
    """dE/dT [J/s] from a multiplier of ``m``'s arrival row, Ipopt's (:func:`marginal_energy`) or
    one fitted at a saved profile (``analysis.pontryagin.estimated_psi``)."""
    return -float(multiplier) * float(m.energy_ref) / float(m.time_ref)


def solution_arrays(m: Model) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray | None]:
    """(v, dt, F_T [N], F_B [N], F_regen [N] or None) from a solved model."""
    v = np.array([pyo.value(m.v[k]) for k in m.K])
    dt = np.array([pyo.value(m.dt[k]) for k in m.I])
    ft = np.array([pyo.value(m.ft[k]) for k in m.I]) * FORCE_SCALE
    fb = np.array([pyo.value(m.fb[k]) for k in m.I]) * FORCE_SCALE
    fr = np.array([pyo.value(m.fr[k]) for k in m.I]) * FORCE_SCALE if hasattr(m, "fr") else None
    return v, dt, ft, fb, fr
