"""Imports of formats researchers already use, recognised by content, mapped onto ecostudy's schemas.

- TTOBench tracks and trains: :mod:`ecostudy.io.ttobench` (ms-eetc semantics).
- TTOBench journeys (``nuorail/ttobench`` journeys/README.md): ``timing points`` ``values`` =
  [position, lower time, upper time, lower speed, upper speed] with ``units`` (position m or km,
  times s, speeds km/h or m/s), null = no constraint, times since the journey's start. Points
  with both speed bounds 0 are stops (the first is the departure, the last the arrival); the
  others are passing points. TTOBench has no dwell times: ecostudy's ``--dwell`` supplies them.
- OSRD rolling stock: :mod:`ecostudy.io.osrd` (OSRD semantics, power mode by ``file.json#MODE``).

The result is a dict in the YAML schema, validated afterwards like any YAML file.
"""
import math
from os import PathLike
from typing import Any, Mapping, TypeAlias

from ecostudy.core import units
from ecostudy.core.errors import InputError, finite_number, problem
from ecostudy.io.osrd import osrd_train
from ecostudy.io.ttobench import DESCRIPTIVE, metadata, ttobench_track, ttobench_train, unmodelled

Where: TypeAlias = str | PathLike[str]


def track_document_to_schema(doc: Mapping[str, Any], path: Where) -> dict[str, Any]:
    if "speed limits" in doc:
        return ttobench_track(doc, path)
    raise InputError(problem(path, "", "not a TTOBench track (no 'speed limits' field)"))


_POSITION = {"m": 1.0, "km": 1000.0}          # [m] per unit
_SPEED_KMH = {"km/h": 1.0, "m/s": 1.0 / units.KMH}  # [km/h] per unit


# a timetable stop's fields read off the row of its arrival, and off the row of its departure
_ARRIVAL = ("", ".position_m", ".arrival_s", ".earliest_s", ".latest_s")
_UNITS = ("position", "lower time constraint", "upper time constraint", "lower speed constraint", "upper speed constraint")
_DEPARTURE = (".departure_s", ".departure_earliest_s", ".departure_latest_s", ".dwell_s")


def ttobench_journey(doc: Mapping[str, Any], path: Where) -> tuple[dict[str, Any], dict[str, str]]:
    """(a TTOBench journey as a timetable dict: stops by position, arrival windows, windows; the
    timetable's fields as the journey names them, for messages: ``stops[1].latest_s`` is
    ``timing points.values[2]``, :func:`ecostudy.io.documents.aliased`)."""
    points = doc.get("timing points")
    if not isinstance(points, dict) or "values" not in points:
        raise InputError(problem(path, "timing points", "expected {'units': ..., 'values': [...]}"))
    if "units" not in points:  # TTOBench's validate_journeys.py: all five, never a default
        raise InputError(problem(path, "timing points.units", "missing field (TTOBench requires the unit of each "
                                 "column: " + ", ".join(f"'{u}'" for u in _UNITS) + ")"))
    given = points["units"]
    if not isinstance(given, dict) or not all(isinstance(u, str) for u in given.values()):
        raise InputError(problem(path, "timing points.units", "expected a mapping of unit names"))
    missing = [u for u in _UNITS if u not in given]
    if missing:
        raise InputError(problem(path, f"timing points.units.{missing[0]}", "missing field (TTOBench requires "
                                 + ", ".join(f"'{u}'" for u in missing) + ")"))
    pos_unit, speed_unit = given["position"], given["lower speed constraint"]
    if pos_unit not in _POSITION:
        raise InputError(problem(path, "timing points.units.position", f"expected m or km, got {pos_unit!r}"))
    if speed_unit not in _SPEED_KMH or given["upper speed constraint"] != speed_unit:
        raise InputError(problem(path, "timing points.units", "speed constraints need one unit, km/h or m/s"))
    for key in ("lower time constraint", "upper time constraint"):  # TTOBench's validate_journeys.py: seconds
        if given[key] != "s":
            raise InputError(problem(path, f"timing points.units.{key}", f"expected s, got {given[key]!r}"))
    unmodelled(doc, {"metadata", "timing points", *DESCRIPTIVE}, path, "journey")
    unmodelled(points, {"units", "values"}, path, "'timing points'", "timing points")
    unmodelled(given, _UNITS, path, "'timing points' unit", "timing points.units")
    rows = points["values"]
    if not isinstance(rows, list) or len(rows) < 2:
        raise InputError(problem(path, "timing points.values", "need at least two timing points"))
    stops: list[dict[str, Any]] = []
    windows: list[dict[str, Any]] = []
    lines: list[str] = []
    aliases = {"stops": "timing points.values", "windows": "timing points.values"}

    def scaled(x: float | None, factor: float) -> float | None:
        return None if x is None else float(x) * factor

    last, before, was_stop = -math.inf, -math.inf, False  # the position of the point above, of the one above it [m]
    for i, row in enumerate(rows):
        where = f"timing points.values[{i}]"
        if not isinstance(row, list) or len(row) != 5:
            lines.append(problem(path, where, "expected [position, lower time, upper time, lower speed, upper speed]"))
            continue
        if any(x is not None and not finite_number(x)
               for x in row) or row[0] is None:
            lines.append(problem(path, where, f"expected finite numbers or null, got {row!r}"))
            continue
        pos = float(row[0]) * _POSITION[pos_unit]
        if pos < last:
            lines.append(problem(path, where, f"position {row[0]:g} {pos_unit} before the point above it: the "
                                 "timing points go along the line"))
            continue
        lo, hi = scaled(row[1], 1.0), scaled(row[2], 1.0)
        vlo, vhi = scaled(row[3], _SPEED_KMH[speed_unit]), scaled(row[4], _SPEED_KMH[speed_unit])
        stopping = vlo == 0 and vhi == 0
        if pos == last:  # TTOBench's validate_journeys.py: only an intermediate stop's arrival and departure
            shared = _shared(i, len(rows), pos == before, stopping and was_stop)
            if shared:
                lines.append(problem(path, where, f"at the position of timing points.values[{i - 1}]: {shared}"))
                continue
        last, before, was_stop = pos, last, stopping
        if stopping and 0 < i < len(rows) - 1 and pos != before and not _at(rows[i + 1], pos, _POSITION[pos_unit]):
            lines.append(problem(path, where, "an intermediate stopping point (both speed constraints 0) with no second "
                                 "at its position: an intermediate stop is an arrival and a departure point at one "
                                 "position (TTOBench's validate_journeys.py)"))
            continue
        if i == 0 or i == len(rows) - 1 or stopping:  # a stopping point
            if vlo != 0 or vhi != 0:
                lines.append(problem(path, where, "the departure and the arrival need both speed bounds 0"))
            if i == 0:
                stops.append({"position_m": pos, **_departure(lo, hi)})
            elif stops and stops[-1]["position_m"] == pos and "earliest_s" in stops[-1]:
                stops[-1].update(_departure(lo, hi))  # the second stopping point of a station: its departure
                aliases.update({f"stops[{len(stops) - 1}]{f}": where for f in _DEPARTURE})
                continue
            else:
                stops.append({"position_m": pos, "earliest_s": lo, "latest_s": hi})
            aliases.update({f"stops[{len(stops) - 1}]{f}": where for f in _ARRIVAL + _DEPARTURE})
        elif any(x is not None for x in (lo, hi, vlo, vhi)):  # a passing point; all null: no constraint
            windows.append({"position_m": pos, "earliest_s": lo, "latest_s": hi,
                            "min_speed_kmh": vlo or None, "max_speed_kmh": vhi})
            aliases.update({f"windows[{len(windows) - 1}]{f}": where for f in
                            ("", ".position_m", ".earliest_s", ".latest_s", ".min_speed_kmh", ".max_speed_kmh")})
    if lines:
        raise InputError(lines)
    meta = metadata(doc)
    return {"name": meta.get("id", str(path)),
            "source": f"TTOBench journey {meta.get('id', path)} on track {meta.get('associated track', '?')} "
                      f"({meta.get('library version', 'version not stated')})",
            "stops": stops, "windows": windows,
            **({"track": str(meta["associated track"])} if meta.get("associated track") else {})}, aliases


def _shared(i: int, rows: int, third: bool, stops: bool) -> str | None:
    """Why row ``i`` of ``rows`` may not share its position with the row above (``third``: that one
    shares it with the row above it; ``stops``: both are stopping points), as TTOBench's validator
    refuses it, else None."""
    if i == 1 or i == rows - 1:
        return "two timing points at one position are an intermediate stop's arrival and departure, not the journey's ends"
    if third:
        return "a third timing point at one position (one arrival and one departure per stop)"
    if not stops:
        return "two timing points at one position are a stop's arrival and departure, both with speed bounds 0"
    return None


def _at(row: Any, pos: float, factor: float) -> bool:
    """Whether ``row`` (a timing point, unchecked) is at ``pos`` [m] (its position times ``factor``)."""
    return isinstance(row, list) and len(row) == 5 and finite_number(row[0]) and float(row[0]) * factor == pos


def _departure(lo: float | None, hi: float | None) -> dict[str, float | None]:
    """A stopping point's times as a departure: fixed when both are equal, else a window."""
    if lo is not None and lo == hi:
        return {"departure_s": lo}
    return {"departure_earliest_s": lo, "departure_latest_s": hi}


def timetable_document_to_schema(doc: Mapping[str, Any], path: Where) -> tuple[dict[str, Any], dict[str, str]]:
    """(schema dict, field-name aliases for messages) from a TTOBench journey (:func:`ttobench_journey`)."""
    if "timing points" in doc:
        return ttobench_journey(doc, path)
    raise InputError(problem(path, "", "not a TTOBench journey (no 'timing points' field)"))


def unpaired(aliases: Mapping[str, str], path: Where) -> tuple[str, str]:
    """(curves, tunnels): how a TTOBench or OSRD train file (``path``; ``aliases``: the train schema's
    field paths as the file names them) would give curves and tunnels a resistance, in its own fields,
    for :func:`~ecostudy.core.grid.warn_unpaired` (``Train.unpaired``); a format with no field for one
    says so (OSRD rolling stock: its ``rolling_resistance`` A, B, C is all it gives)."""
    davis = aliases.get("davis.a_N", "Davis terms")
    resistance = davis.rpartition(".")[0] or davis  # OSRD: rolling_resistance.A; TTOBench: rolling resistance r0
    absent = (f"the train's file {path} gives %s no resistance: its {resistance} has no %s term, and the format no "
              "field for one")
    curve, tunnel = aliases.get("curve_coefficient_m2ps2"), aliases.get("tunnel_resistance")
    return (f"the train's {curve} is 0" if curve else absent % ("curves", "curve"),
            f"the train gives no {tunnel}" if tunnel else absent % ("tunnels", "tunnel"))


def traction_field(aliases: Mapping[str, str]) -> str:
    """The field of a TTOBench or OSRD train file (``aliases``: the train schema's field paths as the
    file names them) that gives its traction, named where a train too weak to move is refused."""
    return aliases.get("traction.max_force_kN") or aliases.get("traction.table.force_kN") or "traction"


def train_document_to_schema(doc: Mapping[str, Any], path: Where,
                             selector: str | None = None) -> tuple[dict[str, Any], dict[str, str]]:
    """(schema dict, field-name aliases for messages) from a TTOBench or OSRD train document;
    ``selector`` picks an OSRD power mode (and comfort): ``MODE`` or ``MODE/COMFORT``."""
    try:
        if "effort_curves" in doc:
            return osrd_train(doc, path, selector)
        if "max traction force" in doc or "rolling resistance r0" in doc:
            return ttobench_train(doc, path, selector)
    except KeyError as exc:
        raise InputError(problem(path, str(exc.args[0]), "missing field"))
    raise InputError(problem(path, "", "not a TTOBench or OSRD train (no 'max traction force' or 'effort_curves')"))
