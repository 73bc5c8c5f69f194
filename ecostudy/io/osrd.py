"""OSRD rolling stock (railjson, OpenRailAssociation/osrd; the realistic files of its
``tests/data/rolling_stocks/realistic/``) read with OSRD's meaning of each field.

- ``effort_curves.modes[mode]``: the default mode, or the one chosen by ``file.json#MODE`` (and
  ``#MODE/COMFORT``, default comfort STANDARD); the curve whose condition is that comfort with no
  electrical profile level and no power restriction, else the mode's ``default_curve``. Speeds
  m/s, efforts N. The train never runs faster than its table's last speed (``max_speed`` is lowered
  to it, with a warning when the table stops short of ``max_speed``).
- ``max_speed`` m/s caps every limit; ``comfort_acceleration`` m/s^2 bounds the net acceleration.
- ``mass`` kg, ``inertia_coefficient`` (M = mass x coefficient), ``length`` m.
- ``rolling_resistance`` of type ``davis``: A N, B N/(m/s), C N/(m/s)^2.
- braking: ``const_gamma`` or ``gamma`` {type, value} m/s^2: a brake force of M gamma; type CONST
  (and const_gamma) also bounds the net deceleration to gamma, as OSRD decelerates at exactly gamma.
- Not modelled, named in one warning when they carry a value: startup_time,
  startup_acceleration, loading_gauge, etcs_brake_params, power_restrictions, energy_sources,
  electrical_power_startup_time, raise_pantograph_time, base_power_class. Descriptive fields
  (name, metadata, categories, signalling systems, liveries, version, locked) are read silently.
"""
import math
import warnings
from os import PathLike
from typing import Any, Mapping, TypeAlias

import numpy as np

from ecostudy.core import units
from ecostudy.core.errors import EcostudyWarning, InputError, finite_number, problem
from ecostudy.core.units import FloatArray

Where: TypeAlias = str | PathLike[str]

MODELLED = {"effort_curves", "max_speed", "comfort_acceleration", "mass", "inertia_coefficient", "length",
            "rolling_resistance", "const_gamma", "gamma"}
DESCRIPTIVE = {"name", "railjson_version", "metadata", "version", "locked", "supported_signaling_systems",
               "primary_category", "other_categories", "liveries", "id"}


def _number(doc: Mapping[str, Any], key: str, path: Where, positive: bool = True) -> float:
    value = doc.get(key)
    if not finite_number(value) or (
            positive and value <= 0):
        raise InputError(problem(path, key, f"expected a {'positive ' if positive else ''}number, got {value!r}"))
    return float(value)


def _curve(doc: Mapping[str, Any], path: Where, selector: str | None) -> tuple[str, str, FloatArray, FloatArray]:
    """(mode, comfort, speeds [m/s], efforts [N]) of the chosen mode and comfort."""
    curves = doc.get("effort_curves")
    if not isinstance(curves, dict) or not isinstance(curves.get("modes"), dict) or not curves["modes"]:
        raise InputError(problem(path, "effort_curves", "expected {'modes': {...}, 'default_mode': ...}"))
    asked, _, comfort = (selector or "").partition("/")
    mode, comfort = asked or curves.get("default_mode"), comfort or "STANDARD"
    if not isinstance(mode, str) or mode not in curves["modes"]:
        raise InputError(problem(path, "effort_curves.modes", f"no mode {mode!r} (modes: {', '.join(curves['modes'])})"))
    entry = curves["modes"][mode]
    if not isinstance(entry, dict):
        raise InputError(problem(path, f"effort_curves.modes.{mode}", "expected a mode with 'curves' and 'default_curve'"))
    chosen: Any = None
    others = 0
    listed = entry.get("curves") or []
    if not isinstance(listed, list) or not all(isinstance(x, dict) and isinstance(x.get("cond") or {}, dict)
                                               for x in listed):
        raise InputError(problem(path, f"effort_curves.modes.{mode}.curves", "expected a list of {'cond', 'curve'}"))
    for item in listed:
        cond = item.get("cond") or {}
        plain = cond.get("electrical_profile_level") is None and cond.get("power_restriction_code") is None
        if plain and cond.get("comfort") == comfort and chosen is None:
            chosen = item.get("curve")
        others += not plain
    if chosen is None:
        if selector and "/" in selector:
            raise InputError(problem(path, f"effort_curves.modes.{mode}", f"no curve for comfort {comfort!r}"))
        chosen = entry.get("default_curve")
    try:
        speeds = np.asarray(chosen["speeds"], dtype=np.float64)
        efforts = np.asarray(chosen["max_efforts"], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise InputError(problem(path, f"effort_curves.modes.{mode}", "expected a curve with 'speeds' and 'max_efforts'"))
    if speeds.size < 2 or speeds.size != efforts.size or not np.all(np.isfinite(speeds) & np.isfinite(efforts)):
        raise InputError(problem(path, f"effort_curves.modes.{mode}", "speeds and max_efforts need equal lengths >= 2"))
    if others:
        warnings.warn(problem(path, f"effort_curves.modes.{mode}", f"{others} curve(s) for electrical profile "
                              "levels or power restrictions not modelled: the plain curve is used everywhere"),
                      EcostudyWarning, stacklevel=3)
    extra = sorted(set(chosen) - {"speeds", "max_efforts"}) if isinstance(chosen, dict) else []
    if extra:
        warnings.warn(problem(path, f"effort_curves.modes.{mode}", f"curve fields ecostudy does not model: "
                              f"{', '.join(extra)} (ignored)"), EcostudyWarning, stacklevel=3)
    return mode, comfort, *_steps(speeds, efforts, path, f"effort_curves.modes.{mode}")


STEP = 0.01  # [m/s]: a repeated speed (a step of the effort) is read as a change over this much speed


def _steps(speeds: FloatArray, efforts: FloatArray, path: Where, where: str) -> tuple[FloatArray, FloatArray]:
    """The curve with speeds that never fall (refused: OSRD's parser asserts them increasing), a point
    given twice once, and each repeated speed with two efforts, a step, read as OSRD's interpolation
    reads it (the first point's effort up to the speed, the last point's from it on): the first point
    moved :data:`STEP` lower, said."""
    gaps = np.diff(speeds)
    if np.any(gaps < 0):
        n = int(np.argmax(gaps < 0)) + 1
        raise InputError(problem(path, f"{where}.speeds[{n}]", f"{speeds[n]:g} m/s after {speeds[n - 1]:g}: the "
                                 "speeds must increase"))
    same = np.concatenate([[False], (gaps == 0) & (np.diff(efforts) == 0)])  # a point given twice: once
    speeds, efforts, gaps = speeds[~same], efforts[~same], np.diff(speeds[~same])
    speeds = speeds.copy()
    for k in np.flatnonzero(gaps == 0).tolist():
        low = speeds[k - 1] if k > 0 else -np.inf
        speeds[k] = max(speeds[k + 1] - STEP, 0.5 * (low + speeds[k + 1]))
        warnings.warn(problem(path, f"{where}.speeds[{k + 1}]", f"a step of the effort at {speeds[k + 1]:g} m/s "
                              f"({efforts[k] / units.KN:g} -> {efforts[k + 1] / units.KN:g} kN), read as a change "
                              f"over the {speeds[k + 1] - speeds[k]:g} m/s below it"), EcostudyWarning, stacklevel=4)
    if np.any(np.diff(speeds) <= 0):
        raise InputError(problem(path, f"{where}.speeds", "a speed repeated more than twice: one step per speed"))
    return speeds, efforts


def _braking(doc: Mapping[str, Any], path: Where, mass: float) -> tuple[dict[str, float], float | None]:
    """(braking schema, net-deceleration bound or None) from const_gamma or gamma {type, value}."""
    gamma = doc.get("gamma")
    if isinstance(gamma, dict):
        kind, value = str(gamma.get("type", "CONST")).upper(), _number(gamma, "value", f"{path}: gamma")
        if kind not in ("CONST", "MAX"):
            raise InputError(problem(path, "gamma.type", f"expected CONST or MAX, got {gamma.get('type')!r}"))
    elif "const_gamma" in doc:
        kind, value = "CONST", _number(doc, "const_gamma", path)
    else:
        raise InputError(problem(path, "const_gamma", "missing braking deceleration (const_gamma or gamma)"))
    return {"max_force_kN": mass * value / units.KN}, (value if kind == "CONST" else None)


def osrd_train(doc: Mapping[str, Any], path: Where,
               selector: str | None = None) -> tuple[dict[str, Any], dict[str, str]]:
    """An OSRD rolling stock as a train-schema dict, and the field names for messages."""
    ignored = [k for k in doc if k not in MODELLED | DESCRIPTIVE and doc[k] not in (None, {}, [], "")]
    if ignored:
        warnings.warn(problem(path, ", ".join(ignored), "OSRD fields ecostudy does not model: ignored"),
                      EcostudyWarning, stacklevel=3)
    mode, comfort, speeds, efforts = _curve(doc, path, selector)
    mass = _number(doc, "mass", path)
    inertia = _number(doc, "inertia_coefficient", path) if "inertia_coefficient" in doc else 1.0
    top = min(_number(doc, "max_speed", path), float(speeds[-1])) if "max_speed" in doc else float(speeds[-1])
    if "max_speed" in doc and speeds[-1] < doc["max_speed"] - 1e-6:
        warnings.warn(problem(path, f"effort_curves.modes.{mode}", f"the curve ends at {speeds[-1] / units.KMH:.0f} "
                              f"km/h, below max_speed {doc['max_speed'] / units.KMH:.0f} km/h: the train runs at most "
                              f"{speeds[-1] / units.KMH:.0f} km/h in this mode"), EcostudyWarning, stacklevel=3)
    rr = doc.get("rolling_resistance")
    if not isinstance(rr, dict) or rr.get("type", "davis") != "davis":
        raise InputError(problem(path, "rolling_resistance", "expected {'type': 'davis', 'A', 'B', 'C'}"))
    extra = sorted(set(rr) - {"type", "A", "B", "C"})
    if extra:
        warnings.warn(problem(path, "rolling_resistance", f"fields ecostudy does not model: {', '.join(extra)} "
                              "(ignored)"), EcostudyWarning, stacklevel=3)
    braking, deceleration = _braking(doc, path, mass * inertia)
    bounds: dict[str, float] = {"max_deceleration_mps2": deceleration} if deceleration else {}
    if "comfort_acceleration" in doc:
        bounds["max_acceleration_mps2"] = _number(doc, "comfort_acceleration", path)
    return {
        "name": str(doc.get("name", path)),
        "source": f"OSRD rolling stock {doc.get('name', path)} (railjson {doc.get('railjson_version', '?')}), "
                  f"mode {mode}, comfort {comfort}",
        "mass_t": mass / units.TONNE,
        "rotating_mass_factor": inertia - 1.0,
        "length_m": _number(doc, "length", path, positive=False) if "length" in doc else 0.0,
        "davis": {"a_N": _number(rr, "A", path, False), "b_N_per_mps": _number(rr, "B", path, False),
                  "c_N_per_mps2": _number(rr, "C", path, False)},
        "traction": {"table": {"speed_kmh": (speeds / units.KMH).tolist(), "force_kN": (efforts / units.KN).tolist()}},
        "braking": braking,
        "max_speed_kmh": top / units.KMH,
        **bounds,
    }, {"davis.a_N": "rolling_resistance.A", "davis.b_N_per_mps": "rolling_resistance.B",
        "davis.c_N_per_mps2": "rolling_resistance.C", "traction.table.speed_kmh": f"effort_curves.modes.{mode}",
        "traction.table.force_kN": f"effort_curves.modes.{mode}", "mass_t": "mass", "length_m": "length"}
