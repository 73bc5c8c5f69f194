"""Driving strategies to compare with the optimum, each scored by the independent simulator.

- ``eco_coasting``: the industrial baseline of thesis 000 Table 6.1: full traction up to the
  limits, hold the limits, and from a coasting point on coast (braking only to respect a limit
  and to stop); the coasting point is the earliest one whose simulated arrival meets the time.
- ``mareco``: a margin-distribution heuristic in the style of OSRD's MARECO (ecostudy/mareco.py):
  cap the top speed, coast before braking and before steep descents, the cap searched so that
  the simulated running time meets the timetable.
- ``das_round``: the nearest driver-advisory handle level (train's ``das_handle_levels``) to the
  optimal handle of each interval (thesis 000 §4.4), without a cruise mode; it keeps no
  timetable of its own, so its arrival and stop errors are part of the comparison.

A strategy's profile becomes forces per interval (clipped to the envelopes), then handles, and
is re-simulated over time; reported times and energies are the simulated ones.
"""
from dataclasses import dataclass

import numpy as np

from . import initial
from .errors import InfeasibleError
from .run import handles
from .simulate import simulate
from .units import to_kwh


@dataclass
class Outcome:
    name: str
    handle: np.ndarray
    trace: object

    def row(self, train, distance):
        t = self.trace
        regen = train.regeneration_efficiency * t.regenerated_energy
        changes = int(np.count_nonzero(np.abs(np.diff(self.handle)) > 1e-3))
        return {"strategy": self.name, "running_time_s": t.arrival_time,
                "traction_energy_kWh": to_kwh(t.traction_energy),
                "net_energy_kWh": to_kwh(t.traction_energy / train.traction_efficiency - regen),
                "stop_error_m": t.stop_position - distance, "handle_changes": changes}


def drive(case, speeds):
    """Handles realising a speed profile on the grid, and their simulation."""
    ft, fb = initial.forces_for(speeds, case.segment, case.train, case.nodes)
    u = handles(case.train, speeds, ft, fb)
    return u, simulate(case.segment, case.train, case.nodes, u)[0]


def eco_coasting(case, running_time):
    """Cruise at the limits, coast from the earliest point whose simulated arrival meets the time."""
    full = case.envelope
    bwd = initial.braking_curve(case.segment, case.train, case.nodes, case.limits)

    def profile(c):
        coast = initial.coast_speeds(case.segment, case.train, case.nodes, case.limits, c, full[c])
        v = full.copy()
        v[c:] = np.minimum(coast[c:], bwd[c:])
        v[-1] = 0.0
        return v

    def arrival(c):
        return drive(case, profile(c))[1].arrival_time

    last = len(case.nodes) - 1
    if arrival(last) > running_time:
        raise InfeasibleError(f"eco-drive coasting cannot meet {running_time:.1f} s")
    lo, hi = 1, last  # arrival(hi) <= running_time; find the smallest such coasting point
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if arrival(mid) <= running_time:
            hi = mid
        else:
            lo = mid
    u, trace = drive(case, profile(hi))
    return Outcome("eco-drive coasting", u, trace)


def mareco(case, running_time):
    """MARECO-style run meeting ``running_time`` (see :mod:`ecostudy.mareco`)."""
    from .mareco import mareco as heuristic
    v1, u, trace = heuristic(case, running_time, drive)
    return Outcome("MARECO-style", u, trace)


def das_round(segment, train, nodes, optimal_handle):
    """Nearest DAS handle level to the optimal handle, interval by interval, re-simulated."""
    levels = np.asarray(train.das_levels)
    u = levels[np.abs(optimal_handle[:, None] - levels[None, :]).argmin(axis=1)]
    trace = simulate(segment, train, nodes, u)[0]
    return Outcome("DAS round (nearest level)", u, trace)
