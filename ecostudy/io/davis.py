"""A train file's Davis coefficients in SI, and the checks of their size: a warning where a unit
looks mixed up (:func:`check_davis_plausible`), a refusal where a term is past any train's
(:func:`check_davis_bound`)."""
import warnings
from typing import Sequence

import numpy as np

from ecostudy.core import units
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.physics import GRAVITY
from ecostudy.io import schemas
from ecostudy.io.documents import Where, given


def davis_si(d: schemas.Davis, static_mass: float) -> tuple[tuple[float, float, float], tuple[str, str, str]]:
    """Davis triple in N, N s/m, N s^2/m^2 from whichever unit system the file used, and its fields."""
    if d.a_N is not None:
        return (d.a_N, given(d.b_N_per_mps), given(d.c_N_per_mps2)), d.TRIPLES[0]
    if d.a_kN is not None:
        return (d.a_kN * units.KN, given(d.b_kN_per_kmh) * units.KN / units.KMH,
                given(d.c_kN_per_kmh2) * units.KN / units.KMH**2), d.TRIPLES[1]
    return (given(d.a_N_per_kg) * static_mass, given(d.b_N_per_kg_per_mps) * static_mass,
            given(d.c_N_per_kg_per_mps2) * static_mass), d.TRIPLES[2]


# plausible Davis coefficients per unit static mass: A [N/kg], B [N s/(m kg)], C [N s^2/(m^2 kg)]
DAVIS_PER_KG = {"a": (2e-4, 0.15), "b": (0.0, 5e-3), "c": (1e-7, 2e-3)}


def check_davis_plausible(davis: Sequence[float], static_mass: float, fields: Sequence[str], path: Where) -> None:
    """Warn when a Davis coefficient is of an implausible size for the mass (mixed-up units).

    ``fields`` names the file's fields for (A, B, C), so the warning points at what to fix.
    """
    if not any(davis):
        warnings.warn(problem(path, "/".join(fields), "every Davis coefficient is 0: the train rolls without "
                              "resistance"), EcostudyWarning, stacklevel=2)
    for (key, (low, high)), value, name in zip(DAVIS_PER_KG.items(), davis, fields):
        per_kg = value / static_mass
        if per_kg and not low <= per_kg <= high:
            warnings.warn(problem(path, name,
                                  f"Davis {key.upper()} = {per_kg:.3g} per kg is implausible for a "
                                  f"{static_mass / units.TONNE:.0f} t train (expected {low:g} to {high:g} "
                                  "in N, m/s units per kg); check the units"), EcostudyWarning, stacklevel=2)


# each Davis term (A, B v, C v^2) at this speed may not exceed the train's weight: a resistance of 1000
# per mille, as much as a vertical climb; the shipped trains' largest term is 39 per mille
# (yazhemsky2017_commuter's C v^2), their others 1 to 8. More is a wrong unit or an overflow (1e308 kN: inf)
DAVIS_BOUND_SPEED = 100 * units.KMH


def check_davis_bound(d: schemas.Davis, davis: Sequence[float], static_mass: float, fields: Sequence[str],
                      names: Sequence[str], path: Where) -> None:
    """Refuse a Davis coefficient whose term at :data:`DAVIS_BOUND_SPEED` exceeds the train's weight
    (``davis`` in SI from the file's ``fields`` of ``d``, written ``names`` in the file)."""
    weight = static_mass * GRAVITY
    lines = [problem(path, name, f"{getattr(d, field):g} gives a resistance of "
                     + (f"{force / 1e3:.3g} kN" if np.isfinite(force) else "more than any number holds (an overflow)")
                     + f" at 100 km/h, above the train's weight ({weight / 1e3:.0f} kN, a 1000 per mille climb); real trains "
                     "meet 1 to 40 per mille: check the value and its unit")
             for n, (value, field, name) in enumerate(zip(davis, fields, names))
             if not (force := value * DAVIS_BOUND_SPEED ** n) <= weight]
    if lines:
        raise InputError(lines)
