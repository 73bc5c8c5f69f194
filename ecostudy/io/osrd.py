"""OSRD rolling stock (railjson, OpenRailAssociation/osrd; the realistic files of its
``tests/data/rolling_stocks/realistic/``) read with OSRD's meaning of each field.

- ``railjson_version`` is the format's version, 'MAJOR.MINOR' (``version`` is the stored object's
  edit count, descriptive), read as OSRD's core reads it (``RJSRollingStockParser.parse``): a major
  version other than :data:`MAJOR` is refused (OSRD refuses a major version mismatch); a minor one
  this reader was not written against (:data:`MINORS`) is read, with a warning naming it (OSRD logs
  a version mismatch and reads it).
- Every field OSRD's parser requires (core ``RJSRollingStockParser.parse``: :data:`REQUIRED`, and a
  braking deceleration, ``gamma`` of railjson 3.2 or ``const_gamma`` of 3.3) is refused when it is
  missing or null, naming it: none is filled in. Both braking fields at once are refused.
- ``effort_curves.modes[mode]``: the default mode, or the one chosen by ``file.json#MODE`` (and
  ``#MODE/COMFORT``, default comfort STANDARD); OSRD's choice (core ``RollingStock.
  findTractiveEffortCurve``, ``EffortCurveConditions.match``): the first curve whose condition has no
  electrical profile level and no power restriction (ecostudy models neither) and whose comfort is
  that comfort or null (any comfort), else the mode's ``default_curve``. Speeds m/s, efforts N. The
  train never runs faster than its table's last speed (``max_speed`` is lowered to it, with a
  warning when the table stops short of ``max_speed``). Every curve of every mode is checked as OSRD
  checks it (equal lengths, 2 points or more, nothing negative), used or not; a mode or a condition
  with a key OSRD does not know is refused, as editoast refuses it (``deny_unknown_fields``).
- Every problem names the field as the file does (``effort_curves.modes.M.default_curve.speeds[2]``,
  ``rolling_resistance.A``); the second return value of :func:`osrd_train` maps the train schema's
  field paths to these names for the schema's own messages.
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
from ecostudy.io.trainschema import MAX_ROTATING_SHARE, mass_out_of_range

Where: TypeAlias = str | PathLike[str]

MODELLED = {"effort_curves", "max_speed", "comfort_acceleration", "mass", "inertia_coefficient", "length",
            "rolling_resistance", "const_gamma", "gamma"}
DESCRIPTIVE = {"name", "railjson_version", "metadata", "version", "locked", "supported_signaling_systems",
               "primary_category", "other_categories", "liveries", "id"}
# what OSRD's parser refuses a file without (core RJSRollingStockParser.parse, in its order; OSRD 66c30bb)
REQUIRED = ("railjson_version", "effort_curves", "name", "length", "max_speed", "startup_time", "startup_acceleration",
            "comfort_acceleration", "inertia_coefficient", "loading_gauge", "mass", "rolling_resistance")
MAJOR, MINORS = "3", ("3.2", "3.3")  # railjson_version: the major read, the versions this reader follows
BRAKING = ("gamma", "const_gamma")  # railjson 3.2's {type, value}, 3.3's number: one of them
MODE_FIELDS = ("curves", "default_curve", "is_electric")  # editoast ModeEffortCurves (deny_unknown_fields)
COND_FIELDS = ("comfort", "electrical_profile_level", "power_restriction_code")  # editoast EffortCurveConditions


def _number(doc: Mapping[str, Any], key: str, path: Where, positive: bool = True, at: str = "") -> float:
    """``doc[key]`` as a number (above 0 when ``positive``); ``at`` is the field path down to ``doc``."""
    if key not in doc:
        raise InputError(problem(path, f"{at}{key}", "missing field"))
    value = doc[key]
    if not finite_number(value) or (positive and value <= 0):
        raise InputError(problem(path, f"{at}{key}", f"expected a {'positive ' if positive else ''}number, "
                                 f"got {value!r}"))
    return float(value)


def _values(curve: Mapping[str, Any], key: str, path: Where, where: str) -> FloatArray:
    """``curve[key]``: a list of finite numbers (a string, a bool or a null refused, naming its index)."""
    if key not in curve:
        raise InputError(problem(path, f"{where}.{key}", "missing field"))
    values = curve[key]
    if not isinstance(values, list):
        raise InputError(problem(path, f"{where}.{key}", f"expected a list of numbers, got {values!r:.40}"))
    try:  # the fast test, then the one that names the first entry that fails it
        array = np.asarray(values, np.float64) if set(map(type, values)) <= {int, float} else None
    except OverflowError:  # an integer too large for a float
        array = None
    if array is None or not np.all(np.isfinite(array)):
        i = next(i for i, x in enumerate(values) if not finite_number(x))
        raise InputError(problem(path, f"{where}.{key}[{i}]", f"expected a number, got {values[i]!r:.40}"))
    return array


def _points(curve: Any, path: Where, where: str) -> tuple[FloatArray, FloatArray]:
    """(speeds [m/s], efforts [N]) of one effort curve at ``where``, with OSRD's checks and its words
    (editoast ``EffortCurve``'s deserialisation, core ``RJSRollingStockParser.parseEffortCurve``): equal
    lengths, two points or more, no negative effort or speed, speeds that never fall. OSRD checks
    every curve of every mode, so a file with one bad curve is refused, used or not."""
    if not isinstance(curve, dict):
        raise InputError(problem(path, where, "expected {'speeds': [...], 'max_efforts': [...]}"))
    speeds, efforts = _values(curve, "speeds", path, where), _values(curve, "max_efforts", path, where)
    if speeds.size != efforts.size:
        raise InputError(problem(path, where, "effort curve invalid, max_efforts and speeds arrays should have the "
                                 f"same length ({speeds.size} speeds, {efforts.size} max_efforts)"))
    if speeds.size < 2:
        raise InputError(problem(path, where, "effort curve should have at least 2 points."))
    for key, values in (("max_efforts", efforts), ("speeds", speeds)):
        if np.any(values < 0):
            i = int(np.argmax(values < 0))
            raise InputError(problem(path, f"{where}.{key}[{i}]", f"{key} values must be equal or greater than 0., "
                                     f"got {values[i]:g}"))
    gaps = np.diff(speeds)
    if np.any(gaps < 0):
        n = int(np.argmax(gaps < 0)) + 1
        raise InputError(problem(path, f"{where}.speeds[{n}]", f"{speeds[n]:g} m/s after {speeds[n - 1]:g}: the "
                                 "speeds must increase"))
    return speeds, efforts


def _curves(modes: Mapping[str, Any], path: Where) -> dict[str, FloatArray | tuple[FloatArray, FloatArray]]:
    """Every curve of every mode by its field path, checked (:func:`_points`) as OSRD checks them."""
    out: dict[str, Any] = {}
    for mode, entry in modes.items():
        at = f"effort_curves.modes.{mode}"
        if not isinstance(entry, dict):
            raise InputError(problem(path, at, "expected a mode with 'curves' and 'default_curve'"))
        _known(entry, MODE_FIELDS, path, at)
        if entry.get("curves") is None:
            raise InputError(problem(path, f"{at}.curves", "missing field"))
        listed = entry["curves"]
        if not isinstance(listed, list):
            raise InputError(problem(path, f"{at}.curves", "expected a list of {'cond', 'curve'}"))
        for i, item in enumerate(listed):
            if not isinstance(item, dict):
                raise InputError(problem(path, f"{at}.curves[{i}]", "expected {'cond': {...}, 'curve': {...}}"))
            if item.get("cond") is None:  # OSRD's parser: parseEffortCurveConditions
                raise InputError(problem(path, f"{at}.curves[{i}].cond", "missing field"))
            if not isinstance(item["cond"], dict):
                raise InputError(problem(path, f"{at}.curves[{i}].cond", f"expected {{{', '.join(COND_FIELDS)}}}"))
            _known(item["cond"], COND_FIELDS, path, f"{at}.curves[{i}].cond")
            out[f"{at}.curves[{i}].curve"] = _points(item.get("curve"), path, f"{at}.curves[{i}].curve")
        if "default_curve" not in entry:
            raise InputError(problem(path, f"{at}.default_curve", "missing field"))
        out[f"{at}.default_curve"] = _points(entry["default_curve"], path, f"{at}.default_curve")
    return out


def _known(doc: Mapping[str, Any], known: tuple[str, ...], path: Where, at: str) -> None:
    """Refuse a key of ``doc`` (at field path ``at``) that is not ``known``, in editoast's words (its
    schemas there are ``deny_unknown_fields``: OSRD refuses the file)."""
    unknown = [key for key in doc if key not in known]
    if unknown:
        raise InputError(problem(path, f"{at}.{unknown[0]}", f"unknown field `{unknown[0]}`, expected one of "
                                 + ", ".join(f"`{k}`" for k in known)))


def _curve(doc: Mapping[str, Any], path: Where, selector: str | None) -> tuple[str, str, str, FloatArray, FloatArray]:
    """(mode, comfort, the curve's field path, speeds [m/s], efforts [N]) of the chosen mode and comfort."""
    curves = doc.get("effort_curves")
    if not isinstance(curves, dict) or not isinstance(curves.get("modes"), dict) or not curves["modes"]:
        raise InputError(problem(path, "effort_curves", "expected {'modes': {...}, 'default_mode': ...}"))
    default = curves.get("default_mode")
    if default is None:
        raise InputError(problem(path, "effort_curves.default_mode", "missing field"))
    if not isinstance(default, str) or default not in curves["modes"]:
        raise InputError(problem(path, "effort_curves.default_mode", f"no mode {default!r} (modes: "
                                 f"{', '.join(curves['modes'])})"))
    asked, _, comfort = (selector or "").partition("/")
    mode, comfort = asked or default, comfort or "STANDARD"
    if mode not in curves["modes"]:
        raise InputError(problem(path, "effort_curves.modes", f"no mode {mode!r} (modes: {', '.join(curves['modes'])})"))
    checked = _curves(curves["modes"], path)
    entry = curves["modes"][mode]
    listed = entry["curves"]
    conds = [item["cond"] for item in listed]
    plain = [i for i, cond in enumerate(conds)
             if cond.get("electrical_profile_level") is None and cond.get("power_restriction_code") is None]
    # OSRD: the first condition that matches; a null comfort matches every comfort
    picked = next(((listed[i]["curve"], f"effort_curves.modes.{mode}.curves[{i}].curve") for i in plain
                   if conds[i].get("comfort") in (None, comfort)), None)
    if picked is None and selector and "/" in selector:
        raise InputError(problem(path, f"effort_curves.modes.{mode}", f"no curve for comfort {comfort!r}"))
    chosen, where = picked or (entry["default_curve"], f"effort_curves.modes.{mode}.default_curve")
    others = len(listed) - len(plain)
    if others:
        warnings.warn(problem(path, f"effort_curves.modes.{mode}", f"{others} curve(s) for electrical profile "
                              "levels or power restrictions not modelled: the plain curve is used everywhere"),
                      EcostudyWarning, stacklevel=3)
    extra = sorted(set(chosen) - {"speeds", "max_efforts"})
    if extra:
        warnings.warn(problem(path, where, f"curve fields ecostudy does not model: {', '.join(extra)} (ignored)"),
                      EcostudyWarning, stacklevel=3)
    speeds, efforts = checked[where]
    return mode, comfort, where, *_steps(speeds, efforts, path, where)


STEP = 0.01  # [m/s]: a repeated speed (a step of the effort) is read as a change over this much speed


def _steps(speeds: FloatArray, efforts: FloatArray, path: Where, where: str) -> tuple[FloatArray, FloatArray]:
    """The curve (speeds that never fall, :func:`_points`) with a point given twice once, and each
    repeated speed with two efforts, a step, read as OSRD's interpolation reads it (the first point's
    effort up to the speed, the last point's from it on): the first point moved :data:`STEP` lower,
    said, naming the second point by its index in the file."""
    same = np.concatenate([[False], (np.diff(speeds) == 0) & (np.diff(efforts) == 0)])  # a point given twice: once
    index = np.flatnonzero(~same)  # each kept point's index in the file
    speeds, efforts = speeds[~same].copy(), efforts[~same]
    flat = np.diff(speeds) == 0
    if np.any(flat[1:] & flat[:-1]):  # three efforts at one speed: no reading gives the middle one a place
        k = int(np.argmax(flat[1:] & flat[:-1])) + 2
        raise InputError(problem(path, f"{where}.speeds[{index[k]}]", f"{speeds[k]:g} m/s given a third time with "
                                 "another effort: one step per speed"))
    if len(speeds) > 2 and speeds[0] == speeds[1]:  # a step at the first speed: its first effort holds at that
        warnings.warn(problem(path, f"{where}.speeds[{index[1]}]", f"a step of the effort at {speeds[1]:g} m/s "
                              f"({efforts[0] / units.KN:g} -> {efforts[1] / units.KN:g} kN) at the curve's first "
                              "speed: the second effort is read from that speed on"), EcostudyWarning, stacklevel=4)
        speeds, efforts, index = speeds[1:], efforts[1:], index[1:]
    for k in np.flatnonzero(np.diff(speeds) == 0).tolist():
        low = speeds[k - 1] if k > 0 else -np.inf
        speeds[k] = max(speeds[k + 1] - STEP, 0.5 * (low + speeds[k + 1]))
        warnings.warn(problem(path, f"{where}.speeds[{index[k + 1]}]", f"a step of the effort at {speeds[k + 1]:g} m/s "
                              f"({efforts[k] / units.KN:g} -> {efforts[k + 1] / units.KN:g} kN), read as a change "
                              f"over the {speeds[k + 1] - speeds[k]:g} m/s below it"), EcostudyWarning, stacklevel=4)
    return speeds, efforts


def _braking(doc: Mapping[str, Any], path: Where, mass: float) -> tuple[dict[str, float], float | None, str]:
    """(braking schema, net-deceleration bound or None, the field giving it) from ``gamma`` {type,
    value} (railjson 3.2) or ``const_gamma`` (3.3): exactly one of them."""
    given = [key for key in BRAKING if doc.get(key) is not None]
    if len(given) != 1:
        raise InputError(problem(path, ", ".join(given) or "gamma", ("both given" if given else "missing field")
                                 + ": one braking deceleration, gamma {type, value} (railjson 3.2) or const_gamma (3.3)"))
    if given == ["const_gamma"]:
        kind, value, field = "CONST", _number(doc, "const_gamma", path), "const_gamma"
    else:
        gamma = doc["gamma"]
        if not isinstance(gamma, dict):
            raise InputError(problem(path, "gamma", f"expected {{type, value}}, got {gamma!r:.40}"))
        _known(gamma, ("type", "value"), path, "gamma")
        if gamma.get("type") is None:
            raise InputError(problem(path, "gamma.type", "missing field (CONST or MAX)"))
        kind, value, field = str(gamma["type"]).upper(), _number(gamma, "value", path, at="gamma."), "gamma.value"
        if kind not in ("CONST", "MAX"):
            raise InputError(problem(path, "gamma.type", f"expected CONST or MAX, got {gamma['type']!r}"))
    return {"max_force_kN": mass * value / units.KN}, (value if kind == "CONST" else None), field


def _version(version: Any, path: Where) -> None:
    """Refuse a ``railjson_version`` that is not a string or whose major version (before the first
    '.', as OSRD splits it) is not :data:`MAJOR`; warn of a version of that major not in :data:`MINORS`."""
    if not isinstance(version, str):
        raise InputError(problem(path, "railjson_version", f"expected a string 'MAJOR.MINOR' such as '3.3', got "
                                 f"{version!r:.40}"))
    major = version.split(".")[0]
    if major != MAJOR:
        raise InputError(problem(path, "railjson_version", f"'{version}': major version {major or '(none)'}, but this "
                                 f"reader reads OSRD rolling stock of major version {MAJOR} ({', '.join(MINORS)}); OSRD "
                                 "refuses a major version mismatch too"))
    if version not in MINORS:
        warnings.warn(problem(path, "railjson_version", f"'{version}' is not a version this reader follows "
                              f"({', '.join(MINORS)}): read as railjson {MAJOR}.x (OSRD reads a minor version "
                              "mismatch with a warning)"), EcostudyWarning, stacklevel=4)


def osrd_train(doc: Mapping[str, Any], path: Where,
               selector: str | None = None) -> tuple[dict[str, Any], dict[str, str]]:
    """An OSRD rolling stock as a train-schema dict, and the field names for messages (the schema's
    field paths as the OSRD file names them)."""
    missing = [key for key in REQUIRED if doc.get(key) is None]  # none is filled in: OSRD refuses the file
    if missing:
        raise InputError(problem(path, missing[0], "missing field (OSRD's rolling-stock parser requires "
                                 + ", ".join(f"'{m}'" for m in missing) + ")"))
    _version(doc["railjson_version"], path)
    ignored = [k for k in doc if k not in MODELLED | DESCRIPTIVE and doc[k] not in (None, {}, [], "")]
    if ignored:
        warnings.warn(problem(path, ", ".join(ignored), "OSRD fields ecostudy does not model: ignored"),
                      EcostudyWarning, stacklevel=3)
    mode, comfort, where, speeds, efforts = _curve(doc, path, selector)
    mass = _number(doc, "mass", path)
    wrong = mass_out_of_range(mass)
    if wrong:
        raise InputError(problem(path, "mass", wrong))
    inertia = _number(doc, "inertia_coefficient", path)
    if not 1 <= inertia <= 1 + MAX_ROTATING_SHARE:
        raise InputError(problem(path, "inertia_coefficient", f"expected 1 to {1 + MAX_ROTATING_SHARE:g} (M = mass x "
                                 f"coefficient: the rotating masses add a share of the mass), got {inertia:g}"))
    top = min(_number(doc, "max_speed", path), float(speeds[-1]))
    if speeds[-1] < doc["max_speed"] - 1e-6:
        warnings.warn(problem(path, where, f"the curve ends at {speeds[-1] / units.KMH:.0f} km/h, below max_speed "
                              f"{doc['max_speed'] / units.KMH:.0f} km/h: the train runs at most "
                              f"{speeds[-1] / units.KMH:.0f} km/h in this mode"), EcostudyWarning, stacklevel=3)
    rr = doc.get("rolling_resistance")
    if not isinstance(rr, dict) or rr.get("type", "davis") != "davis":
        raise InputError(problem(path, "rolling_resistance", "expected {'type': 'davis', 'A', 'B', 'C'}"))
    extra = sorted(set(rr) - {"type", "A", "B", "C"})
    if extra:
        warnings.warn(problem(path, "rolling_resistance", f"fields ecostudy does not model: {', '.join(extra)} "
                              "(ignored)"), EcostudyWarning, stacklevel=3)
    braking, deceleration, gamma = _braking(doc, path, mass * inertia)
    bounds: dict[str, float] = {"max_deceleration_mps2": deceleration} if deceleration else {}
    bounds["max_acceleration_mps2"] = _number(doc, "comfort_acceleration", path)
    return {
        "name": str(doc["name"]),
        "source": f"OSRD rolling stock {doc['name']} (railjson {doc['railjson_version']}), mode {mode}, comfort {comfort}",
        "mass_t": mass / units.TONNE,
        "rotating_mass_factor": inertia - 1.0,
        "length_m": _number(doc, "length", path, positive=False),
        "davis": {key: _number(rr, name, path, False, at="rolling_resistance.") for key, name in DAVIS.items()},
        "traction": {"table": {"speed_kmh": (speeds / units.KMH).tolist(), "force_kN": (efforts / units.KN).tolist()}},
        "braking": braking,
        "max_speed_kmh": top / units.KMH,
        **bounds,
    }, {**{f"davis.{key}": f"rolling_resistance.{name}" for key, name in DAVIS.items()},
        "traction.table.speed_kmh": f"{where}.speeds", "traction.table.force_kN": f"{where}.max_efforts",
        "mass_t": "mass", "length_m": "length", "name": "name", "rotating_mass_factor": "inertia_coefficient",
        "max_speed_kmh": "max_speed", "max_acceleration_mps2": "comfort_acceleration",
        "max_deceleration_mps2": gamma, "braking.max_force_kN": gamma}


DAVIS = {"a_N": "A", "b_N_per_mps": "B", "c_N_per_mps2": "C"}  # the schema's Davis fields: OSRD's names
