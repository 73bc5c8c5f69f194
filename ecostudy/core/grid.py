"""The segment between two stops, in travel distance x in [0, D], and its distance grid.

Profiles are piecewise constant: a value holds from its start position to the next one.
Grid nodes sit on every gradient, curve and (train-length) speed-limit change, because a
change that falls between nodes costs accuracy; the remaining nodes fill the pieces in
proportion to their length, at least :data:`MIN_INTERVALS` intervals each.
"""
import warnings
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.physics import ROECKL_MIN_RADIUS
from ecostudy.core.types import Track, Train, source_file
from ecostudy.core.units import FloatArray, Numeric


MIN_INTERVALS = 2  # the fewest intervals a piece between two changes gets (see make_grid)


@dataclass(frozen=True)
class Profile:
    """Piecewise function of travel distance: ``values[i] + slopes[i] (x - starts[i])`` on
    ``[starts[i], starts[i+1])``; piecewise constant when ``slopes`` is None (clothoids are the
    linear pieces: curvature varying linearly with distance)."""

    starts: np.ndarray
    values: np.ndarray
    slopes: np.ndarray | None = None

    def __call__(self, x: Numeric) -> Numeric:
        i = np.clip(np.searchsorted(self.starts, x, side="right") - 1, 0, len(self.values) - 1)
        if self.slopes is None:
            return self.values[i]
        return self.values[i] + self.slopes[i] * (np.asarray(x, float) - self.starts[i])

    def integral(self, x: Numeric) -> Numeric:
        """The integral of the profile from ``starts[0]`` to ``x`` (the first piece extends below it,
        the last beyond its start)."""
        slopes = np.zeros(len(self.values)) if self.slopes is None else self.slopes
        widths = np.diff(self.starts)
        pieces = np.concatenate([[0.0], np.cumsum(self.values[:-1] * widths + 0.5 * slopes[:-1] * widths ** 2)])
        i = np.clip(np.searchsorted(self.starts, x, side="right") - 1, 0, len(self.values) - 1)
        h = np.asarray(x, float) - self.starts[i]
        return pieces[i] + self.values[i] * h + 0.5 * slopes[i] * h * h

    def mean_over(self, centre: Numeric, length: Numeric) -> Numeric:
        """The mean of the profile over ``[centre - length/2, centre + length/2]`` (a car's length):
        continuous in ``centre`` where the profile jumps."""
        half = 0.5 * np.asarray(length, float)
        return (self.integral(centre + half) - self.integral(centre - half)) / (2.0 * half)


def _directed(positions: Sequence[float] | FloatArray, values: Sequence[float] | FloatArray, start: float, end: float,
              slopes: FloatArray | None = None) -> Profile:
    """Profile of a track quantity as seen by a train running from ``start`` to ``end``.

    Returns travel-distance starts and values; for a train running towards decreasing
    positions the order is mirrored (the caller flips the sign of gradients).
    """
    positions, values = np.asarray(positions, float), np.asarray(values, float)
    lo, hi = min(start, end), max(start, end)
    idx = int(np.searchsorted(positions, lo, side="right")) - 1
    keep = [max(idx, 0)] + [i for i in range(len(positions)) if lo < positions[i] < hi]
    pos = np.array([lo] + [positions[i] for i in keep[1:]])
    slope = None if slopes is None else np.asarray(slopes, float)[keep]
    val = values[keep] if slope is None else values[keep] + slope * (pos - positions[keep])
    if end >= start:
        return Profile(pos - lo, val, slope)
    # running backwards: piece [p_i, p_{i+1}) is met at distance hi - p_{i+1}
    ends = np.append(pos[1:], hi)
    if slope is None:
        return Profile((hi - ends)[::-1], val[::-1])
    return Profile((hi - ends)[::-1], (val + slope * (ends - pos))[::-1], -slope[::-1])


def tunnel_profile(track: Track, train: Train, start: float, end: float) -> Profile:
    """Extra quadratic resistance C [N s^2/m^2] along the run: the train's coefficient for each
    tunnel's cross section inside the tunnel, 0 outside (TTOBench ``tunnels``, ``tunnel resistance``)."""
    edges: list[float] = [0.0]
    extra: list[float] = [0.0]
    for pos, length, area in sorted(track.tunnels):
        if edges[-1] == pos:  # starts where the last one ends (or at 0): no straight piece between
            edges.pop(), extra.pop()
        edges += [pos, pos + length]
        extra += [train.tunnel_coefficient(area), 0.0]
    return _directed(np.array(edges), np.array(extra), start, end)


def train_length_limit(limit: Profile, length: float) -> Profile:
    """Speed limit for the train's head: min of the limit over the train, [x - L, x].

    A train may speed up only when its tail has left a restriction; before the start the
    limit at the start is assumed.
    """
    candidates = np.unique(np.concatenate([limit.starts, limit.starts + length]))
    values = []
    for a, b in zip(candidates, np.append(candidates[1:], np.inf)):
        x = a if np.isinf(b) else 0.5 * (a + b)
        lo = x - length
        inside = (limit.starts <= x) & (np.append(limit.starts[1:], np.inf) > lo)
        values.append(limit.values[inside].min())
    lowest = np.array(values)
    keep = np.concatenate([[True], lowest[1:] != lowest[:-1]])
    return Profile(candidates[keep], lowest[keep])


@dataclass(frozen=True)
class Segment:
    """Everything the formulation and the simulator need about one run, in SI units."""

    distance: float       # D [m]
    gradient: Profile     # tan(alpha), positive uphill in the travel direction
    curvature: Profile    # [1/m]
    limit: Profile        # train-length speed limit for the head [m/s]
    from_stop: str = ""
    to_stop: str = ""
    tunnel: Profile = Profile(np.zeros(1), np.zeros(1))  # extra quadratic resistance C [N s^2/m^2]

    def breakpoints(self) -> FloatArray:
        pts = np.concatenate([self.gradient.starts, self.curvature.starts, self.limit.starts, self.tunnel.starts])
        return np.unique(pts[(pts > 0) & (pts < self.distance)])


def warn_unmodelled(segment: Segment, formulation: str, train: Train | None = None) -> None:
    """One warning when ``formulation`` leaves out the tunnel resistance of ``segment`` or the
    ``train``'s efficiency maps (it then uses the constant efficiencies)."""
    if np.any(segment.tunnel.values != 0):
        warnings.warn(f"{formulation} does not model the tunnel resistance ('tunnel resistance' on "
                      f"'{segment.from_stop}'-'{segment.to_stop}'): tunnels cost nothing there",
                      EcostudyWarning, stacklevel=3)
    if train is not None and (train.traction_efficiency_map or train.regeneration_efficiency_map):
        warnings.warn(f"{formulation} does not model efficiency maps: it uses the constant efficiencies "
                      f"({train.traction_efficiency:g}, {train.regeneration_efficiency:g})", EcostudyWarning,
                      stacklevel=3)


def admissible_speeds(segment: Segment, count: int = 101) -> FloatArray:
    """Every speed the train may run on ``segment`` [m/s], sampled: 0 up to its highest limit
    (the train's top speed caps the limits already) in ``count`` steps."""
    x = np.unique(np.concatenate([np.linspace(0.0, segment.distance, 1001), segment.breakpoints()]))
    return np.linspace(0.0, float(np.max(node_limits(segment, x))), count)


def drop_idle_power(segment: Segment, train: Train, formulation: str) -> tuple[Train, tuple[str, ...]]:
    """(``train`` without the power limits that never bind on ``segment``, the names of the
    envelopes whose limit was dropped), with one warning saying so: a limit with P >= F_max(v) v
    at every admissible speed (``physics.power_never_binds``) is no row of ``formulation``."""
    lean, idle = train.without_idle_power(admissible_speeds(segment))
    if idle:
        warnings.warn(f"{formulation}: {', '.join(idle)} power limit never binds: dropped (P >= F_max(v) v at "
                      f"every admissible speed on '{segment.from_stop}'-'{segment.to_stop}')", EcostudyWarning,
                      stacklevel=3)
    return lean, idle


def travel_distance(track: Track, from_stop: str, to_stop: str, position: Numeric) -> Numeric:
    """Distance from ``from_stop`` of a track position, in the direction of travel [m]."""
    start, end = track.stops[from_stop], track.stops[to_stop]
    return position - start if end >= start else start - position


_WARNED: set[tuple[str, str, str]] = set()


def warn_unpaired(track: Track, train: Train) -> None:
    """Once per track and train: curves or tunnels on the track that the train gives no resistance for."""
    lines = []
    if np.any(track.curvatures != 0) and train.curve_resistance == "coefficient" and train.curve_coefficient == 0:
        lines.append(f"curves cost nothing: {train.unpaired[0]}")
    if track.tunnels and not train.tunnel_resistance:
        lines.append(f"tunnels cost nothing: {train.unpaired[1]}")
    lines = [f"track '{track.name}' with train '{train.name}': {line}" for line in lines] + tunnels_outside(track, train)
    for line in lines:
        if (track.name, train.name, line) not in _WARNED:
            _WARNED.add((track.name, train.name, line))
            warnings.warn(line, EcostudyWarning, stacklevel=3)


def tunnels_outside(track: Track, train: Train) -> list[str]:
    """One line per tunnel of ``track`` whose cross section lies outside the sections of ``train``'s
    ``tunnel_resistance`` (:meth:`Train.tunnel_coefficient` holds the nearest end's coefficient there),
    naming the track's file and the tunnel's position."""
    if not train.tunnel_resistance:
        return []
    areas = [area for area, _ in train.tunnel_resistance]
    lo, hi = min(areas), max(areas)
    where = (source_file(track) or (f"track '{track.name}'",))[0]
    listed = f"{lo:g} m²" if lo == hi else f"{lo:g} to {hi:g} m²"
    return [problem(where, "tunnels", f"the tunnel at {pos:g} m has a cross section of {area:g} m², outside the "
                    f"{listed} train '{train.name}' gives a tunnel_resistance for: costed as {lo if area < lo else hi:g} m²")
            for pos, _, area in track.tunnels if not lo <= area <= hi]


def too_long(train: Train, track: Track) -> str | None:
    """Why the train cannot run on the track (its length is longer than the track), else None: the
    one check of it, for every file read (:func:`ecostudy.io.loaders.check_fits` names the file and
    its field), every case a study expands and every segment cut."""
    if train.length > track.length:
        return f"{train.length:g} m is longer than the track '{track.name}' ({track.length:g} m)"
    return None


def roeckl_out_of_range(train: Train, track: Track) -> str | None:
    """Why the train's curve resistance cannot be had on the track (a Roeckl train, a curve tighter
    than :data:`~ecostudy.core.physics.ROECKL_MIN_RADIUS`, at either end of a clothoid), else None:
    checked with :func:`too_long`, named as it is."""
    if train.curve_resistance != "roeckl":
        return None
    ends = np.append(track.curve_positions[1:], track.length) - track.curve_positions
    last = track.curvatures + (0.0 if track.curvature_slopes is None else track.curvature_slopes * ends)
    k = np.maximum(np.abs(track.curvatures), np.abs(last))
    tight = np.flatnonzero(k * ROECKL_MIN_RADIUS > 1 + 1e-9)
    if not tight.size:
        return None
    i = int(tight[0])
    return (f"the curve at {track.curve_positions[i]:g} m has a radius of {1 / k[i]:g} m, below the "
            f"{ROECKL_MIN_RADIUS:g} m from which Roeckl's formula (train '{train.name}''s curve resistance, as ms-eetc "
            "uses it) is used: ms-eetc refuses such a track, and below 55 m the formula has no value")


def too_long_named(train: Train, track: Track) -> str | None:
    """:func:`too_long` naming the train and its field, where its file is not known here."""
    why = too_long(train, track)
    return None if why is None else f"train '{train.name}': length_m: {why}"


def head_limit(track: Track, train: Train, start: float, end: float) -> Profile:
    """The head's speed limit from ``start`` to ``end`` [m]: :func:`train_length_limit` of the line's
    limits, capped by the train's top speed, seen from as far behind the start as the train is
    long (where the track goes on there): standing at an intermediate stop its body lies over the
    track behind, and a restriction there holds until its tail has left it."""
    sign = 1.0 if end >= start else -1.0
    behind = min(train.length, start if sign > 0 else track.length - start)
    line = _directed(track.limit_positions, track.limits, start - sign * behind, end)
    line = Profile(line.starts, np.minimum(line.values, train.max_speed))  # the train's top speed caps the line's
    whole = train_length_limit(line, train.length)
    first = int(np.searchsorted(whole.starts, behind, side="right")) - 1  # the piece the start lies in
    return Profile(np.concatenate([[0.0], whole.starts[first + 1:] - behind]), whole.values[first:])


def make_segment(track: Track, train: Train, from_stop: str, to_stop: str) -> Segment:
    """Cut the track between two stops into travel-direction profiles."""
    warn_unpaired(track, train)
    start, end = track.stops[from_stop], track.stops[to_stop]
    why = too_long_named(train, track)
    if why is not None:
        raise InputError(why)
    why = roeckl_out_of_range(train, track)
    if why is not None:
        raise InputError(problem(f"track '{track.name}'", "curves", why))
    sign = 1.0 if end >= start else -1.0
    gradient = _directed(track.gradient_positions, track.gradients, start, end)
    gradient = Profile(gradient.starts, sign * gradient.values)
    curvature = _directed(track.curve_positions, track.curvatures, start, end, track.curvature_slopes)
    limit = head_limit(track, train, start, end)
    return Segment(abs(end - start), gradient, curvature, limit, from_stop, to_stop,
                   tunnel_profile(track, train, start, end))


def make_grid(segment: Segment, points: int, extra: Sequence[float] | FloatArray = ()) -> FloatArray:
    """``points`` node positions on [0, D], including every profile change and ``extra`` positions.

    The intervals between changes get a share of the nodes proportional to their length, at
    least :data:`MIN_INTERVALS` each (fewer only where ``points`` cannot give every piece as many;
    the intervals a short piece needs are taken from the longest pieces), and are divided uniformly.
    """
    inner = np.unique(np.concatenate([segment.breakpoints(), np.asarray(extra, dtype=float)]))
    inner = inner[(inner > 0) & (inner < segment.distance)]
    breaks = np.concatenate([[0.0], inner, [segment.distance]])
    lengths = np.diff(breaks)
    intervals = max(points - 1, len(lengths))
    least = max(1, min(MIN_INTERVALS, intervals // len(lengths)))
    share = np.maximum(least, np.floor(lengths / segment.distance * intervals).astype(int))
    while share.sum() > intervals:  # a short piece's minimum, taken from the longest pieces
        share[np.argmax(np.where(share > least, lengths, -1.0))] -= 1
    while share.sum() < intervals:  # hand out the remainder to the coarsest pieces
        share[np.argmax(lengths / share)] += 1
    nodes = [np.linspace(a, b, n + 1)[:-1] for a, b, n in zip(breaks[:-1], breaks[1:], share)]
    return np.append(np.concatenate(nodes), segment.distance)


def intervals_of(nodes: FloatArray, x: Numeric) -> Any:
    """Index of the grid interval holding each position of ``x`` (the first or last one beyond the
    ends); an array for an array."""
    return np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, len(nodes) - 2)


def interval_of(nodes: FloatArray, x: float) -> int:
    """Index of the grid interval holding position ``x`` (:func:`intervals_of` of one position)."""
    return int(intervals_of(nodes, x))


def node_limits(segment: Segment, nodes: FloatArray) -> FloatArray:
    """Speed limit at each node: the lower of the limits on its two sides [m/s]."""
    left = segment.limit(np.maximum(nodes - 1e-9, 0.0))
    right = segment.limit(nodes)
    return np.asarray(np.minimum(left, right), float)
