"""Point-mass train physics as pure functions (Farooqi 2018 §2.1, Yazhemsky 2017 Ch.3).

Every function is written with ``+ - * / **`` only, so it accepts floats, numpy arrays and Pyomo
expressions alike: the optimisation model and the verifying simulator share one formula.
All quantities are SI.

Nomenclature
------------
v      speed [m/s]
M      effective (inertial) mass, static mass plus rotating-mass allowance [kg]
Ms     static mass, the mass gravity acts on [kg]
A,B,C  Davis coefficients [N], [N s/m], [N s^2/m^2]
"""
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence, TypeAlias

import numpy as np

from ecostudy.core.units import FloatArray, Numeric

GRAVITY = 9.80665  # [m/s^2]

# (c0, c1, [(a_j, v_j)]) of a smoothed table (:func:`table_coefficients`)
Coefficients: TypeAlias = tuple[float, float, list[tuple[float, float]]]
Samples: TypeAlias = Sequence[float] | FloatArray  # a table's column, as a list or an array


def davis_resistance(speed: Numeric, a: Numeric, b: Numeric, c: Numeric) -> Numeric:
    """Running resistance R_v = A + B v + C v^2 [N] (Farooqi 2018 eq. 2.2, Yazhemsky 2017 eq. 3.2).

    Parameters
    ----------
    speed : numeric  Train speed [m/s].
    a, b, c : float  Davis coefficients [N], [N s/m], [N s^2/m^2].
    """
    return a + b * speed + c * speed**2


def gradient_force(static_mass: Numeric, gradient: Numeric) -> Numeric:
    """Gravity component along the track, Ms g tan(alpha) [N] (Farooqi 2018 eq. 2.2).

    Parameters
    ----------
    static_mass : float  Ms [kg]; the rotating-mass allowance does not weigh anything.
    gradient : numeric  tan(alpha) [-], positive uphill (10 per mille -> 0.010).
    """
    return static_mass * GRAVITY * gradient


def curve_force(static_mass: Numeric, coefficient: Numeric, curvature: Numeric) -> Numeric:
    """Curve resistance Ms lambda_t / r_c [N] (Farooqi 2018 eq. 2.2).

    Parameters
    ----------
    static_mass : float  Ms [kg].
    coefficient : float  lambda_t, train-dependent curve coefficient [m^2/s^2].
    curvature : numeric  1 / radius [1/m], signed by direction; 0 on straight track.
    """
    return static_mass * coefficient * abs(curvature)


ROECKL_MIN_RADIUS = 150.0  # [m] the smallest radius Roeckl's formula is used for: ms-eetc's (track.py CURVATURE_THRESHOLD)


def roeckl_force(static_mass: Numeric, curvature: Numeric) -> Numeric:
    """Curve resistance by Roeckl's formula, as ms-eetc uses it (``mseetc/train.py``) [N]:
    Ms g 0.5 / (r - 30) for radii r >= 300 m, Ms g 0.65 / (r - 55) below, in curvature k = 1 / r (numpy
    only). ms-eetc pairs the fits with radii the other way round from Roeckl's formula as usually
    published (650 / (r - 55) N/kN from 300 m, 500 / (r - 30) below): kept, so that a TTOBench case
    costs what its reference computes. Below :data:`ROECKL_MIN_RADIUS` ms-eetc refuses the track
    and ecostudy too (:func:`ecostudy.core.grid.roeckl_out_of_range`); here it is a ValueError.
    """
    k = np.abs(np.asarray(curvature, float))
    if np.any(k * ROECKL_MIN_RADIUS > 1 + 1e-9):
        raise ValueError(f"Roeckl's formula at a radius of {1 / float(np.max(k)):g} m, below {ROECKL_MIN_RADIUS:g} m")
    share = np.where(k <= 1 / 300, 0.5 * k / (1 - 30 * k), 0.65 * k / (1 - 55 * k))
    return static_mass * GRAVITY * share


def hinge(x: Numeric, width: float) -> Numeric:
    """Smooth max(x, 0): (x + sqrt(x^2 + w^2)) / 2. Error at the kink w/2, C-infinity."""
    return 0.5 * (x + (x * x + width * width) ** 0.5)


def smooth_max(a: Numeric, b: Numeric, width: float) -> Numeric:
    """max(a, b) rounded over ``width``: (a + b + sqrt((a - b)^2 + w^2)) / 2 (at most w/2 too high)."""
    return 0.5 * (a + b + ((a - b) ** 2 + width * width) ** 0.5)


def smooth_min(a: Numeric, b: Numeric, width: float) -> Numeric:
    """min(a, b) rounded over ``width`` (at most w/2 too low)."""
    return 0.5 * (a + b - ((a - b) ** 2 + width * width) ** 0.5)


def table_coefficients(speeds: Samples, forces: Samples, width: float) -> Coefficients:
    """(c0, c1, [(a_j, v_j)]) with table_force = c0 + c1 v + sum a_j sqrt((v - v_j)^2 + w^2).

    The linear interpolant of the table is f0 + sum_j (s_j - s_j-1) max(v - v_j, 0) with zero
    slope outside the table; each max is replaced by the hinge (x + sqrt(x^2 + w^2)) / 2 and the
    linear halves of all hinges are gathered into c0 + c1 v, so an expression has one sqrt per kink.
    """
    speeds, forces = [float(x) for x in speeds], [float(x) for x in forces]
    slopes = [(f1 - f0) / (v1 - v0) for v0, v1, f0, f1 in zip(speeds, speeds[1:], forces, forces[1:])]
    jumps = [b - a for a, b in zip([0.0] + slopes, slopes + [0.0])]  # slope change at each table speed
    terms = [(0.5 * d, v) for d, v in zip(jumps, speeds) if d != 0.0]
    c1 = sum(a for a, _ in terms)
    c0 = -sum(a * v for a, v in terms)
    # shift so that the smooth curve passes through the first table point
    c0 += forces[0] - (c0 + c1 * speeds[0] + sum(a * ((speeds[0] - v) ** 2 + width**2) ** 0.5 for a, v in terms))
    return c0, c1, terms


def smooth_table(speed: Numeric, coefficients: Coefficients, width: float) -> Numeric:
    """Evaluate c0 + c1 v + sum a_j sqrt((v - v_j)^2 + w^2) (see :func:`table_coefficients`)."""
    c0, c1, terms = coefficients
    value = c0 + c1 * speed
    for a, v in terms:
        value = value + a * ((speed - v) ** 2 + width * width) ** 0.5
    return value


def step_integral(cuts: Samples, values: Samples, width: float) -> Coefficients:
    """Coefficients (for :func:`smooth_table`) of Phi(x), the integral from ``cuts[0]`` of the step
    function f(x) = values[k] on cuts[k] <= x < cuts[k+1], each kink of Phi (a step of f) rounded over
    ``width``:

        Phi(x) = c0 + c1 x + sum_k a_k sqrt((x - x_k)^2 + w^2),   a_k = (f_k - f_k-1) / 2 at each step x_k,

    the closed form of max(x - x_k, 0) = (x - x_k + |x - x_k|) / 2 with |u| rounded to sqrt(u^2 + w^2);
    c1 = f_0 + sum a_k (slope f_0 before the first step, f_last after the last: no kink at either end),
    c0 puts Phi(cuts[0]) at 0. Its derivative (:func:`smooth_table_slope`) is f with each step smoothed,
    f_k-1 + (f_k - f_k-1) (1 + u / sqrt(u^2 + w^2)) / 2, u = x - x_k (10 % to 90 % of the step over
    +-2.06 w); Phi(b) - Phi(a) is that smoothed f's exact integral over [a, b], within |f_k - f_k-1| w / 2
    of the unsmoothed one per step.

    Parameters
    ----------
    cuts : sequence  Increasing positions, one more than ``values``.
    values : sequence  The function's value on each piece.
    width : float  Rounding width of each step [unit of ``cuts``].
    """
    x, f = [float(c) for c in cuts], [float(y) for y in values]
    terms = [(0.5 * (f1 - f0), c) for c, f0, f1 in zip(x[1:-1], f[:-1], f[1:]) if f1 != f0]
    c1 = f[0] + sum(a for a, _ in terms)
    c0 = -(c1 * x[0] + sum(a * ((x[0] - c) ** 2 + width * width) ** 0.5 for a, c in terms))
    return c0, c1, terms


def smooth_table_slope(x: Numeric, coefficients: Coefficients, width: float) -> Numeric:
    """The derivative of :func:`smooth_table`: c1 + sum a_j (x - x_j) / sqrt((x - x_j)^2 + w^2)."""
    _, c1, terms = coefficients
    value: Numeric = c1
    for a, c in terms:
        value = value + a * (x - c) / ((x - c) ** 2 + width * width) ** 0.5
    return value


MEAN_EPS2 = 1e-6  # [m^2] below about this squared length an interval's mean is its middle's value


def interval_mean(phi_a: Numeric, phi_b: Numeric, length: Numeric, middle: Numeric, eps2: float = MEAN_EPS2) -> Numeric:
    """Mean of a function over an interval from its integral Phi at both ends [Phi(b) - Phi(a)] / (b - a),
    written (dPhi L + eps2 f_mid) / (L^2 + eps2) with L = b - a and ``middle`` = f at the middle: defined
    and smooth at L = 0 (an interval stood on is worth its point's value), within eps2 / L^2 of the mean
    beyond (1e-6 at L = 1 m under the default)."""
    return ((phi_b - phi_a) * length + eps2 * middle) / (length * length + eps2)


def table_force(speed: Numeric, speeds: Samples, forces: Samples, width: float) -> Numeric:
    """Speed-force table as a smooth piecewise-linear interpolant [N].

    Linear between table points, constant below the first and beyond the last; each kink is
    rounded over ``width`` (see :func:`table_coefficients`).

    Parameters
    ----------
    speed : numeric  [m/s].
    speeds, forces : sequences  Table, speeds strictly increasing [m/s], forces [N].
    width : float  Rounding width of each kink [m/s].
    """
    return smooth_table(speed, table_coefficients(speeds, forces, width), width)


@dataclass(frozen=True)
class Envelope:
    """Maximum force as a function of speed: a table, or a force limit plus a power limit.

    ``kind`` is ``"table"`` (``speeds``, ``forces``, ``width``) or ``"force_power"``
    (``max_force`` [N] and ``max_power`` [W], ``inf`` for none).
    """

    kind: str
    max_force: float = float("inf")
    max_power: float = float("inf")
    speeds: tuple[float, ...] = ()
    forces: tuple[float, ...] = ()
    width: float = 0.0
    coefficients: Coefficients | tuple[()] = field(default=(), compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.kind == "table" and not self.coefficients:
            object.__setattr__(self, "coefficients", table_coefficients(self.speeds, self.forces, self.width))

    def force(self, speed: Numeric) -> Numeric:
        """Maximum force at ``speed`` [N] for floats and numpy arrays (tables: Pyomo too)."""
        if self.kind == "table":
            return smooth_table(speed, self.smooth_coefficients, self.width)
        if isinstance(speed, float):  # the simulator's hot path
            return min(self.max_force, self.max_power / max(speed, 1e-9))
        speed = np.maximum(speed, 1e-9)
        return np.minimum(self.max_force, self.max_power / speed)

    def smooth_force(self, speed: Numeric, corner_share: float = 0.0005) -> Numeric:
        """Maximum force as one smooth expression [N], usable in equality constraints.

        Tables are smooth already. min(F_max, P_max / v) = P_max / max(v, v_c) with the corner
        speed v_c = P_max / F_max; the max is rounded over ``corner_share`` * v_c, so the force is
        at most 0.03 % low right at the corner and exact away from it.
        """
        return self.smooth_function(corner_share)(speed)

    def smooth_function(self, corner_share: float = 0.0005) -> Callable[[Numeric], Numeric]:
        """:meth:`smooth_force` as a function of the speed alone (a scalar loop calls it cheaply)."""
        if self.kind == "table":
            coefficients, width = self.smooth_coefficients, self.width
            return lambda speed: smooth_table(speed, coefficients, width)
        force, power = self.max_force, self.max_power
        if not np.isfinite(power):
            return lambda speed: force + 0.0 * speed
        corner = power / force
        return lambda speed: power / smooth_max(speed, corner, corner_share * corner)

    def scaled(self, share: float) -> "Envelope":
        """This envelope with every force (and the power) times ``share``."""
        if self.kind == "table":
            return Envelope("table", speeds=self.speeds, forces=tuple(f * share for f in self.forces), width=self.width)
        return Envelope("force_power", max_force=self.max_force * share, max_power=self.max_power * share)

    @property
    def peak(self) -> float:
        """Largest force the envelope ever allows [N]."""
        return max(self.forces) if self.kind == "table" else self.max_force

    def idle_power(self, speeds: Numeric) -> bool:
        """True when this envelope has a power limit that never binds at ``speeds`` [m/s]
        (:func:`power_never_binds` on its force limit)."""
        return (self.kind == "force_power" and bool(np.isfinite(self.max_power))
                and power_never_binds(self.max_force, self.max_power, speeds))

    @property
    def smooth_coefficients(self) -> Coefficients:
        """The coefficients of a table envelope (set by ``__post_init__``)."""
        if not self.coefficients:
            raise ValueError(f"a {self.kind} envelope has no table")
        return self.coefficients

    def without_power(self) -> "Envelope":
        """This envelope without its power limit."""
        return replace(self, max_power=float("inf"))


def power_never_binds(force: Numeric, power: float, speeds: Numeric) -> bool:
    """True when a power limit can never be the binding one: P >= F_max(v) v at every speed.

    Checked pointwise on the envelope, so a table or a speed-dependent force limit is judged where
    it is, not by its peak. A limit that never binds only adds rows (and, in the convex program,
    a badly scaled tangent) to a formulation, so the formulations drop it.

    Parameters
    ----------
    force : numeric  F_max(v), the force limit without the power limit, at ``speeds`` [N].
    power : float  P, the power limit [W].
    speeds : numeric  Every admissible speed, e.g. 0 up to the highest limit of the segment [m/s].
    """
    return bool(np.all(power >= np.asarray(force, float) * np.maximum(np.asarray(speeds, float), 0.0)))


CHORD_TOLERANCE = 0.05  # [-] a force-and-power fit may lie this far below a table's chords (a hyperbola sampled every 20 km/h)


def force_power_fit(speeds: Samples, forces: Samples,
                    tolerance: float = 0.005) -> tuple[float, float] | None:
    """(F_max, P_max) if every table point lies on min(F_max, P_max / v) within ``tolerance`` and,
    between the points, the curve is never above the table's linear interpolation by more than
    ``tolerance`` nor below it by more than :data:`CHORD_TOLERANCE` (a power hyperbola sampled at
    its corner and beyond lies a little below its chords; a corner between two points would put it
    above them: a train stronger than its table).

    Such a table is then modelled exactly by F <= F_max and F v <= P_max: cheaper than the
    smoothed interpolant. Beyond the table's last speed the fit goes on along the power limit, where a
    table is held constant. Returns None for any other shape.
    """
    v, f = np.asarray(speeds, float), np.asarray(forces, float)
    f_max = float(f[0])
    if f_max <= 0 or np.any(f > f_max * (1 + tolerance)):
        return None
    weak = (v > 0) & (f < f_max * (1 - tolerance))
    power = float(np.median(f[weak] * v[weak])) if np.any(weak) else float("inf")
    model = np.minimum(f_max, power / np.maximum(v, 1e-9))
    if not np.all(np.abs(model - f) <= tolerance * f):
        return None
    fine = np.linspace(v[0], v[-1], 2000)
    chords, curve = np.interp(fine, v, f), np.minimum(f_max, power / np.maximum(fine, 1e-9))
    inside = np.all(curve <= chords * (1 + tolerance)) and np.all(curve >= chords * (1 - CHORD_TOLERANCE))
    return (f_max, power) if inside else None


def table_width(speeds: Samples, forces: Samples, tolerance: float = 0.002) -> float:
    """Largest kink rounding [m/s] keeping the smooth table within ``tolerance`` of the linear one."""
    speeds, forces = np.asarray(speeds, float), np.asarray(forces, float)
    fine = np.linspace(speeds[0], speeds[-1], 4000)
    exact = np.interp(fine, speeds, forces)
    scale = np.maximum(np.abs(exact), 1e-3 * np.max(np.abs(forces)))
    width = 0.25 * float(np.min(np.diff(speeds)))
    for _ in range(40):
        err = np.max(np.abs(table_force(fine, speeds, forces, width) - exact) / scale)
        if err <= tolerance:
            return width
        width *= 0.5
    return width


def running_resistance(speed: Numeric, davis: Sequence[float], static_mass: float, gradient: Numeric,
                       curve_coefficient: float, curvature: Numeric, roeckl: bool = False) -> Numeric:
    """Total resistance F_R = R_v(v) + R_g(s) [N] (Farooqi 2018 eq. 2.2); the curve term by
    Roeckl's formula instead of lambda_t / r when ``roeckl``."""
    a, b, c = davis
    curve = roeckl_force(static_mass, curvature) if roeckl else curve_force(static_mass, curve_coefficient, curvature)
    return davis_resistance(speed, a, b, c) + gradient_force(static_mass, gradient) + curve


def interval_resistance(v0: Numeric, v1: Numeric, davis: Sequence[Numeric], fixed: Numeric) -> Numeric:
    """Mean resistance over an interval between speeds v0 and v1 [N]: the trapezoidal mean of the
    Davis resistance at both ends plus the speed-independent gradient and curve force ``fixed``
    of the interval (Farooqi 2018 eq. 2.2). The one formula of the NLP, the phases NLP, the
    time-domain legs and the kinematic profiles; per unit mass when ``davis`` and ``fixed`` are.
    """
    a, b, c = davis
    return a + 0.5 * b * (v0 + v1) + 0.5 * c * (v0 * v0 + v1 * v1) + fixed


def moving_share(speed_sum: Numeric, width: float = 0.01) -> Numeric:
    """Share of the braking, resisting and grade forces that act over a time step whose end speeds
    add up to ``speed_sum`` [m/s]: s^2 / (s^2 + width^2), 0 for a step that starts and ends at a
    stand, above 0.99 once the ends add up to 0.1 m/s. A smooth standstill for time-domain NLPs: a
    stopped train stays stopped (the brakes hold it on any grade) until traction moves it, where
    without it a braking or resisting force at v = 0 would drive the speed below zero."""
    return speed_sum * speed_sum / (speed_sum * speed_sum + width * width)


def acceleration(traction: Numeric, braking: Numeric, resistance: Numeric, mass: Numeric) -> Numeric:
    """dv/dt = (F_T - F_B - F_R) / M [m/s^2] (Farooqi 2018 eq. 2.1)."""
    return (traction - braking - resistance) / mass


@dataclass(frozen=True)
class EfficiencyMap:
    """Efficiency [-] as a function of speed and force (ms-eetc's load-dependent efficiency as a
    table): ``values[i][j]`` at ``speeds[i]`` [m/s] and ``forces[j]`` [N], bilinear between the
    table points and constant beyond them, every kink rounded (:func:`table_force`), so it
    evaluates floats, numpy arrays and Pyomo expressions alike.

    eta(v, F) = sum_j hat_j(F) row_j(v), hat_j the interpolant of the j-th unit vector over the
    forces and row_j the interpolant of column j over the speeds.
    """

    speeds: tuple[float, ...]
    forces: tuple[float, ...]
    values: tuple[tuple[float, ...], ...]
    hats: tuple[tuple[Coefficients, float], ...] = field(default=(), compare=False, repr=False)
    rows: tuple[tuple[Coefficients, float], ...] = field(default=(), compare=False, repr=False)

    def __post_init__(self) -> None:
        values = np.asarray(self.values, float)
        wf = 0.002 * float(np.min(np.diff(self.forces)))  # rounding of the hats: 0.1 % at a table point
        wv = min(table_width(self.speeds, values[:, j], 0.0005) for j in range(len(self.forces)))
        unit = np.eye(len(self.forces))
        object.__setattr__(self, "hats", tuple((table_coefficients(self.forces, unit[j], wf), wf)
                                               for j in range(len(self.forces))))
        object.__setattr__(self, "rows", tuple((table_coefficients(self.speeds, values[:, j], wv), wv)
                                               for j in range(len(self.forces))))

    def __call__(self, speed: Numeric, force: Numeric) -> Numeric:
        total: Numeric = 0.0
        for (hat, wf), (row, wv) in zip(self.hats, self.rows):
            total = total + smooth_table(force, hat, wf) * smooth_table(speed, row, wv)
        return total


def efficiency(eta: "EfficiencyMap | float", speed: Numeric, force: Numeric) -> Numeric:
    """A constant efficiency, or an :class:`EfficiencyMap` at (speed, force)."""
    return eta(speed, force) if isinstance(eta, EfficiencyMap) else eta


def line_energy(ft: Numeric, fr: Numeric, speed: Numeric, ds: Numeric, eta_t: "EfficiencyMap | float",
                eta_r: "EfficiencyMap | float") -> Numeric:
    """Energy drawn from the line minus energy fed back [J] per interval: F_T ds / eta_T(v, F_T)
    - eta_R(v, F_R) F_R ds (Farooqi 2018 eq. 7.3 with efficiencies that may depend on speed and
    force). ``speed`` is the interval's mean speed; floats, arrays or Pyomo expressions."""
    return ft * ds / efficiency(eta_t, speed, ft) - efficiency(eta_r, speed, fr) * fr * ds
