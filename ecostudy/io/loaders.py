"""Load train, track, timetable and study files into SI objects. All unit conversion is here (a heavy-haul
consist file's: :mod:`ecostudy.io.consistfile`).

Every problem becomes one line ``file: field: what is wrong``; all problems of a file are
reported together (:class:`ecostudy.errors.InputError`).
"""
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ecostudy.core import units
from ecostudy.core.adhesion import TOP_SPEED, Adhesion, capped_envelopes
from ecostudy.core.defaults import RUN_POINTS
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.grid import roeckl_out_of_range, too_long
from ecostudy.core.physics import EfficiencyMap, Envelope, force_power_fit, table_width
from ecostudy.core.types import Supply, Timing, Track, Train, Window, source_file
from ecostudy.io import schemas
from ecostudy.io.consistfile import (consist_from_document as consist_from_document,  # re-exported: a consist file
                                     load_consist as load_consist)
from ecostudy.io.davis import check_davis_bound, check_davis_plausible, davis_si
from ecostudy.io.formats import (timetable_document_to_schema, track_document_to_schema, train_document_to_schema,
                                 traction_field, unpaired)
from ecostudy.io.timetable import name_stops, off_clock, segment_timing, turning_back, window_origin, windows_from_schema
from ecostudy.io.ttobench import TRACK_ALIASES
from ecostudy.io.writers import default_output
from ecostudy.io.documents import (Where, check_path, given, named_file, read_document as read_document,  # re-exported
                                   read_from, split_selector, validate as validate)


@dataclass(frozen=True)
class Study:
    name: str
    track: Track
    train: Train
    from_stop: str
    to_stop: str
    timing: Timing
    objective: str = "energy"
    weights: tuple[float, float] | None = None  # the mixed objective's (w_t, w_e); None: not given, (1, 1)
    points: int = RUN_POINTS
    output: Path = field(default_factory=lambda: Path("out"))
    track_path: Path | None = None
    train_path: Path | None = None
    windows: tuple[Window, ...] = ()
    timing_field: str = "running_time_s"  # the study file's field the timing came from (for errors)
    documents: tuple[Mapping[str, Any], ...] = ()  # (train, track) as their files give them
    timetable_path: Path | None = None  # the timetable's file, when the timing came from one
    timetable_windows: int = 0  # how many of ``windows`` (the last) are the timetable's

    def window_origin(self, field: str, study: Where) -> tuple[Where, str]:
        """(file, field) of ``windows[i]...`` as its file writes it (:func:`~ecostudy.io.timetable.window_origin`)."""
        return window_origin(field, study, self.timetable_path, len(self.windows) - self.timetable_windows)


# --------------------------------------------------------------------------- conversions
def _envelope(spec: schemas.Traction | schemas.Braking, mass: float) -> Envelope:
    """Traction or braking schema -> :class:`Envelope` in N, W, m/s."""
    if spec.table is not None:
        speeds = np.asarray(spec.table.speed_kmh) * units.KMH
        forces = np.asarray(spec.table.force_kN) * units.KN
        fit = force_power_fit(speeds, forces)
        if fit is not None:  # the table is a force and a power limit: model it exactly as such
            return Envelope("force_power", max_force=fit[0], max_power=fit[1])
        return Envelope("table", speeds=tuple(speeds.tolist()), forces=tuple(forces.tolist()),
                        width=table_width(speeds, forces))
    if isinstance(spec, schemas.Braking) and spec.max_deceleration_mps2 is not None:
        return Envelope("force_power", max_force=mass * spec.max_deceleration_mps2)
    power = spec.max_power_kW * units.KW if spec.max_power_kW is not None else float("inf")
    return Envelope("force_power", max_force=given(spec.max_force_kN) * units.KN, max_power=power)


def _efficiency_map(table: schemas.EfficiencyTable | None) -> EfficiencyMap | None:
    """An efficiency table of a train file as an :class:`EfficiencyMap` in m/s and N (or None)."""
    if table is None:
        return None
    return EfficiencyMap(tuple(np.asarray(table.speed_kmh) * units.KMH), tuple(np.asarray(table.force_kN) * units.KN),
                         tuple(tuple(row) for row in table.efficiency))


def train_from_schema(t: schemas.TrainFile, path: Where, aliases: Mapping[str, str] | None = None) -> Train:
    static = t.mass_t * units.TONNE
    mass = (t.effective_mass_t * units.TONNE if t.effective_mass_t is not None
            else static * (1 + given(t.rotating_mass_factor)))
    davis, fields = davis_si(t.davis, static)
    aliases = aliases or {}
    check_davis_bound(t.davis, davis, static, fields, [aliases.get(f"davis.{f}", f"davis.{f}") for f in fields], path)
    check_davis_plausible(davis, static, [aliases.get(f"davis.{f}", f"davis.{f}") for f in fields], path)
    regen, eta_r = None, 0.0
    if t.regenerative_braking is not None:
        r = t.regenerative_braking
        regen = Envelope("force_power", max_force=r.max_force_kN * units.KN if r.max_force_kN else float("inf"),
                         max_power=r.max_power_kW * units.KW if r.max_power_kW else float("inf"))
        eta_r = r.efficiency
    traction, a = _envelope(t.traction, mass), t.adhesion
    adhesion = None if a is None else Adhesion(a.adhesive_mass_t * units.TONNE, a.law, a.mu)
    if adhesion is not None:  # capped once here: every formulation and the plant see the same curve
        top = t.max_speed_kmh * units.KMH if t.max_speed_kmh is not None else TOP_SPEED
        traction, regen = capped_envelopes(traction, regen, adhesion, top, path)
    return Train(name=t.name, mass=mass, static_mass=static, length=t.length_m, davis=davis,
                 traction=traction, braking=_envelope(t.braking, mass), adhesion=adhesion,
                 regeneration=regen, traction_efficiency=t.traction_efficiency,
                 regeneration_efficiency=eta_r, curve_coefficient=t.curve_coefficient_m2ps2,
                 das_levels=tuple(t.das_handle_levels),
                 max_speed=float("inf") if t.max_speed_kmh is None else t.max_speed_kmh * units.KMH,
                 max_acceleration=t.max_acceleration_mps2 or float("inf"),
                 max_deceleration=t.max_deceleration_mps2 or float("inf"),
                 curve_resistance=t.curve_resistance,
                 traction_efficiency_map=_efficiency_map(t.traction_efficiency_map),
                 regeneration_efficiency_map=_efficiency_map(t.regenerative_braking.efficiency_map
                                                             if t.regenerative_braking else None),
                 tunnel_resistance=tuple((x.cross_section_m2, x.c_kN_per_kmh2 * units.KN / units.KMH**2)
                                         for x in t.tunnel_resistance),
                 calibration_reason=t.calibration.reason.strip() if t.calibration is not None else "",
                 # a TTOBench or OSRD file's own fields, in what the train says of itself
                 unpaired=unpaired(aliases, path) if aliases else Train.unpaired,
                 traction_field=traction_field(aliases) if aliases else Train.traction_field)


def track_from_schema(t: schemas.TrackFile) -> Track:
    curves = t.curves or [schemas.Curve(position_m=0, radius_m=None)]
    if curves[0].position_m > 0:  # straight before the first curve entry
        curves = [schemas.Curve(position_m=0, radius_m=None)] + list(curves)
    positions = np.array([c.position_m for c in curves], float)
    ends = np.append(positions[1:], t.length_m)
    start, end = np.array([c.curvatures() for c in curves], float).T
    slopes = (end - start) / np.maximum(ends - positions, 1e-9)  # clothoids: curvature linear in distance
    return Track(
        name=t.name, length=t.length_m, stops={s.name: s.position_m for s in t.stops},
        gradient_positions=np.array([g.position_m for g in t.gradients], float),
        gradients=np.array([g.gradient_permille for g in t.gradients], float) * units.PERMILLE,
        curve_positions=positions, curvatures=start,
        limit_positions=np.array([s.position_m for s in t.speed_limits], float),
        limits=np.array([s.speed_kmh for s in t.speed_limits], float) * units.KMH,
        curvature_slopes=slopes if np.any(slopes != 0) else None,
        tunnels=tuple((x.position_m, x.length_m, x.cross_section_m2) for x in t.tunnels))


def train_document(path: Where) -> tuple[dict[str, Any], dict[str, str] | None]:
    """(schema-shaped data, field aliases for messages) of a train file: YAML, or TTOBench/OSRD JSON.
    ``file.json#MODE`` (or ``#MODE/COMFORT``) picks an OSRD rolling stock's power mode."""
    check_path(path, "train")
    path, selector = split_selector(path)
    data = read_document(path)
    if Path(path).suffix.lower() == ".json":
        return train_document_to_schema(data, path, selector)
    if selector:
        raise InputError(problem(path, "", f"'#{selector}' picks a power mode of an OSRD rolling stock (.json)"))
    return data, None


def track_document(path: Where) -> dict[str, Any]:
    """Schema-shaped data of a track file: YAML, or TTOBench JSON."""
    check_path(path, "track")
    data = read_document(path)
    if Path(path).suffix.lower() == ".json":
        return track_document_to_schema(data, path)
    return data


def read_train(path: Where) -> tuple[dict[str, Any], Train]:
    """(document, :class:`Train`) of a train file (YAML, or TTOBench/OSRD JSON): its warnings, naming it."""
    data, aliases = train_document(path)
    return data, read_from(train_from_schema(validate(schemas.TrainFile, data, path, aliases), split_selector(path)[0],
                                              aliases), path)


def read_track(path: Where) -> tuple[dict[str, Any], Track]:
    """(document, :class:`Track`) of a track file (YAML, or TTOBench JSON); a line whose every limit is
    below 25 km/h is warned about (m/s given as km/h?)."""
    data = track_document(path)
    track = track_from_schema(validate(schemas.TrackFile, data, path,
                                       TRACK_ALIASES if Path(path).suffix.lower() == ".json" else None))
    if track.limits.max() < 25 * units.KMH and track.length > 2000:
        warnings.warn(problem(path, "speed_limits", f"every limit is below 25 km/h on a {track.length / 1000:.1f} km "
                              "line: check the unit (m/s given as km/h?)"), EcostudyWarning, stacklevel=2)
    return data, read_from(track, path)


def check_fits(path: Where, train: Train, track: Track, field: str | None = None) -> None:
    """Refuse a train longer than its track, naming the train's file and its length field (``field``: the length's
    own where a file names it otherwise), and a Roeckl train on too tight a curve, naming the track's file."""
    why = too_long(train, track)
    if why is not None:
        file = split_selector(path)[0]
        raise InputError(problem(file, field or ("length" if Path(file).suffix.lower() == ".json" else "length_m"), why))
    if (why := roeckl_out_of_range(train, track)) is not None:
        raise InputError(problem((source_file(track) or (f"track '{track.name}'",))[0], "curves", why))


def load_train(path: Where) -> Train:
    """A train file's :class:`Train` (:func:`read_train`)."""
    return read_train(path)[1]


def load_track(path: Where) -> Track:
    """A track file's :class:`Track` (:func:`read_track`)."""
    return read_track(path)[1]


def train_from_dict(data: Mapping[str, Any], where: str = "train (in code)") -> Train:
    """A :class:`Train` from the fields of a train file (units in the field names), validated and
    converted exactly as a file is; ``where`` names it in error messages."""
    return train_from_schema(validate(schemas.TrainFile, data, where), where)


def track_from_dict(data: Mapping[str, Any], where: str = "track (in code)") -> Track:
    """A :class:`Track` from the fields of a track file, validated and converted as a file is."""
    return track_from_schema(validate(schemas.TrackFile, data, where))


def read_timetable(path: Where) -> tuple[schemas.TimetableFile, dict[str, str]]:
    """(a timetable file, YAML or a TTOBench journey JSON; its fields as the file names them, for
    messages: :func:`~ecostudy.io.documents.aliased`, empty for YAML)."""
    data, aliases = read_document(path), dict[str, str]()
    if Path(path).suffix.lower() == ".json":
        data, aliases = timetable_document_to_schema(data, path)
    return validate(schemas.TimetableFile, data, path, aliases), aliases


def load_timetable(path: Where) -> schemas.TimetableFile:
    """Read a timetable file (YAML, or a TTOBench journey JSON)."""
    return read_timetable(path)[0]


# --------------------------------------------------------------------------- cross-file checks
def check_stops(track: Track, from_stop: str, to_stop: str, where: Where,
                fields: tuple[str, str] = ("from", "to")) -> None:
    """Both stops must be on the track and distinct (``fields``: how ``where`` names them, ``--from``...)."""
    lines: list[str] = []
    for field_name, stop in zip(fields, (from_stop, to_stop)):
        if stop not in track.stops:
            lines.append(problem(where, field_name, f"unknown stop '{stop}' (track '{track.name}' has: "
                                 + ", ".join(track.stops) + ")"))
    if not lines and track.stops[from_stop] == track.stops[to_stop]:
        lines.append(problem(where, fields[1], f"must differ from '{fields[0]}'"))
    if lines:
        raise InputError(lines)


def check_stop_list(track: Track, names: Sequence[str], where: Where, field: str) -> None:
    """A journey's stops in order: two or more, each a stop of the track by its exact name (an
    empty name is refused, never read as "all stops"), no stop straight after itself."""
    lines: list[str] = []
    for i, name in enumerate(names):
        if not name.strip():
            lines.append(problem(where, f"{field}[{i}]", "an empty stop name"))
        elif name not in track.stops:
            lines.append(problem(where, f"{field}[{i}]", f"unknown stop '{name}' (track '{track.name}' has: "
                                 + ", ".join(track.stops) + ")"))
        elif i and names[i - 1] in track.stops and track.stops[names[i - 1]] == track.stops[name]:
            lines.append(problem(where, f"{field}[{i}]", f"'{name}' straight after '{names[i - 1]}' (the same place): "
                                 "a segment needs two different stops"))
    if not lines and len(names) < 2:
        lines.append(problem(where, field, f"need two or more stops (track '{track.name}' has: "
                             + ", ".join(track.stops) + ")"))
    lines += [] if lines else [problem(where, field, back) for back in [turning_back(track, names)] if back]
    if lines:
        raise InputError(lines)


def chosen_stops(track: Track, from_stop: str | None, to_stop: str | None, where: Where,
                 fields: tuple[str, str] = ("from", "to")) -> tuple[str, str]:
    """(from, to): the stops asked for, the track's first and last where not, checked (:func:`check_stops`)."""
    names = list(track.stops)
    first = names[0] if from_stop is None else from_stop  # '' is a name given (and refused), not "default"
    last = names[-1] if to_stop is None else to_stop
    check_stops(track, first, last, where, fields)
    return first, last


def timing_from_timetable(tt: schemas.TimetableFile, from_stop: str, to_stop: str, path: Where,
                          dwell: float = 0.0) -> Timing:
    """The timing of one run between two stops of a timetable (:func:`~ecostudy.io.timetable.segment_timing`;
    ``dwell`` [s] at an intermediate stop that gives none), for callers that give it no timing
    windows (adjacent stops of a timetable without windows)."""
    return segment_timing(tt, from_stop, to_stop, path, dwell)[0]


def load_study(study_path: Where, read: Callable[..., Any] = lambda file, reader: reader(file)) -> "Study":
    """Read a study file and the files it names (relative to the study file), each by
    ``read(file, reader)`` (``reader``: :func:`read_track` or :func:`read_train`)."""
    path = Path(study_path)
    s = validate(schemas.StudyFile, read_document(path), path)
    if s.library is not None:
        raise InputError(problem(path, "library", "a library study runs with `ecostudy run`"))
    track_file, train_file = named_file(path, "track", given(s.track)), named_file(path, "train", given(s.train))
    (track_doc, track), (train_doc, train) = read(track_file, read_track), read(train_file, read_train)
    from_stop, to_stop = chosen_stops(track, s.from_stop, s.to_stop, path)
    if s.timetable is not None:
        timetable = named_file(path, "timetable", s.timetable)
        tt, _ = name_stops(load_timetable(timetable), track, timetable)
        timing, passing = segment_timing(tt, from_stop, to_stop, timetable)
        timed = windows_from_schema(passing, track, from_stop, to_stop, timetable)
    else:
        timed, timetable = (), None
        timing = Timing(running_time=s.running_time_s,
                        supplement=None if s.supplement_percent is None else s.supplement_percent * units.PERCENT,
                        window=s.window_s)
    timing_field = "timetable" if s.timetable is not None else next(
        (name for name in ("running_time_s", "supplement_percent", "window_s") if getattr(s, name) is not None),
        "running_time_s")
    output = Path(s.output) if s.output else default_output(s.name)
    weights = (s.weights.time, s.weights.energy) if "weights" in s.model_fields_set else None  # None: not given
    return Study(name=s.name, track=track, train=train, from_stop=from_stop, to_stop=to_stop, timing=timing,
                 objective=s.objective, weights=weights, points=s.points, output=output, track_path=track_file, train_path=train_file,
                 windows=windows_from_schema(s.windows, track, from_stop, to_stop, path) + timed, timing_field=timing_field,
                 documents=(train_doc, track_doc), timetable_path=timetable, timetable_windows=len(timed))


@dataclass
class NetworkStudy:
    """A network study in SI units (`ecostudy network`)."""

    name: str
    track: Track
    train: Train
    stops: list[str]
    running_times: list[float] | None  # [s] per segment, or None with ``supplement``
    supplement: float | None        # [-] per segment over its all-out time
    dwell: float                    # [s]
    dt: float                       # [s]
    names: list[str]
    offsets: list[float]            # [s]
    supply: Supply
    strategies: list[str]
    buffer: float | None            # [m]
    points: int
    output: Path
    documents: tuple[Mapping[str, Any], ...] = ()  # (train, track) as their files give them


def load_network_study(study_path: Where) -> NetworkStudy:
    """Read a network study file and the files it names; units converted here."""
    path = Path(study_path)
    s = validate(schemas.NetworkStudyFile, read_document(path), path)
    off_clock(path, s.time_step_s, [(f"trains[{i}].offset_s", t.offset_s) for i, t in enumerate(s.trains)]
              + [("dwell_s", s.dwell_s)])
    (track_doc, track), (train_doc, train) = (read_track(named_file(path, "track", s.track)),
                                              read_train(named_file(path, "train", s.train)))
    check_fits(named_file(path, "train", s.train), train, track)
    stops = list(track.stops) if s.stops is None else s.stops
    check_stop_list(track, stops, path, "stops")
    if s.running_times_s is not None and len(s.running_times_s) != len(stops) - 1:
        raise InputError(problem(path, "running_times_s", f"need {len(stops) - 1} values, one per segment"))
    sub = s.substation
    if not 0 <= sub.position_m <= track.length:
        raise InputError(problem(path, "substation.position_m", f"{sub.position_m:g} m is off the line (0 to {track.length:g} m)"))
    supply = Supply(position=sub.position_m, voltage=sub.voltage_V, resistance=sub.internal_resistance_ohm,
                    line_resistance=sub.line_resistance_ohm_per_km / 1000.0,
                    max_voltage=sub.max_voltage_V or sub.voltage_V * 685 / 600,
                    min_voltage=sub.min_voltage_V or sub.voltage_V * 2 / 3,
                    max_current=sub.max_train_current_A or float("inf"),
                    max_regen_current=sub.max_regen_current_A or float("inf"))
    return NetworkStudy(s.name, track, train, stops, s.running_times_s,
                        None if s.supplement_percent is None else s.supplement_percent * units.PERCENT,
                        s.dwell_s, s.time_step_s, [t.name for t in s.trains], [t.offset_s for t in s.trains],
                        supply, list(s.strategies), s.buffer_m, s.points,
                        Path(s.output) if s.output else default_output(s.name), (train_doc, track_doc))


__all__ = ["Train", "Track", "Timing", "Study", "load_train", "load_track", "load_study", "read_train", "read_track",
           "load_timetable", "read_timetable", "check_stops", "check_stop_list"]
