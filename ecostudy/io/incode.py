"""A :class:`~ecostudy.core.types.Train` or :class:`~ecostudy.core.types.Track` built or changed in
code (``dataclasses.replace``) checked by the rules of its file before anything is solved.

The object is written back into the fields of its file (units in their names: ``mass_t``,
``speed_kmh``) and that document validated through the file's own schema (:mod:`ecostudy.io.schemas`,
the one place of the rules), every problem one line naming the object's own field as a caller
spells it: ``arguments: train.traction_efficiency: Input should be less than or equal to 1``. A
field the file gives in other units says which file field the rule was read on:
``arguments: train.static_mass (as the file's mass_t): Input should be greater than or equal to 1``.
"""
import math
import numbers
from typing import Any, Iterable, Mapping

from ecostudy.core import units
from ecostudy.core.errors import InputError, problem
from ecostudy.core.grid import too_long
from ecostudy.core.physics import EfficiencyMap, Envelope
from ecostudy.core.types import Track, Train
from ecostudy.io import schemas
from ecostudy.io.davis import check_davis_bound
from ecostudy.io.documents import validate

WHERE = "arguments"
Fields = Mapping[str, tuple[str, "bool | str"]]

# file field (a schema path, '[]' for a list's items) -> (the object's field, whether the file gives it
# in other units: True, or the file's field as the object's)
TRAIN_FIELDS: Fields = {
    "name": ("name", False), "mass_t": ("static_mass", True), "rotating_mass_factor": ("mass", "rotating_mass_factor = mass / static_mass - 1"),
    "length_m": ("length", False), "davis": ("davis", False), "davis.a_N": ("davis[0]", False),
    "davis.b_N_per_mps": ("davis[1]", False), "davis.c_N_per_mps2": ("davis[2]", False),
    "traction_efficiency": ("traction_efficiency", False), "curve_coefficient_m2ps2": ("curve_coefficient", False),
    "curve_resistance": ("curve_resistance", False), "tunnel_resistance": ("tunnel_resistance", False),
    "tunnel_resistance[].cross_section_m2": ("tunnel_resistance[][0]", False),
    "tunnel_resistance[].c_kN_per_kmh2": ("tunnel_resistance[][1]", True),
    "max_speed_kmh": ("max_speed", True), "max_acceleration_mps2": ("max_acceleration", False),
    "max_deceleration_mps2": ("max_deceleration", False), "das_handle_levels": ("das_levels", False),
    "adhesion": ("adhesion", False), "adhesion.adhesive_mass_t": ("adhesion.mass", True),
    "adhesion.law": ("adhesion.law", False), "adhesion.mu": ("adhesion.mu", False),
    "regenerative_braking": ("regeneration", False),
    "regenerative_braking.efficiency": ("regeneration_efficiency", False),
}
ENVELOPE_FIELDS: Fields = {"": ("", False), ".table": ("", False), ".table.speed_kmh": (".speeds", True),
                   ".table.force_kN": (".forces", True), ".max_force_kN": (".max_force", True),
                   ".max_power_kW": (".max_power", True)}
MAP_FIELDS: Fields = {"": ("", False), ".speed_kmh": (".speeds", True), ".force_kN": (".forces", True),
              ".efficiency": (".values", False)}
TRACK_FIELDS: Fields = {
    "name": ("name", False), "length_m": ("length", False), "stops": ("stops", False),
    "stops[].name": ("stops", False), "stops[].position_m": ("stops[]", False),
    "gradients": ("gradient_positions", False), "gradients[].position_m": ("gradient_positions[]", False),
    "gradients[].gradient_permille": ("gradients[]", True), "curves": ("curve_positions", False),
    "curves[].position_m": ("curve_positions[]", False), "curves[].radius_m": ("curvatures[]", True),
    "curves[].end_radius_m": ("curvature_slopes[]", True), "speed_limits": ("limit_positions", False),
    "speed_limits[].position_m": ("limit_positions[]", False), "speed_limits[].speed_kmh": ("limits[]", True),
    "tunnels": ("tunnels", False), "tunnels[].position_m": ("tunnels[][0]", False),
    "tunnels[].length_m": ("tunnels[][1]", False), "tunnels[].cross_section_m2": ("tunnels[][2]", False),
}


def _aliases(owner: str, fields: Fields) -> dict[str, str]:
    """Schema path -> the name a line gives it (:func:`ecostudy.io.documents.aliased`): ``owner.field``,
    with the file's field beside it where the file reads it in other units; a list's items by
    index (``[]`` in a path, filled in order)."""
    out = {}
    for path, (name, converted) in fields.items():
        leaf = converted if isinstance(converted, str) else path.rsplit(".", 1)[-1].replace("[]", "")
        unit = f" (as the file's {leaf})" if converted else ""
        out[path] = f"{owner}.{name}{unit}"
        for items in ("[]", "[][]"):  # an item of a list (of lists) field
            out.setdefault(f"{path}{items}", f"{owner}.{name}{items}{unit}")
    return out


def _nested(fields: Fields, path: str, name: str) -> Fields:
    return {f"{path}{p}": (f"{name}{n}", c) for p, (n, c) in fields.items()}


TRAIN_ALIASES = _aliases("train", {
    **TRAIN_FIELDS, **_nested(ENVELOPE_FIELDS, "traction", "traction"), **_nested(ENVELOPE_FIELDS, "braking", "braking"),
    **{f"regenerative_braking{p}": (f"regeneration{n}", c) for p, (n, c) in ENVELOPE_FIELDS.items() if "table" not in p},
    **_nested(MAP_FIELDS, "traction_efficiency_map", "traction_efficiency_map"),
    **_nested(MAP_FIELDS, "regenerative_braking.efficiency_map", "regeneration_efficiency_map")})
REGENERATION_TABLE_ALIASES = _aliases("train", {p: (f"regeneration{n}", c) for p, (n, c) in
                                                {"speed_kmh": (".speeds", True), "force_kN": (".forces", True)}.items()})
TRACK_ALIASES = _aliases("track", TRACK_FIELDS)


def _over(value: Any, scale: float) -> Any:
    """``value`` in the file's unit (divided by ``scale``); a value that is no number is left as it is,
    for the schema to refuse by name."""
    return value / scale if isinstance(value, numbers.Real) and not isinstance(value, bool) else value


def _unless_none(value: Any, scale: float = 1.0) -> Any:
    """A limit the file leaves out for none (``inf`` in SI) as None, else in the file's unit."""
    return None if isinstance(value, numbers.Real) and value == math.inf else _over(value, scale)


def _envelope(envelope: Any) -> Any:
    """An :class:`Envelope` as a traction or braking block of a train file (a table, or a force
    with a power); anything else as it is (the schema refuses it)."""
    if not isinstance(envelope, Envelope):
        return envelope
    if envelope.kind == "table":
        return {"table": _table(envelope.speeds, envelope.forces)}
    if envelope.kind != "force_power":  # neither form: the schema says what it takes
        return {}
    return {"max_force_kN": _over(envelope.max_force, units.KN), "max_power_kW": _unless_none(envelope.max_power, units.KW)}


def _table(speeds: Iterable[Any], forces: Iterable[Any]) -> dict[str, Any]:
    return {"speed_kmh": [_over(v, units.KMH) for v in speeds], "force_kN": [_over(f, units.KN) for f in forces]}


def _map(table: EfficiencyMap | None) -> Any:
    if not isinstance(table, EfficiencyMap):
        return table
    return {**_table(table.speeds, table.forces), "efficiency": [list(row) for row in table.values]}


def train_as_document(train: Train) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """(the fields of a train file that give ``train``, a regenerative brake's table or None).

    A regenerative brake capped at adhesion is a table, which a train file does not give (it caps
    it when loaded): it is returned apart, for the table schema alone."""
    static, mass = train.static_mass, train.mass
    known = isinstance(static, numbers.Real) and math.isfinite(static) and static > 0  # else mass_t says it
    factor = (train.rotating_mass_factor if isinstance(mass, numbers.Real) else mass) if known else 0.0
    regen, regen_table, block = train.regeneration, None, None
    if regen is not None:
        block = {"efficiency": train.regeneration_efficiency, "efficiency_map": _map(train.regeneration_efficiency_map)}
        if isinstance(regen, Envelope) and regen.kind == "table":
            regen_table = _table(regen.speeds, regen.forces)
        elif isinstance(regen, Envelope) and regen.kind == "force_power":  # a limit left out is inf
            block.update(max_force_kN=_unless_none(regen.max_force, units.KN),
                         max_power_kW=_unless_none(regen.max_power, units.KW))
        else:  # not an envelope: refused as its force
            block["max_force_kN"] = regen
    adhesion = train.adhesion
    doc = {
        "name": train.name, "source": "built in code", "mass_t": _over(static, units.TONNE),
        "rotating_mass_factor": factor, "length_m": train.length,
        "davis": dict(zip(schemas.Davis.TRIPLES[0], train.davis)) if isinstance(train.davis, (tuple, list))
        and len(train.davis) == 3 else train.davis,
        "traction": _envelope(train.traction), "braking": _envelope(train.braking),
        "traction_efficiency": train.traction_efficiency,
        "traction_efficiency_map": _map(train.traction_efficiency_map), "regenerative_braking": block,
        "curve_coefficient_m2ps2": train.curve_coefficient, "curve_resistance": train.curve_resistance,
        "tunnel_resistance": [{"cross_section_m2": a, "c_kN_per_kmh2": _over(c, units.KN / units.KMH ** 2)}
                              for a, c in train.tunnel_resistance],
        "max_speed_kmh": _unless_none(train.max_speed, units.KMH),
        "max_acceleration_mps2": _unless_none(train.max_acceleration),
        "max_deceleration_mps2": _unless_none(train.max_deceleration),
        "das_handle_levels": list(train.das_levels),
        "adhesion": None if adhesion is None else {"adhesive_mass_t": _over(adhesion.mass, units.TONNE),
                                                   "law": adhesion.law, "mu": adhesion.mu},
    }
    return doc, regen_table


def _curves(track: Track) -> list[dict[str, Any]]:
    """The track's curve sections as a file gives them: radii, a clothoid's end radius."""
    positions, starts = list(track.curve_positions), list(track.curvatures)
    slopes = None if track.curvature_slopes is None else list(track.curvature_slopes)
    ends = positions[1:] + [track.length]
    out = []
    for i, (x, c) in enumerate(zip(positions, starts)):
        row: dict[str, Any] = {"position_m": x, "radius_m": None if c == 0 else _over(1.0, c)}
        if slopes is not None and slopes[i] != 0:
            end = c + slopes[i] * (ends[i] - x)
            row["end_radius_m"] = math.inf if end == 0 else 1.0 / end
        out.append(row)
    return out


def track_as_document(track: Track) -> dict[str, Any]:
    """The fields of a track file that give ``track``."""
    return {
        "name": track.name, "source": "built in code", "length_m": track.length,
        "stops": [{"name": n, "position_m": x} for n, x in track.stops.items()],
        "gradients": [{"position_m": x, "gradient_permille": _over(g, units.PERMILLE)}
                      for x, g in zip(track.gradient_positions, track.gradients)],
        "curves": _curves(track),
        "speed_limits": [{"position_m": x, "speed_kmh": _over(v, units.KMH)}
                         for x, v in zip(track.limit_positions, track.limits)],
        "tunnels": [{"position_m": a, "length_m": n, "cross_section_m2": s} for a, n, s in track.tunnels],
    }


def _lengths(owner: str, pairs: Iterable[tuple[str, Any, str, Any]]) -> list[str]:
    """A line for each pair of fields that must be as long as each other and are not."""
    return [problem(WHERE, f"{owner}.{b}", f"{len(vb)} values for the {len(va)} of {owner}.{a}")
            for a, va, b, vb in pairs if vb is not None and len(va) != len(vb)]


def _checked(schema: type, data: Any, aliases: dict[str, str]) -> tuple[list[str], Any]:
    try:
        return [], validate(schema, data, WHERE, aliases)
    except InputError as exc:
        return exc.problems, None


def built_problems(train: Train | None = None, track: Track | None = None) -> list[str]:
    """The lines a train or track file giving ``train`` or ``track`` would be refused with, naming
    their fields (``arguments: train.mass ...``); a train longer than its track too. None: not checked."""
    lines: list[str] = []
    if train is not None:
        try:
            doc, regen_table = train_as_document(train)
        except (TypeError, ValueError) as exc:  # a field that is not what Train says it is
            return [problem(WHERE, "train", f"not a Train of the fields core.types.Train names ({exc})")]
        found, checked = _checked(schemas.TrainFile, doc, TRAIN_ALIASES)
        lines += found
        if regen_table is not None:
            lines += _checked(schemas.ForceTable, regen_table, REGENERATION_TABLE_ALIASES)[0]
        if checked is not None:  # each Davis term against the weight: the loader's own check
            try:
                check_davis_bound(checked.davis, train.davis, train.static_mass, schemas.Davis.TRIPLES[0],
                                  [f"train.davis[{i}]" for i in range(3)], WHERE)
            except InputError as exc:
                lines += exc.problems
    if track is not None:
        try:
            lines += _lengths("track", [("gradient_positions", track.gradient_positions, "gradients", track.gradients),
                                        ("curve_positions", track.curve_positions, "curvatures", track.curvatures),
                                        ("curve_positions", track.curve_positions, "curvature_slopes",
                                         track.curvature_slopes),
                                        ("limit_positions", track.limit_positions, "limits", track.limits)])
            lines += _checked(schemas.TrackFile, track_as_document(track), TRACK_ALIASES)[0]
        except (TypeError, ValueError, ZeroDivisionError) as exc:
            lines.append(problem(WHERE, "track", f"not a Track of the fields core.types.Track names ({exc})"))
    if train is not None and track is not None and not lines:
        why = too_long(train, track)
        if why is not None:
            lines.append(problem(WHERE, "train.length", why))
    return lines
