"""Point-mass train physics as pure functions (thesis 000 §2.1, thesis 001 Ch.3).

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
from dataclasses import dataclass

import numpy as np

GRAVITY = 9.80665  # [m/s^2]


def davis_resistance(speed, a, b, c):
    """Running resistance R_v = A + B v + C v^2 [N] (thesis 000 eq. 2.2, thesis 001 eq. 3.2).

    Parameters
    ----------
    speed : numeric  Train speed [m/s].
    a, b, c : float  Davis coefficients [N], [N s/m], [N s^2/m^2].
    """
    return a + b * speed + c * speed**2


def gradient_force(static_mass, gradient):
    """Gravity component along the track, Ms g tan(alpha) [N] (thesis 000 eq. 2.2).

    Parameters
    ----------
    static_mass : float  Ms [kg]; the rotating-mass allowance does not weigh anything.
    gradient : numeric  tan(alpha) [-], positive uphill (10 per mille -> 0.010).
    """
    return static_mass * GRAVITY * gradient


def curve_force(static_mass, coefficient, curvature):
    """Curve resistance Ms lambda_t / r_c [N] (thesis 000 eq. 2.2).

    Parameters
    ----------
    static_mass : float  Ms [kg].
    coefficient : float  lambda_t, train-dependent curve coefficient [m^2/s^2].
    curvature : numeric  1 / radius [1/m]; 0 on straight track.
    """
    return static_mass * coefficient * curvature


def hinge(x, width):
    """Smooth max(x, 0): (x + sqrt(x^2 + w^2)) / 2. Error at the kink w/2, C-infinity."""
    return 0.5 * (x + (x * x + width * width) ** 0.5)


def table_force(speed, speeds, forces, width):
    """Speed-force table as a smooth piecewise-linear interpolant [N].

    The linear interpolant is written as a sum of hinges, each kink rounded over ``width``;
    constant below the first and beyond the last table speed.

    Parameters
    ----------
    speed : numeric  [m/s].
    speeds, forces : sequences  Table, speeds strictly increasing [m/s], forces [N].
    width : float  Rounding width of each kink [m/s].
    """
    slopes = np.diff(forces) / np.diff(speeds)
    value = forces[0] + 0.0 * speed
    prev = 0.0
    for vj, sj in zip(speeds[:-1], slopes):
        value = value + (sj - prev) * (hinge(speed - vj, width) - hinge(speeds[0] - vj, width))
        prev = sj
    return value + (0.0 - prev) * (hinge(speed - speeds[-1], width) - hinge(speeds[0] - speeds[-1], width))


@dataclass(frozen=True)
class Envelope:
    """Maximum force as a function of speed: a table, or a force limit plus a power limit.

    ``kind`` is ``"table"`` (``speeds``, ``forces``, ``width``) or ``"force_power"``
    (``max_force`` [N] and ``max_power`` [W], ``inf`` for none).
    """

    kind: str
    max_force: float = float("inf")
    max_power: float = float("inf")
    speeds: tuple = ()
    forces: tuple = ()
    width: float = 0.0

    def force(self, speed):
        """Maximum force at ``speed`` [N] for floats and numpy arrays (tables: Pyomo too)."""
        if self.kind == "table":
            return table_force(speed, np.asarray(self.speeds), np.asarray(self.forces), self.width)
        speed = np.maximum(speed, 1e-9)
        return np.minimum(self.max_force, self.max_power / speed)

    @property
    def peak(self):
        """Largest force the envelope ever allows [N]."""
        return max(self.forces) if self.kind == "table" else self.max_force


def table_width(speeds, forces, tolerance=0.002):
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


def running_resistance(speed, davis, static_mass, gradient, curve_coefficient, curvature):
    """Total resistance F_R = R_v(v) + R_g(s) [N] (thesis 000 eq. 2.2)."""
    a, b, c = davis
    return (davis_resistance(speed, a, b, c) + gradient_force(static_mass, gradient)
            + curve_force(static_mass, curve_coefficient, curvature))


def acceleration(traction, braking, resistance, mass):
    """dv/dt = (F_T - F_B - F_R) / M [m/s^2] (thesis 000 eq. 2.1)."""
    return (traction - braking - resistance) / mass
