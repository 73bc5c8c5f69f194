"""A driving mode as a driver reads it, from a handle level or a cruise target speed: the one
place that names them (the DAS advice writes them, a saved advice table is checked against them)."""
import math
import re

from ecostudy.core.units import KMH, to_kmh

NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


def mode_name(level: float, target: float | None = None) -> str:
    """Driver-readable mode of a handle level (or of a cruise target speed [m/s])."""
    if target is not None and math.isfinite(target):
        return f"cruise at {to_kmh(target):.1f} km/h"
    if level >= 1 - 1e-9:
        return "full traction"
    if level > 1e-9:
        return f"traction {100 * level:.0f} %"
    if level <= -1 + 1e-9:
        return "full service braking"
    if level < -1e-9:
        return f"braking {-100 * level:.0f} %"
    return "coast"


def names_mode(text: str, level: float, target_kmh: float | None = None) -> bool:
    """Whether ``text`` is the mode of ``level`` (or of the cruise target ``target_kmh`` [km/h]) as a
    table written to six digits gives them back: the same words, the percentage within 1 and the
    speed within 0.1 km/h (a level or speed on a rounding edge reads either way)."""
    target = target_kmh * KMH if target_kmh is not None and math.isfinite(target_kmh) else None
    want = mode_name(level, target)
    if NUMBER.sub("#", str(text).strip()) != NUMBER.sub("#", want):
        return False
    given, wanted = NUMBER.findall(str(text)), NUMBER.findall(want)
    within = 0.1 if "km/h" in want else 1.0
    return all(abs(float(g) - float(w)) <= within + 1e-9 for g, w in zip(given, wanted))
