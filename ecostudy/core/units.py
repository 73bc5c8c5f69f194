"""Unit conversions at the file boundary. Everything inside ecostudy is SI (m, s, kg, N, W, J).

Files name their units in field names (``speed_kmh``, ``force_kN``, ``mass_t``); loaders multiply
by the factors below, here and nowhere else.
"""
import math
import re
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

# A float, a numpy array of floats or a Pyomo expression: the physics written with + - * / ** only
# takes any of them, so the simulator and the NLP share one formula (typing cannot say "anything
# with these operators" more narrowly than Any).
Numeric: TypeAlias = Any
FloatArray: TypeAlias = npt.NDArray[np.float64]

KMH = 1.0 / 3.6          # [m/s] per [km/h]
KN = 1000.0              # [N] per [kN]
KW = 1000.0              # [W] per [kW]
TONNE = 1000.0           # [kg] per [t]
PERMILLE = 1e-3          # [-] per [per mille]
KWH = 3.6e6              # [J] per [kWh]
PERCENT = 0.01           # [-] per [%]


def to_kmh(speed: Numeric) -> Numeric:
    """Speed [m/s] -> [km/h]."""
    return speed / KMH


def to_kwh(energy: Numeric) -> Numeric:
    """Energy [J] -> [kWh]."""
    return energy / KWH


def number(value: Any, spec: str = ".3f") -> str:
    """``value`` formatted by ``spec`` as every printed table and report line shows it: a value that
    rounds to zero prints as zero with its digits ('0.000', '+0.00'), never '-0.000' (the files keep
    the full value). ``spec`` '~N': N significant digits in fixed point, never an exponent (255200
    and 265310.4 as '255200' and '265310', 0.851234 as '0.85123'), for a column whose rows differ
    in magnitude."""
    if spec.startswith("~"):  # (not finite or not a number: as it is)
        finite = isinstance(value, (int, float, np.floating)) and math.isfinite(value)
        digits = int(spec[1:]) - 1 - (math.floor(math.log10(abs(value))) if finite and value else 0)
        spec = f".{max(0, digits)}f" if finite else ""
    text = format(value, spec)
    if isinstance(value, (int, float, np.floating)) and math.isfinite(value) and "-" in text \
            and not re.search(r"[1-9]", re.split(r"[eE]", text)[0]):
        return format(0.0, spec)
    return text


def signed(value: Any, places: int = 3) -> str:
    """``value`` with its sign always shown, ``places`` decimals, by :func:`number`: a difference
    or an error ('+0.120', '-1.500'); one that rounds to zero prints as '+0.000', never '-0.000'."""
    return number(value, f"+.{places}f")


def apart(a: float, b: float, places: int = 1) -> tuple[str, str]:
    """``a`` and ``b`` with ``places`` decimals, or as many more (up to 6) as tell them apart: a time
    asked a hair under the least possible reads 50.48 against 50.49 s, not 50.5 against 50.5."""
    while places < 6 and f"{a:.{places}f}" == f"{b:.{places}f}":
        places += 1
    return f"{a:.{places}f}", f"{b:.{places}f}"


# Units as the published formats spell them (TTOBench, OSRD), by dimension: [SI] per [unit].
BY_DIMENSION = {
    "mass": {"kg": 1.0, "t": TONNE},
    "length": {"m": 1.0, "km": 1000.0},
    "time": {"s": 1.0},
    "speed": {"m/s": 1.0, "km/h": KMH},
    "acceleration": {"m/s^2": 1.0},
    "force": {"N": 1.0, "kN": KN},
    "power": {"W": 1.0, "kW": KW, "MW": 1e6},
    "share": {"%": PERCENT, "-": 1.0},
    "slope": {"permil": PERMILLE},
    "area": {"m^2": 1.0},
    "force per speed": {"N/(m/s)": 1.0, "kN/(m/s)": KN, "N/(km/h)": 1.0 / KMH, "kN/(km/h)": KN / KMH},
    "force per speed^2": {"N/(m/s)^2": 1.0, "kN/(m/s)^2": KN, "N/(km/h)^2": 1.0 / KMH**2,
                          "kN/(km/h)^2": KN / KMH**2, "kg/m": 1.0},  # N/(m/s)^2 = kg/m (TTOBench's tunnels)
}


def si_factor(unit: object, dimension: str) -> float | None:
    """[SI] per [unit] for a unit of ``dimension``; None for a unit ecostudy does not know."""
    return BY_DIMENSION[dimension].get(unit) if isinstance(unit, str) else None
