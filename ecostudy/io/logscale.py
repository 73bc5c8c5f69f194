"""A logged run's speeds against its positions: the travel each measures while the train runs.

A speed sensor off in scale (a worn wheel's diameter) or positions off in scale make the speeds'
distance another share of the positions' travel than 1. The calibration replays the kinetic energy
from the logged speed, which goes as v^2: a scale s biases the fitted mass by about -2 (s - 1)
(:data:`SCALE_MASS_BIAS`), and its interval does not widen with it. :func:`scale_problem` judges
the mismatch against the fitted mass's interval (:mod:`ecostudy.calibration.estimate`).
"""
import numpy as np

from ecostudy.core import units
from ecostudy.io.logfile import LoggedRun, travel_steps

SCALE_SPEED, SCALE_TRAVEL = 2.0, 1000.0  # the scale: while the train runs above this [m/s], over at least this [m]
# the fitted mass is biased by about -SCALE_MASS_BIAS times (scale - 1): the kinetic energy goes as v^2
# (measured on the worked example's logs with speeds 0.998, 1.001, 1.002, 1.005 times the truth: 1.91 to 2.00)
SCALE_MASS_BIAS = 2.0
SCALE_ERRORS = 2.0  # the mismatch judged is the measured one less this many of its standard errors (the speeds' noise)
SCALE_TOLERANCE = 0.003  # without a fitted mass to judge against: speeds and positions more apart than this share


def measured_scale(log: LoggedRun) -> tuple[float, float] | None:
    """(the speeds' distance over the positions' travel while the train runs, at least :data:`SCALE_SPEED`,
    its standard error) where a log gives both over at least :data:`SCALE_TRAVEL` m; else None. The
    error from the spread of the 10 s steps about the ratio (:func:`~ecostudy.io.logfile.travel_steps`):
    the speeds' noise integrated over each step, the positions' own at its ends."""
    if log.v is None or "position" not in log.columns[0]:
        return None
    travel, driven = travel_steps(log, SCALE_SPEED)
    total = float(np.sum(travel))
    if total < SCALE_TRAVEL:
        return None
    ratio = float(np.sum(driven)) / total
    spread = float(np.std(driven - ratio * travel, ddof=1)) if travel.size > 1 else 0.0
    return ratio, spread * float(np.sqrt(travel.size)) / total


def speed_scale(log: LoggedRun) -> float | None:
    """The ratio of :func:`measured_scale` (1 when speeds and positions agree), or None."""
    measured = measured_scale(log)
    return None if measured is None else measured[0]


def scale_problem(log: LoggedRun, mass: tuple[float, float] | None = None) -> str:
    """Why a log's speeds and positions do not measure the same travel closely enough, "" where they
    do or cannot be compared (:func:`measured_scale`). With ``mass`` (the fitted static mass and its
    95 % half-width [kg]): where the mass bias the mismatch implies, :data:`SCALE_MASS_BIAS` times it,
    exceeds that half-width (the interval then misses the logged train's mass), the mismatch taken
    :data:`SCALE_ERRORS` standard errors of its measurement nearer 1 (the speeds' noise alone does
    not bias the mass); without (the mass not fitted), where they are more than :data:`SCALE_TOLERANCE`
    apart."""
    measured = measured_scale(log)
    if measured is None:
        return ""
    ratio, error = measured
    cause = "a speed sensor off in scale (a worn wheel's diameter) or positions off in scale"
    if mass is None:
        if abs(ratio - 1.0) <= SCALE_TOLERANCE:
            return ""
        return (f"its speeds give {ratio:.6g} times the travel of its positions while it runs (more than "
                f"{100 * SCALE_TOLERANCE:g} % apart): {cause} bias the fitted resistance and, fitted, the mass by "
                f"about {SCALE_MASS_BIAS:g} times that")
    estimate, half = mass
    bias = -SCALE_MASS_BIAS * (ratio - 1.0)
    if SCALE_MASS_BIAS * max(abs(ratio - 1.0) - SCALE_ERRORS * error, 0.0) * estimate <= half:
        return ""
    return (f"its speeds give {ratio:.6g} times the travel of its positions while it runs (standard error "
            f"{error:.1g}): {cause} bias the fitted mass by about {units.signed(100 * bias, 3)} % "
            f"({units.signed(bias * estimate, 0)} kg, {SCALE_MASS_BIAS:g} times the mismatch), more than its 95 % "
            f"interval's half-width of {half:.0f} kg ({100 * half / estimate:.2g} %): the interval would miss the "
            "logged train's mass")
