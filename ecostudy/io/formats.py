"""Imports of formats researchers already use, recognised by content, mapped onto ecostudy's schemas.

- TTOBench (Kouzoupis, Pendharkar, Corman; BSD-2) tracks: ``stops``, ``speed limits``
  [position m, km/h], ``gradients`` [position m, per mille], ``curvatures`` [position, radius at
  start, radius at end; sign = direction, "infinity" = straight]; either bare lists or
  ``{"units": ..., "values": [...]}``.
- TTOBench trains: ``mass`` kg, ``rho`` %, ``max traction force``/``max reg braking force``/
  ``max pn braking force`` kN, ``max traction power``/``max reg braking power`` kW,
  ``max deceleration`` m/s^2, ``rolling resistance r0`` kN, ``r1`` kN/(km/h), ``r2`` kN/(km/h)^2,
  ``efficiency traction``/``efficiency reg brake`` %.
- TTOBench journeys (``nuorail/ttobench`` journeys/README.md): ``timing points`` ``values`` =
  [position, lower time, upper time, lower speed, upper speed] with ``units`` (position m or km,
  times s, speeds km/h or m/s), null = no constraint, times since the journey's start. Points
  with both speed bounds 0 are stops (the first is the departure, the last the arrival); the
  others are passing points. TTOBench has no dwell times: ecostudy's ``--dwell`` supplies them.
- OSRD rolling stock: ``effort_curves`` (default mode's ``speeds`` [m/s], ``max_efforts`` [N]),
  ``mass`` kg, ``length`` m, ``inertia_coefficient``, ``rolling_resistance`` A/B/C [N, N/(m/s),
  N/(m/s)^2], ``gamma``/``const_gamma`` [m/s^2].

The result is a dict in the YAML schema, validated afterwards like any YAML file.
"""
import math

import numpy as np

from ecostudy.core import units
from ecostudy.core.errors import InputError, problem


def _values(doc, key, path):
    """A TTOBench field as a list: bare list, {"values": [...]}, or {"value": x}."""
    item = doc[key]
    if isinstance(item, dict):
        if "values" in item:
            return item["values"]
        if "value" in item:
            return item["value"]
        raise InputError(problem(path, key, "expected 'values' or 'value'"))
    return item


def _scalar(doc, key, path, default=None):
    if key not in doc:
        if default is None:
            raise InputError(problem(path, key, "missing field"))
        return default
    value = _values(doc, key, path)
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(problem(path, key, f"expected a number, got {value!r}"))


def _speed_kmh(doc, key, path, default):
    """A TTOBench speed in km/h, converted from its ``unit`` (km/h or m/s; another unit is refused)."""
    value = _scalar(doc, key, path, default)
    unit = doc[key].get("unit", "km/h") if isinstance(doc.get(key), dict) else "km/h"
    if unit not in _SPEED_KMH:
        raise InputError(problem(path, f"{key}.unit", f"unknown speed unit {unit!r} (km/h or m/s)"))
    return value * _SPEED_KMH[unit]


def _radius(r):
    if isinstance(r, str):
        if r.strip().lower() in ("infinity", "inf"):
            return math.inf
        r = float(r)
    return abs(float(r)) if r else math.inf


def ttobench_track(doc, path):
    meta = doc.get("metadata", {})
    name = meta.get("id") or doc.get("id") or str(path)
    stops = _values(doc, "stops", path) if "stops" in doc else _values(doc, "timing points", path)
    length = float(stops[-1])
    curves = []
    for pos, r0, r1 in _values(doc, "curvatures", path) if "curvatures" in doc else []:
        k = 0.5 * (1 / _radius(r0) + 1 / _radius(r1))  # transition: mean curvature of the section
        curves.append({"position_m": float(pos), "radius_m": None if k == 0 else 1 / k})
    grads = _values(doc, "gradients", path) if "gradients" in doc else [[0.0, 0.0]]
    return {
        "name": name,
        "source": f"TTOBench track {name} ({meta.get('library version', 'version not stated')}, "
                  f"{meta.get('license', 'BSD-2-Clause')})",
        "length_m": length,
        "stops": [{"name": f"S{i}", "position_m": float(p)} for i, p in enumerate(stops)],
        "gradients": [{"position_m": float(p), "gradient_permille": float(g)} for p, g in grads],
        "curves": curves,
        "speed_limits": [{"position_m": float(p), "speed_kmh": float(v)}
                         for p, v in _values(doc, "speed limits", path)],
    }


def ttobench_train(doc, path):
    meta = doc.get("metadata", {})
    name = meta.get("id") or str(path)
    mass = _scalar(doc, "mass", path)
    f_t = _scalar(doc, "max traction force", path)
    p_t = _scalar(doc, "max traction power", path)
    f_reg = _scalar(doc, "max reg braking force", path, 0.0)
    p_reg = _scalar(doc, "max reg braking power", path, math.inf)
    f_pn = _scalar(doc, "max pn braking force", path, 0.0)
    top = _speed_kmh(doc, "max speed", path, 200.0)
    bounds = {}  # net acceleration bounds on top of the forces (ms-eetc's semantics of both fields)
    if "max acceleration" in doc:
        bounds["max_acceleration_mps2"] = _scalar(doc, "max acceleration", path)
    if "max deceleration" in doc:
        bounds["max_deceleration_mps2"] = _scalar(doc, "max deceleration", path)
    if f_reg <= 0 and f_pn <= 0 and "max deceleration" in doc:  # no brake forces given: the deceleration is the brake
        braking = {"max_deceleration_mps2": bounds["max_deceleration_mps2"]}
    else:  # electric brake (force and power limited) plus pneumatic brake, tabulated
        speeds = np.linspace(0.0, top, 41)
        force = np.minimum(f_reg, p_reg / np.maximum(speeds * units.KMH, 1e-9)) + f_pn
        if force.max() <= 0:
            raise InputError(problem(path, "max reg braking force", "no braking force at all"))
        braking = {"table": {"speed_kmh": speeds.round(3).tolist(), "force_kN": force.round(4).tolist()}}
    regen = None
    if f_reg > 0:
        regen = {"max_force_kN": f_reg, "efficiency": _scalar(doc, "efficiency reg brake", path, 100.0) * units.PERCENT}
        if math.isfinite(p_reg):
            regen["max_power_kW"] = p_reg
    return {
        "name": name,
        "source": f"TTOBench train {name} ({meta.get('library version', 'version not stated')}); "
                  "point mass (TTOBench gives no length)",
        "mass_t": mass / units.TONNE,
        "rotating_mass_factor": _scalar(doc, "rho", path, 0.0) * units.PERCENT,
        "length_m": 0.0,
        "davis": {"a_kN": _scalar(doc, "rolling resistance r0", path),
                  "b_kN_per_kmh": _scalar(doc, "rolling resistance r1", path, 0.0),
                  "c_kN_per_kmh2": _scalar(doc, "rolling resistance r2", path, 0.0)},
        "traction": {"max_force_kN": f_t, "max_power_kW": p_t},
        "braking": braking,
        "traction_efficiency": _scalar(doc, "efficiency traction", path, 100.0) * units.PERCENT,
        "regenerative_braking": regen,
        **({"max_speed_kmh": top} if "max speed" in doc else {}),
        **bounds,
    }, {"davis.a_kN": "rolling resistance r0", "davis.b_kN_per_kmh": "rolling resistance r1",
        "davis.c_kN_per_kmh2": "rolling resistance r2"}


def osrd_train(doc, path):
    curves = doc["effort_curves"]
    try:
        mode = curves["modes"][curves["default_mode"]]
        curve = mode.get("default_curve") or mode["curves"][0]["curve"]
        speeds, efforts = curve["speeds"], curve["max_efforts"]
    except (KeyError, IndexError, TypeError):
        raise InputError(problem(path, "effort_curves", "expected modes[default_mode].default_curve "
                                 "with 'speeds' and 'max_efforts'"))
    speeds, efforts = np.asarray(speeds, float), np.asarray(efforts, float)
    keep = np.concatenate([[True], np.diff(speeds) > 0])  # OSRD curves may repeat a speed
    rr = doc.get("rolling_resistance", {})
    gamma = doc.get("const_gamma")
    if gamma is None and isinstance(doc.get("gamma"), dict):
        gamma = doc["gamma"].get("value")
    if gamma is None:
        raise InputError(problem(path, "const_gamma", "missing braking deceleration (const_gamma or gamma.value)"))
    return {
        "name": doc.get("name", str(path)),
        "source": f"OSRD rolling stock {doc.get('name', path)} (railjson {doc.get('railjson_version', '?')})",
        "mass_t": float(doc["mass"]) / units.TONNE,
        "rotating_mass_factor": float(doc.get("inertia_coefficient", 1.0)) - 1.0,
        "length_m": float(doc.get("length", 0.0)),
        "davis": {"a_N": rr.get("A"), "b_N_per_mps": rr.get("B"), "c_N_per_mps2": rr.get("C")},
        "traction": {"table": {"speed_kmh": (speeds[keep] / units.KMH).tolist(),
                               "force_kN": (efforts[keep] / units.KN).tolist()}},
        "braking": {"max_deceleration_mps2": float(gamma)},
        **({"max_speed_kmh": float(doc["max_speed"]) / units.KMH} if doc.get("max_speed") else {}),  # OSRD: m/s
    }, {"davis.a_N": "rolling_resistance.A", "davis.b_N_per_mps": "rolling_resistance.B",
        "davis.c_N_per_mps2": "rolling_resistance.C"}


def track_document_to_schema(doc, path):
    if "speed limits" in doc:
        return ttobench_track(doc, path)
    raise InputError(problem(path, "", "not a TTOBench track (no 'speed limits' field)"))


_POSITION = {"m": 1.0, "km": 1000.0}          # [m] per unit
_SPEED_KMH = {"km/h": 1.0, "m/s": 1.0 / units.KMH}  # [km/h] per unit


def ttobench_journey(doc, path):
    """A TTOBench journey as a timetable dict (stops by position, arrival windows, windows)."""
    points = doc.get("timing points")
    if not isinstance(points, dict) or "values" not in points:
        raise InputError(problem(path, "timing points", "expected {'units': ..., 'values': [...]}"))
    given = points.get("units", {})
    pos_unit, speed_unit = given.get("position", "m"), given.get("lower speed constraint", "km/h")
    if pos_unit not in _POSITION:
        raise InputError(problem(path, "timing points.units.position", f"expected m or km, got {pos_unit!r}"))
    if speed_unit not in _SPEED_KMH or given.get("upper speed constraint", speed_unit) != speed_unit:
        raise InputError(problem(path, "timing points.units", "speed constraints need one unit, km/h or m/s"))
    rows = points["values"]
    if not isinstance(rows, list) or len(rows) < 2:
        raise InputError(problem(path, "timing points.values", "need at least two timing points"))
    stops, windows, lines = [], [], []

    def scaled(x, factor):
        return None if x is None else float(x) * factor

    for i, row in enumerate(rows):
        where = f"timing points.values[{i}]"
        if not isinstance(row, list) or len(row) != 5:
            lines.append(problem(path, where, "expected [position, lower time, upper time, lower speed, upper speed]"))
            continue
        if any(x is not None and not isinstance(x, (int, float)) for x in row) or row[0] is None:
            lines.append(problem(path, where, f"expected numbers or null, got {row!r}"))
            continue
        pos = float(row[0]) * _POSITION[pos_unit]
        lo, hi = scaled(row[1], 1.0), scaled(row[2], 1.0)
        vlo, vhi = scaled(row[3], _SPEED_KMH[speed_unit]), scaled(row[4], _SPEED_KMH[speed_unit])
        if i == 0 or i == len(rows) - 1 or (vlo == 0 and vhi == 0):
            if vlo != 0 or vhi != 0:
                lines.append(problem(path, where, "the departure and the arrival need both speed bounds 0"))
            if i == 0:
                stops.append({"position_m": pos, "departure_s": lo or 0.0})
            else:
                stops.append({"position_m": pos, "earliest_s": lo, "latest_s": hi})
        else:
            windows.append({"position_m": pos, "earliest_s": lo, "latest_s": hi,
                            "min_speed_kmh": vlo or None, "max_speed_kmh": vhi})
    if lines:
        raise InputError(lines)
    meta = doc.get("metadata", {})
    return {"name": meta.get("id", str(path)),
            "source": f"TTOBench journey {meta.get('id', path)} on track {meta.get('associated track', '?')} "
                      f"({meta.get('library version', 'version not stated')})",
            "stops": stops, "windows": windows}


def timetable_document_to_schema(doc, path):
    if "timing points" in doc:
        return ttobench_journey(doc, path)
    raise InputError(problem(path, "", "not a TTOBench journey (no 'timing points' field)"))


def train_document_to_schema(doc, path):
    """(schema dict, field-name aliases for messages) from a TTOBench or OSRD train document."""
    try:
        if "effort_curves" in doc:
            return osrd_train(doc, path)
        if "max traction force" in doc or "rolling resistance r0" in doc:
            return ttobench_train(doc, path)
    except KeyError as exc:
        raise InputError(problem(path, str(exc.args[0]), "missing field"))
    raise InputError(problem(path, "", "not a TTOBench or OSRD train (no 'max traction force' or 'effort_curves')"))
