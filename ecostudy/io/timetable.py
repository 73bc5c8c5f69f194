"""A journey's timing requirements on one clock: stops, dwells, arrival windows, passing points.

A timetable names its stops or gives their positions (the TTOBench journey format does the
latter); :func:`name_stops` puts the track's names on them. :func:`journey_plan` turns a timetable
with windows into a :class:`JourneyPlan` in SI, the passing points assigned to the segment they
lie on. Times are on the journey clock (0 at the first departure), as TTOBench counts them.
"""
import math
from dataclasses import dataclass, replace
from os import PathLike
from typing import Mapping, Sequence, TypeAlias

from ecostudy.core import units
from ecostudy.core.errors import InputError, problem
from ecostudy.core.grid import travel_distance
from ecostudy.core.types import Timing, Track, Window
from ecostudy.io import schemas
from ecostudy.io.documents import aliased

Where: TypeAlias = str | PathLike[str]
Bounds: TypeAlias = tuple[float | None, float | None]  # (earliest, latest) [s], None where open

POSITION_TOLERANCE = 1.0  # [m] a timetable position within this of a track stop is that stop
# [-] of a clock step: a time this near a whole number of steps is on the clock (0.1 s and the
# like are not exact in binary: 48 s / 0.4 s is 120.00000000000001)
CLOCK_TOLERANCE = 1e-6


def name_stops(tt: schemas.TimetableFile, track: Track, path: Where,
               aliases: Mapping[str, str] | None = None) -> tuple[schemas.TimetableFile, Track]:
    """(``tt`` with every stop given by position named after the track's stop there, the track).

    A position that is no stop of the track becomes one (named ``at_<position>m``), so a journey
    may stop anywhere (TTOBench journeys do): the returned track has it among its stops. Stops that
    turn back (:func:`turning_back`) are refused, each field named as the file names it (``aliases``:
    :func:`~ecostudy.io.loaders.read_timetable`).
    """
    aliases = aliases or {}
    rows: list[schemas.TimetableStop] = []
    lines: list[str] = []
    added: dict[str, float] = {}
    for i, row in enumerate(tt.stops):
        if row.stop is not None:
            if row.stop not in track.stops:
                lines.append(problem(path, aliased(f"stops[{i}].stop", aliases),
                                     f"'{row.stop}' is not a stop of track '{track.name}' "
                                     f"({', '.join(track.stops)})"))
            rows.append(row)
            continue
        position = row.position_m if row.position_m is not None else float("nan")  # not None: the schema says
        if not 0 <= position <= track.length:
            lines.append(problem(path, aliased(f"stops[{i}].position_m", aliases), f"{position:g} m is not on track "
                                 f"'{track.name}' (0 to {track.length:g} m)"))
            continue
        near = [n for n, x in {**track.stops, **added}.items() if abs(x - position) <= POSITION_TOLERANCE]
        name = near[0] if near else f"at_{position:g}m"
        added.setdefault(name, position) if not near else None
        rows.append(row.model_copy(update={"stop": name, "position_m": None}))
    if lines:
        raise InputError(lines)
    if added:
        stops = dict(sorted({**track.stops, **added}.items(), key=lambda kv: kv[1]))
        track = replace(track, stops=stops)
    back = turning_back(track, [str(row.stop) for row in rows])
    if back is not None:
        raise InputError(problem(path, aliased("stops", aliases), back))
    return tt.model_copy(update={"stops": rows}), track


def turning_back(track: Track, names: Sequence[str]) -> str | None:
    """What is wrong with the first stop of ``names`` (known stops of ``track``, in journey order) that
    lies back the way the journey came, or None: a journey runs one way along the track."""
    x = [track.stops[n] for n in names]
    for i in range(2, len(x)):
        if (x[i] - x[i - 1]) * (x[i - 1] - x[i - 2]) < 0:
            return (f"'{names[i]}' lies back toward '{names[i - 2]}' after '{names[i - 1]}': a journey runs one way "
                    "along the track (list its stops in track order, either way)")
    return None


@dataclass(frozen=True)
class JourneyPlan:
    """Stops served and what the clock requires of them; windows per segment (SI, journey clock).

    ``arrival[n]``: (earliest, latest) arrival at the end of segment n, None where open.
    ``departure[n]``: departure window (earliest, latest) from the start of segment n (equal for a
    fixed time, either None where open), or None: arrival + dwell.
    ``dwell[n]``: (least) dwell before segment n departs (0 for the first).
    ``windows[n]``: core.types.Window passing points of segment n, distance from its departure stop;
    ``window_rows[n]``: the index of each in the timetable's ``windows`` (its field, for messages).
    """

    stops: tuple[str, ...]
    departure: tuple[Bounds | None, ...]
    dwell: tuple[float, ...]
    arrival: tuple[Bounds, ...]
    windows: tuple[tuple[Window, ...], ...]
    window_rows: tuple[tuple[int, ...], ...] = ()


def journey_plan(tt: schemas.TimetableFile, track: Track, path: Where, dwell: float = 0.0,
                 aliases: Mapping[str, str] | None = None) -> JourneyPlan:
    """The :class:`JourneyPlan` of a named timetable ``tt``; ``dwell`` [s] where a stop gives none;
    a refusal names its field as the file does (``aliases``, as :func:`name_stops`)."""
    names = [str(row.stop) for row in tt.stops]
    lines: list[str] = []
    aliases = aliases or {}
    if len(names) < 2:
        lines.append(problem(path, aliased("stops", aliases), "need at least two stops"))
    for i, (a, b) in enumerate(zip(names, names[1:])):
        if track.stops[a] == track.stops[b]:
            lines.append(problem(path, aliased(f"stops[{i + 1}]", aliases), f"'{b}' is where the journey already is"))
    if lines:
        raise InputError(lines)
    first = tt.stops[0]
    ready = (first.arrival_s or 0.0) + (first.dwell_s or 0.0)  # as segment_timing reads the first stop
    departure: list[Bounds | None] = [_departure(first) or (ready, ready)]
    dwells: list[float] = [0.0]
    arrival: list[Bounds] = []
    for row in tt.stops[1:]:
        if row.arrival_s is not None:
            arrival.append((row.arrival_s, row.arrival_s))
        else:
            arrival.append((row.earliest_s, row.latest_s))
    for row in tt.stops[1:-1]:
        departure.append(_departure(row))
        dwells.append(row.dwell_s if row.dwell_s is not None else dwell)
    windows: list[list[tuple[Window, int]]] = [[] for _ in names[1:]]
    for i, w in enumerate(tt.windows):
        for n, (a, b) in enumerate(zip(names, names[1:])):
            d = travel_distance(track, a, b, w.position_m)
            if 0 < d < abs(track.stops[b] - track.stops[a]):
                windows[n].append((window_si(w, d), i))
                break
        else:
            lines.append(problem(path, aliased(f"windows[{i}].position_m", aliases),
                                 f"{w.position_m:g} m is not strictly between "
                                 "two consecutive stops of the journey"))
    if lines:
        raise InputError(lines)
    ordered = [sorted(w, key=lambda x: x[0].distance) for w in windows]
    return JourneyPlan(tuple(names), tuple(departure), tuple(dwells), tuple(arrival),
                       tuple(tuple(w for w, _ in ws) for ws in ordered), tuple(tuple(i for _, i in ws) for ws in ordered))


def _departure(row: schemas.TimetableStop) -> Bounds | None:
    """A timetable stop's departure as (earliest, latest), or None when it gives none."""
    if row.departure_s is not None:
        return (row.departure_s, row.departure_s)
    if row.departure_earliest_s is None and row.departure_latest_s is None:
        return None
    return (row.departure_earliest_s, row.departure_latest_s)


def schedule(plan: JourneyPlan, running_times: Sequence[float]) -> tuple[list[float], list[float]]:
    """Departure and arrival times [s] per segment on the journey clock for ``running_times``:
    each departure as early as its window and the previous arrival plus the dwell allow."""
    dep: list[float] = []
    arr: list[float] = []
    clock = 0.0
    for n, t in enumerate(running_times):
        window = plan.departure[n]
        ready = clock + plan.dwell[n] if n else 0.0
        clock = ready if window is None else max(ready, window[0] or 0.0)
        dep.append(clock)
        clock += t
        arr.append(clock)
    return dep, arr


def window_si(w: schemas.Window, distance: float) -> Window:
    """A schema window as an SI :class:`Window` at ``distance`` [m] from its departure stop."""
    return Window(distance, w.earliest_s, w.latest_s,
                  None if w.min_speed_kmh is None else w.min_speed_kmh * units.KMH,
                  None if w.max_speed_kmh is None else w.max_speed_kmh * units.KMH)


def windows_from_schema(windows: Sequence[schemas.Window], track: Track, from_stop: str, to_stop: str,
                        where: Where) -> tuple[Window, ...]:
    """Windows in SI and travel distance; each must lie strictly between the two stops."""
    out: list[Window] = []
    lines: list[str] = []
    length = abs(track.stops[to_stop] - track.stops[from_stop])
    for i, w in enumerate(windows):
        d = travel_distance(track, from_stop, to_stop, w.position_m)
        if not 0 < d < length:
            lines.append(problem(where, f"windows[{i}].position_m", f"{w.position_m} m is not between "
                                 f"'{from_stop}' and '{to_stop}'"))
            continue
        out.append(window_si(w, d))
    if lines:
        raise InputError(lines)
    return tuple(out)


def clock_steps(seconds: float, dt: float) -> int | None:
    """``seconds`` as a whole number of clock steps ``dt`` [s]; None where it falls between two."""
    steps = seconds / dt
    return round(steps) if abs(steps - round(steps)) <= CLOCK_TOLERANCE else None


def off_clock(path: Where, dt: float, times: Sequence[tuple[str, float]]) -> None:
    """Refuse every time (field, [s]) of a study on a clock of step ``dt`` [s] (``time_step_s``) that
    falls between two steps, naming the two nearest times on the clock: the clock cannot honour it,
    and moving a departure or a dwell to a step would run another timetable than the one written."""
    def said(x: float) -> str:
        return f"{round(x, 9):.12g}"  # 48.400000000000006 as 48.4, 86399.65 in full

    lines = []
    for name, seconds in times:
        if clock_steps(seconds, dt) is None:
            below, above = (said(n * dt) for n in (math.floor(seconds / dt), math.ceil(seconds / dt)))
            lines.append(problem(path, name, f"{said(seconds)} s is not on the {said(dt)} s clock (time_step_s): "
                                 f"give {below} or {above}"))
    if lines:
        raise InputError(lines)


def segment_timing(tt: schemas.TimetableFile, from_stop: str, to_stop: str,
                   path: Where, dwell: float = 0.0) -> tuple[Timing, list[schemas.Window]]:
    """(the timing of one run from ``from_stop`` to ``to_stop`` of a timetable, its passing windows
    with times since that run's departure). The running time is the arrival at ``to`` less the
    departure at ``from`` (arrival plus dwell; ``dwell`` [s] at a stop after the first that gives
    none, as :func:`journey_plan` reads it); an arrival window (``earliest_s`` and ``latest_s``)
    is the run's window. Refused in one line each: a stop of the timetable between the two (one run
    does not stop on the way), a departure window (one run departs at a fixed time)."""
    if tt.supplement_percent is not None:
        return Timing(supplement=tt.supplement_percent * units.PERCENT), []
    index = {r.stop: i for i, r in enumerate(tt.stops)}
    lines = [problem(path, "stops", f"stop '{s}' is not in the timetable") for s in (from_stop, to_stop) if s not in index]
    if lines:
        raise InputError(lines)
    i, j = index[from_stop], index[to_stop]
    start, end = tt.stops[i], tt.stops[j]
    if j > i + 1:
        raise InputError(problem(path, f"stops[{i + 1}]", f"'{tt.stops[i + 1].stop}' is a stop between '{from_stop}' "
                                 f"and '{to_stop}' ({j - i - 1} in all): one run does not stop on the way; "
                                 "`ecostudy journey --timetable` runs each segment"))
    if start.departure_earliest_s is not None or start.departure_latest_s is not None:
        raise InputError(problem(path, f"stops[{i}]", f"a departure window at '{from_stop}': one run departs at a "
                                 "fixed time (departure_s); `ecostudy journey --timetable` plans departure windows"))
    dep = start.departure_s
    if dep is None and start.arrival_s is not None:
        dep = start.arrival_s + (start.dwell_s if start.dwell_s is not None else dwell if i > 0 else 0.0)
    need = problem(path, "stops", f"need a departure at '{from_stop}' and an arrival at '{to_stop}' (arrival_s, or "
                   "the window earliest_s and latest_s)")
    if dep is None:
        raise InputError(need)
    if end.arrival_s is not None:
        timing, arr = Timing(running_time=end.arrival_s - dep), end.arrival_s
    elif end.earliest_s is not None and end.latest_s is not None:
        timing, arr = Timing(window=(end.earliest_s - dep, end.latest_s - dep)), end.earliest_s
    else:
        raise InputError(need)
    if arr <= dep:
        raise InputError(problem(path, "stops", f"arrival at '{to_stop}' ({arr} s) is not after departure ({dep} s)"))
    since = [w.model_copy(update={k: getattr(w, k) - dep for k in ("earliest_s", "latest_s") if getattr(w, k) is not None})
             for w in tt.windows]
    return timing, since


def window_origin(field: str, study: Where, timetable: Where | None, own: int) -> tuple[Where, str]:
    """(file, field) of ``windows[i]...`` as its file writes it: the study file ``study``'s (its ``own``
    windows come first), or the ``timetable``'s for one of its windows; of two windows in two files
    (``windows[i].x, windows[j].y``), the study's, the other named with its file."""
    named = []
    for part in field.split(", "):
        i = int(part.split("[", 1)[1].split("]", 1)[0]) if part.startswith("windows[") else -1
        named.append((study, part) if timetable is None or i < own else
                     (timetable, part.replace(f"windows[{i}]", f"windows[{i - own}]", 1)))
    one = len({str(file) for file, _ in named}) == 1
    return (named[0][0] if one else study), ", ".join(part if one or file == study else f"{file}: {part}"
                                                      for file, part in named)
