"""TTOBench tracks and trains (Kouzoupis, Pendharkar, Corman; BSD-2; ``nuorail/ttobench`` v1.5),
read with the semantics of the library's reference implementation, ms-eetc (``dkouzoup/ms-eetc``:
``mseetc/train.py``, ``track.py``, ``ocp.py``).

Every field carries its unit (``{"unit", "value"}`` or ``{"units", "values"}``); units are
converted by :mod:`ecostudy.core.units` and an unknown unit is refused by name. What each field
means (docs/formats.md has the table):

- ``max speed`` caps every speed limit; ``max acceleration`` / ``max deceleration`` bound the net
  acceleration on top of the force and power limits (ms-eetc ``ocp.py``: accMin <= a <= accMax);
- braking = regenerative (force and power limited) + pneumatic force; both absent is refused;
- ``rho`` is the rotating-mass allowance (ms-eetc: a value below 1 is a share, 6 % -> 1.06);
- curves cost Roeckl's resistance (ms-eetc ``TrainModel``); a curvature entry whose radii differ
  is a clothoid, curvature linear in distance (ms-eetc ``sampleClothoid``), resolved on the grid;
  a radius below 150 m is refused, as ms-eetc refuses it;
- ``tunnels`` [position, length, cross section] add the train's ``tunnel resistance`` coefficient
  for that cross section to the quadratic resistance inside the tunnel;
- ``length`` makes speed limits hold until the train's tail has passed them;
- ``ETCS braking data`` is checked complete and in known units, then reported as not modelled.

Fields ecostudy does not model are named in a warning; ``metadata``, ``num seats``, ``num
coaches`` and ``altitude`` are descriptive and read silently.
"""
import math
import warnings
from os import PathLike
from typing import Any, Collection, Mapping, Sequence, TypeAlias

import numpy as np

from ecostudy.core import units
from ecostudy.core.errors import EcostudyWarning, InputError, finite_number, problem
from ecostudy.core.physics import ROECKL_MIN_RADIUS
from ecostudy.io.trainschema import mass_out_of_range

Where: TypeAlias = str | PathLike[str]

DESCRIPTIVE = {"metadata", "num seats", "num coaches", "altitude"}
TRAIN_FIELDS = {"mass", "rho", "length", "max traction power", "max reg braking power", "max traction force",
                "max reg braking force", "max pn braking force", "max acceleration", "max deceleration",
                "max speed", "rolling resistance r0", "rolling resistance r1", "rolling resistance r2",
                "efficiency traction", "efficiency reg brake", "tunnel resistance", "ETCS braking data"}
TRACK_FIELDS = {"stops", "speed limits", "gradients", "curvatures", "tunnels", "ETCS braking data"}
ETCS_TRAIN = {"A_brake_emergency": None, "A_brake_service": None, "K_dry_rst": "share", "K_wet_rst": "share",
              "T_traction": "time", "T_be": "time", "T_bs": "time", "v_uncertainty": "share"}
ETCS_TRACK = {"M_NVAVADH": "share", "Kt_int": "share"}
TRACK_ALIASES = {  # the track schema's fields as a TTOBench track names them (its tables' rows and columns)
    **{f"speed_limits[].{k}": f"speed limits.values[].{v}" for k, v in (("position_m", "position"), ("speed_kmh", "velocity"))},
    **{f"gradients[].{k}": f"gradients.values[].{v}" for k, v in (("position_m", "position"), ("gradient_permille", "slope"))},
    **{f"curves[].{k}": f"curvatures.values[].{v}" for k, v in (("position_m", "position"), ("radius_m", "radius at start"),
                                                                  ("end_radius_m", "radius at end"))},
    **{f"tunnels[].{k}": f"tunnels.values[].{v}" for k, v in (("position_m", "position"), ("length_m", "length"),
                                                               ("cross_section_m2", "cross section"))},
    "stops[].position_m": "stops.values[]", "length_m": "stops (the last one's position)",
    "speed_limits": "speed limits", "speed_limits[]": "speed limits.values[]", "gradients[]": "gradients.values[]",
    "curves": "curvatures", "curves[]": "curvatures.values[]", "tunnels[]": "tunnels.values[]", "stops[]": "stops.values[]",
}
REQUIRED = {"mass", "max speed", "max traction power", "max reg braking power", "max traction force",
            "max reg braking force", "rolling resistance r0", "rolling resistance r1", "rolling resistance r2"}
DIMENSIONS = {"mass": "mass", "max speed": "speed", "max traction force": "force", "max traction power": "power",
              "max reg braking force": "force", "max reg braking power": "power", "max pn braking force": "force",
              "rolling resistance r0": "force", "rolling resistance r1": "force per speed",
              "rolling resistance r2": "force per speed^2"}
POSITIVE = {"mass", "max speed", "max traction force", "max traction power"}


def metadata(doc: Mapping[str, Any]) -> dict[str, str]:
    """The ``metadata`` mapping of a document (an empty one when it is missing or not a mapping)."""
    meta = doc.get("metadata")
    return {k: str(v) for k, v in meta.items()} if isinstance(meta, dict) else {}


def _convert(value: object, unit: object, dimension: str, path: Where, key: str) -> float:
    factor = units.si_factor(unit, dimension)
    if factor is None:
        known = ", ".join(units.BY_DIMENSION[dimension])
        raise InputError(problem(path, key, f"unknown unit {unit!r} for a {dimension} (known: {known})"))
    if not finite_number(value):
        raise InputError(problem(path, key, f"expected a finite number, got {value!r}"))
    return float(value) * factor


def quantity(doc: Mapping[str, Any], key: str, path: Where, dimension: str, default: float | None = None) -> float:
    """A ``{"unit": u, "value": x}`` field in SI; ``default`` (SI) when absent, else refused."""
    if key not in doc:
        if default is None:
            raise InputError(problem(path, key, "missing field"))
        return default
    item = doc[key]
    if not isinstance(item, dict) or "value" not in item or "unit" not in item:
        raise InputError(problem(path, key, "expected {\"unit\": ..., \"value\": ...}"))
    unmodelled(item, {"unit", "value"}, path, f"{key!r}", key)
    return _convert(item["value"], item["unit"], dimension, path, key)


def table(doc: Mapping[str, Any], key: str, path: Where, columns: Sequence[tuple[str, str]]) -> list[list[float]]:
    """A ``{"units": {...}, "values": [[...], ...]}`` field as rows in SI; ``columns`` is a list of
    (unit name, dimension); a cell "infinity" is read as inf (a straight's radius)."""
    item = doc.get(key)
    if not isinstance(item, dict) or not isinstance(item.get("values"), list) or not isinstance(item.get("units"), dict):
        raise InputError(problem(path, key, "expected {\"units\": {...}, \"values\": [[...], ...]}"))
    given = item["units"]
    unmodelled(item, {"units", "values"}, path, f"{key!r}", key)
    unmodelled(given, {name for name, _ in columns}, path, f"{key!r} unit", f"{key}.units")
    rows: list[list[float]] = []
    for i, row in enumerate(item["values"]):
        where = f"{key}.values[{i}]"
        if not isinstance(row, list) or len(row) != len(columns):
            raise InputError(problem(path, where, f"expected [{', '.join(c for c, _ in columns)}]"))
        out: list[float] = []
        for (name, dimension), value in zip(columns, row):
            unit = given.get(name)
            if unit is None:
                raise InputError(problem(path, f"{key}.units", f"missing the unit of {name!r}"))
            if isinstance(value, str) and value.strip().lower() in ("infinity", "inf"):
                out.append(math.inf)
                continue
            out.append(_convert(value, unit, dimension, path, where))
        rows.append(out)
    return rows


def unmodelled(doc: Mapping[str, Any], known: Collection[str], path: Where, what: str, within: str = "") -> None:
    """Warn of each key of ``doc`` (a document, or the mapping of its field ``within``) that is not
    ``known``: a field ecostudy does not read."""
    for key in doc:
        if key not in known and (within or key not in DESCRIPTIVE):
            warnings.warn(problem(path, f"{within}.{key}" if within else key,
                                  f"a {what} field ecostudy does not model: ignored"), EcostudyWarning, stacklevel=3)


def _etcs(doc: Mapping[str, Any], path: Where, fields: Mapping[str, str | None], what: str,
          used: bool = False) -> list[tuple[float, float]] | None:
    """Check ``ETCS braking data`` complete and in known units; warn that it is not modelled
    (``used``: only the service-brake curve is, as the braking envelope). Returns the service
    curve [(speed m/s, deceleration m/s^2)] of a train's data."""
    data = doc["ETCS braking data"]
    if not isinstance(data, dict):
        raise InputError(problem(path, "ETCS braking data", "expected a mapping of fields"))
    missing = sorted(set(fields) - set(data))
    if missing:
        raise InputError(problem(path, "ETCS braking data", "missing " + ", ".join(missing)))
    unmodelled(data, fields, path, "'ETCS braking data'", "ETCS braking data")  # TTOBench refuses it as redundant
    service: list[tuple[float, float]] | None = None
    for name, dimension in fields.items():
        if dimension is None:  # a deceleration curve: [velocity, deceleration], both > = 0
            rows = table(data, name, path, [("velocity", "speed"), ("deceleration", "acceleration")])
            if len(rows) < 2 or any(a < 0 or v < 0 for v, a in rows) or any(b[0] <= a[0] for a, b in zip(rows, rows[1:])):
                raise InputError(problem(path, f"ETCS braking data.{name}", "need two or more rows, velocities "
                                         "increasing from 0 and decelerations >= 0"))
            service = [(v, a) for v, a in rows] if name == "A_brake_service" else service
        else:
            quantity(data, name, path, dimension)
    if used:
        warnings.warn(problem(path, "ETCS braking data", "the service-brake deceleration curve (A_brake_service) is "
                              "the braking envelope; the emergency curve, correction factors, delays and speed "
                              "uncertainty are read and checked, not modelled"), EcostudyWarning, stacklevel=3)
    else:
        warnings.warn(problem(path, "ETCS braking data", f"{what} ETCS braking data read and checked, not modelled "
                              "(ecostudy brakes on the train's brake forces and deceleration bound; "
                              "train.json#etcs brakes on its service-brake curve)"), EcostudyWarning, stacklevel=3)
    return service


def ttobench_track(doc: Mapping[str, Any], path: Where) -> dict[str, Any]:
    """A TTOBench track as a track-schema dict (SI converted to the schema's field units)."""
    meta = metadata(doc)
    name = meta.get("id") or str(path)
    unmodelled(doc, TRACK_FIELDS, path, "track")
    stops = doc.get("stops")
    if not isinstance(stops, dict) or "unit" not in stops or not isinstance(stops.get("values"), list):
        raise InputError(problem(path, "stops", "expected {\"unit\": ..., \"values\": [...]}"))
    positions = [_convert(p, stops["unit"], "length", path, "stops") for p in stops["values"]]
    if len(positions) < 2:
        raise InputError(problem(path, "stops", "need at least two stops"))
    limits = table(doc, "speed limits", path, [("position", "length"), ("velocity", "speed")])
    grades = (table(doc, "gradients", path, [("position", "length"), ("slope", "slope")])
              if "gradients" in doc else [[0.0, 0.0]])
    curves = []
    if "curvatures" in doc:
        for i, (pos, r0, r1) in enumerate(table(doc, "curvatures", path, [("position", "length"), ("radius at start",
                                                                          "length"), ("radius at end", "length")])):
            if min(abs(r0), abs(r1)) < ROECKL_MIN_RADIUS:  # ms-eetc track.py: CURVATURE_THRESHOLD = 1/150
                raise InputError(problem(path, f"curvatures.values[{i}]", f"a radius of {min(abs(r0), abs(r1)):g} m, "
                                         f"below {ROECKL_MIN_RADIUS:g} m: ms-eetc refuses the track (its curvature "
                                         "limit), and Roeckl's formula of curve resistance is not used below it"))
            start = None if math.isinf(r0) else r0
            curves.append({"position_m": pos, "radius_m": start, **({} if r1 == r0 else {"end_radius_m": r1})})
    tunnels = []
    if "tunnels" in doc:
        tunnels = [{"position_m": p, "length_m": n, "cross_section_m2": a} for p, n, a in table(
            doc, "tunnels", path, [("position", "length"), ("length", "length"), ("cross section", "area")])]
    if "ETCS braking data" in doc:
        _etcs(doc, path, ETCS_TRACK, "track")
    return {
        "name": name,
        "source": f"TTOBench track {name} ({meta.get('library version', 'version not stated')}, "
                  f"{meta.get('license', 'BSD-2-Clause')})",
        "length_m": positions[-1],
        "stops": [{"name": f"S{i}", "position_m": p} for i, p in enumerate(positions)],
        "gradients": [{"position_m": p, "gradient_permille": g / units.PERMILLE} for p, g in grades],
        "curves": curves,
        "tunnels": tunnels,
        "speed_limits": [{"position_m": p, "speed_kmh": v / units.KMH} for p, v in limits],
    }


def _braking(doc: Mapping[str, Any], path: Where, top: float, f_reg: float, p_reg: float,
             f_pn: float) -> dict[str, Any]:
    """Regenerative (force and power limited) plus pneumatic braking as a force table [kN] over
    [0, top], with the regenerative corner speed P/F as a table point."""
    if f_reg <= 0 and f_pn <= 0:
        raise InputError(problem(path, "max reg braking force", "no brake at all (regenerative and pneumatic "
                                 "forces are both 0)"))
    speeds = np.linspace(0.0, top, 81)
    if f_reg > 0 and math.isfinite(p_reg) and p_reg / f_reg < top:
        speeds = np.unique(np.append(speeds, p_reg / f_reg))
    force = np.minimum(f_reg, p_reg / np.maximum(speeds, 1e-9)) + f_pn
    return {"table": {"speed_kmh": (speeds / units.KMH).tolist(), "force_kN": (force / units.KN).tolist()}}


def ttobench_train(doc: Mapping[str, Any], path: Where,
                   selector: str | None = None) -> tuple[dict[str, Any], dict[str, str]]:
    """A TTOBench train as a train-schema dict, and the field names for messages. ``selector``
    ``etcs``: brake on the service-brake deceleration curve of ``ETCS braking data`` (times the
    effective mass) instead of the brake forces."""
    if selector not in (None, "etcs"):
        raise InputError(problem(path, f"#{selector}", "a TTOBench train takes '#etcs' (brake on the ETCS "
                                 "service-brake curve) or nothing"))
    if selector == "etcs" and "ETCS braking data" not in doc:
        raise InputError(problem(path, "ETCS braking data", "missing: '#etcs' brakes on its service-brake curve"))
    meta = metadata(doc)
    name = meta.get("id") or str(path)
    unmodelled(doc, TRAIN_FIELDS, path, "train")
    missing = sorted(REQUIRED - set(doc))  # TTOBench's validate_trains.py: no reading of ours fills them
    if missing:
        raise InputError(problem(path, missing[0], "missing field (TTOBench requires "
                                 + ", ".join(f"'{m}'" for m in missing) + ")"))
    value = {key: quantity(doc, key, path, dimension, 0.0) for key, dimension in DIMENSIONS.items()}
    for key, x in value.items():  # ms-eetc's checks (train.py checkFields); a brake is given as its size
        if x < 0 or (x == 0 and key in POSITIVE):
            raise InputError(problem(path, key, f"must be {'above 0' if key in POSITIVE else '0 or more'}, not {x:g}"))
    top, f_t, p_t = value["max speed"], value["max traction force"], value["max traction power"]
    f_reg, p_reg, f_pn = value["max reg braking force"], value["max reg braking power"], value["max pn braking force"]
    if f_reg > 0 and p_reg == 0:
        raise InputError(problem(path, "max reg braking power", f"0 beside a regenerative force of {f_reg / units.KN:g} "
                                 "kN: both above 0, or the force 0 for no electric brake"))
    rho = quantity(doc, "rho", path, "share", 0.0)
    factor = rho if rho < 1 else rho - 1  # ms-eetc: 6 % -> 1.06, a factor 1.06 kept
    if not 0 <= factor <= 0.5:  # ms-eetc's own check: 1 <= rho <= 1.5
        raise InputError(problem(path, "rho", f"the rotating-mass factor {1 + factor:g} is outside 1-1.5 (a value "
                                 "below 1 is read as a share, as ms-eetc reads it: 0.06 -> 1.06)"))
    bounds = {}
    for key, field in (("max acceleration", "max_acceleration_mps2"), ("max deceleration", "max_deceleration_mps2")):
        if key in doc:
            bound = quantity(doc, key, path, "acceleration")
            if bound == 0 or (key == "max acceleration" and bound < 0):  # ms-eetc: a deceleration of either sign
                raise InputError(problem(path, key, f"must be above 0, not {bound:g} m/s^2"))
            bounds[field] = abs(bound)
    given = [key for key in ("efficiency traction", "efficiency reg brake") if key in doc]
    if len(given) == 1:  # TTOBench and ms-eetc: both or neither
        other = ({"efficiency traction", "efficiency reg brake"} - set(given)).pop()
        raise InputError(problem(path, other, f"missing: give both efficiencies or neither ({given[0]!r} is given)"))
    if not given:
        warnings.warn(problem(path, "efficiency traction", "no efficiencies given: traction and regenerative braking "
                              "counted at 100 % (ms-eetc's mechanical energy); the net energy is at the wheel"),
                      EcostudyWarning, stacklevel=2)
    regen = None
    if f_reg > 0:
        regen = {"max_force_kN": f_reg / units.KN,
                 "efficiency": quantity(doc, "efficiency reg brake", path, "share", 1.0)}
        if math.isfinite(p_reg):
            regen["max_power_kW"] = p_reg / units.KW
    tunnels = []
    if "tunnel resistance" in doc:
        rows = table(doc, "tunnel resistance", path, [("cross section", "area"), ("coefficient", "force per speed^2")])
        tunnels = [{"cross_section_m2": a, "c_kN_per_kmh2": c * units.KMH**2 / units.KN} for a, c in rows]
    service = _etcs(doc, path, ETCS_TRAIN, "train", used=selector == "etcs") if "ETCS braking data" in doc else None
    length = quantity(doc, "length", path, "length", 0.0)
    mass = value["mass"]
    if (wrong := mass_out_of_range(mass)) is not None:  # said in kg and t: the schema's bound is in tonnes
        raise InputError(problem(path, "mass", wrong))
    braking = _braking(doc, path, top, f_reg, p_reg, f_pn)
    if selector == "etcs":  # the deceleration curve of the whole train: force = M a, M with the rotating allowance
        if service is None:
            raise InputError(problem(path, "ETCS braking data", "missing: '#etcs' brakes on its A_brake_service curve"))
        effective = mass * (1 + factor)
        braking = {"table": {"speed_kmh": [v / units.KMH for v, _ in service],
                             "force_kN": [effective * a / units.KN for _, a in service]}}
    return {
        "name": name,
        "source": f"TTOBench train {name} ({meta.get('library version', 'version not stated')}); "
                  + (f"{length:g} m long" if length else "point mass (no length given)"),
        "mass_t": mass / units.TONNE,
        "rotating_mass_factor": factor,
        "length_m": length,
        "davis": {"a_N": value["rolling resistance r0"], "b_N_per_mps": value["rolling resistance r1"],
                  "c_N_per_mps2": value["rolling resistance r2"]},
        "traction": {"max_force_kN": f_t / units.KN, "max_power_kW": p_t / units.KW},
        "braking": braking,
        "traction_efficiency": quantity(doc, "efficiency traction", path, "share", 1.0),
        "regenerative_braking": regen,
        "curve_resistance": "roeckl",
        "tunnel_resistance": tunnels,
        "max_speed_kmh": top / units.KMH,
        **bounds,
    }, {"davis.a_N": "rolling resistance r0", "davis.b_N_per_mps": "rolling resistance r1",
        "davis.c_N_per_mps2": "rolling resistance r2", "traction.max_force_kN": "max traction force",
        "traction.max_power_kW": "max traction power", "regenerative_braking.max_force_kN": "max reg braking force",
        "regenerative_braking.max_power_kW": "max reg braking power", "mass_t": "mass", "length_m": "length",
        "max_speed_kmh": "max speed", "traction_efficiency": "efficiency traction",
        "regenerative_braking.efficiency": "efficiency reg brake", "tunnel_resistance": "tunnel resistance",
        "tunnel_resistance[]": "tunnel resistance.values[]",
        "tunnel_resistance[].cross_section_m2": "tunnel resistance.values[].cross section",
        "tunnel_resistance[].c_kN_per_kmh2": "tunnel resistance.values[].coefficient"}
