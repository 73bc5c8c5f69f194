"""Two logs that share samples: one logged run given twice, whole (a copy, its clock shifted or its
units other) or exported with rows trimmed (a different start or end). Fitted as two, the shared
samples would narrow every interval as if they were two runs."""
from dataclasses import dataclass

import numpy as np

from ecostudy.io.logfile import INTEGRATED, LoggedRun

MIN_SHARED = 100     # rows: fewer shared rows are not judged
MAX_CANDIDATES = 50  # rows of the longer log tried as the shorter log's first row


@dataclass(frozen=True)
class Overlap:
    """Where ``log``'s rows are ``other``'s: log rows ``first``.. and other rows ``other_first``..,
    ``rows`` of them, ``log``'s clock ``offset`` seconds after the other's."""

    first: int
    other_first: int
    rows: int
    offset: float
    whole: bool  # both logs are these rows: one run given twice whole


def _same(log: LoggedRun, other: LoggedRun, i: int, j: int, n: int) -> bool:
    """Whether ``n`` rows of ``log`` from ``i`` are ``other``'s from ``j``: the time from those rows,
    the positions (where both have a position column) and the speeds equal within the last digits
    both files write."""
    pairs = [("time", log.t[i:i + n] - log.t[i], other.t[j:j + n] - other.t[j])]
    if INTEGRATED not in (log.columns[0], other.columns[0]):
        pairs.append(("position", log.x[i:i + n], other.x[j:j + n]))
    if log.v is not None and other.v is not None:
        pairs.append(("speed", log.v[i:i + n], other.v[j:j + n]))
    if len(pairs) < 2:
        return False
    for quantity, a, b in pairs:
        within = log.resolution.get(quantity, 0.0) + other.resolution.get(quantity, 0.0) + 1e-9 * float(np.max(np.abs(a)))
        if np.any(np.abs(a - b) > within):
            return False
    return True


def overlap(log: LoggedRun, other: LoggedRun) -> Overlap | None:
    """The samples ``log`` shares with ``other`` (one's first row somewhere in the other, and at
    least :data:`MIN_SHARED` rows, or all of the shorter, equal from there on), or None: the time
    from those rows, the positions (where both have a position column) and the speeds in SI equal
    within the last digits both files write, whatever units their columns are in (``speed_kmh``
    against ``speed_mps``)."""
    for a, b, swapped in ((log, other, False), (other, log, True)):
        quantity, ours, theirs = (("speed", a.v, b.v) if a.v is not None and b.v is not None else
                                  ("position", a.x, b.x))
        tol = a.resolution.get(quantity, 0.0) + b.resolution.get(quantity, 0.0) + 1e-12
        for j in np.nonzero(np.abs(theirs - ours[0]) <= tol)[0][:MAX_CANDIDATES]:
            n = min(len(a.t), len(b.t) - int(j))
            if n >= min(MIN_SHARED, len(a.t)) and _same(a, b, 0, int(j), n):
                offset = float(a.t[0] - b.t[j])
                whole = j == 0 and n == len(a.t) == len(b.t)
                return Overlap(int(j), 0, n, -offset, whole) if swapped else Overlap(0, int(j), n, offset, whole)
    return None
