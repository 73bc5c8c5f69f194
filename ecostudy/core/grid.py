"""The segment between two stops, in travel distance x in [0, D], and its distance grid.

Profiles are piecewise constant: a value holds from its start position to the next one.
Grid nodes sit on every gradient, curve and (train-length) speed-limit change, because a
change that falls between nodes costs accuracy; the remaining nodes fill the pieces in
proportion to their length.
"""
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Profile:
    """Piecewise-constant function of travel distance: ``values[i]`` on ``[starts[i], starts[i+1])``."""

    starts: np.ndarray
    values: np.ndarray

    def __call__(self, x):
        i = np.searchsorted(self.starts, x, side="right") - 1
        return self.values[np.clip(i, 0, len(self.values) - 1)]


def _directed(positions, values, start, end):
    """Profile of a track quantity as seen by a train running from ``start`` to ``end``.

    Returns travel-distance starts and values; for a train running towards decreasing
    positions the order is mirrored (the caller flips the sign of gradients).
    """
    positions = np.asarray(positions, float)
    values = np.asarray(values, float)
    lo, hi = min(start, end), max(start, end)
    idx = np.searchsorted(positions, lo, side="right") - 1
    keep = [max(idx, 0)] + [i for i in range(len(positions)) if lo < positions[i] < hi]
    pos = np.array([lo] + [positions[i] for i in keep[1:]])
    val = values[keep]
    if end >= start:
        return Profile(pos - lo, val)
    # running backwards: piece [p_i, p_{i+1}) is met at distance hi - p_{i+1}
    ends = np.append(pos[1:], hi)
    return Profile((hi - ends)[::-1], val[::-1])


def train_length_limit(limit, length):
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
    values = np.array(values)
    keep = np.concatenate([[True], values[1:] != values[:-1]])
    return Profile(candidates[keep], values[keep])


@dataclass(frozen=True)
class Segment:
    """Everything the formulation and the simulator need about one run, in SI units."""

    distance: float       # D [m]
    gradient: Profile     # tan(alpha), positive uphill in the travel direction
    curvature: Profile    # [1/m]
    limit: Profile        # train-length speed limit for the head [m/s]
    from_stop: str = ""
    to_stop: str = ""

    def breakpoints(self):
        pts = np.concatenate([self.gradient.starts, self.curvature.starts, self.limit.starts])
        return np.unique(pts[(pts > 0) & (pts < self.distance)])


def travel_distance(track, from_stop, to_stop, position):
    """Distance from ``from_stop`` of a track position, in the direction of travel [m]."""
    start, end = track.stops[from_stop], track.stops[to_stop]
    return position - start if end >= start else start - position


def make_segment(track, train, from_stop, to_stop):
    """Cut the track between two stops into travel-direction profiles."""
    start, end = track.stops[from_stop], track.stops[to_stop]
    sign = 1.0 if end >= start else -1.0
    gradient = _directed(track.gradient_positions, track.gradients, start, end)
    gradient = Profile(gradient.starts, sign * gradient.values)
    curvature = _directed(track.curve_positions, track.curvatures, start, end)
    line = _directed(track.limit_positions, track.limits, start, end)
    line = Profile(line.starts, np.minimum(line.values, train.max_speed))  # the train's top speed caps the line's
    limit = train_length_limit(line, train.length)
    return Segment(abs(end - start), gradient, curvature, limit, from_stop, to_stop)


def make_grid(segment, points, extra=()):
    """``points`` node positions on [0, D], including every profile change and ``extra`` positions.

    The intervals between changes get a share of the nodes proportional to their length
    (at least one interval each) and are divided uniformly.
    """
    inner = np.unique(np.concatenate([segment.breakpoints(), np.asarray(extra, dtype=float)]))
    inner = inner[(inner > 0) & (inner < segment.distance)]
    breaks = np.concatenate([[0.0], inner, [segment.distance]])
    lengths = np.diff(breaks)
    intervals = max(points - 1, len(lengths))
    share = np.maximum(1, np.floor(lengths / segment.distance * intervals).astype(int))
    while share.sum() < intervals:  # hand out the remainder to the coarsest pieces
        share[np.argmax(lengths / share)] += 1
    nodes = [np.linspace(a, b, n + 1)[:-1] for a, b, n in zip(breaks[:-1], breaks[1:], share)]
    return np.append(np.concatenate(nodes), segment.distance)


def interval_of(nodes, x):
    """Index of the grid interval holding position ``x`` (the first or last one beyond the ends)."""
    return int(np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, len(nodes) - 2))


def node_limits(segment, nodes):
    """Speed limit at each node: the lower of the limits on its two sides [m/s]."""
    left = segment.limit(np.maximum(nodes - 1e-9, 0.0))
    right = segment.limit(nodes)
    return np.minimum(left, right)
