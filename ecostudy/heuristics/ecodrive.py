"""Driving strategies to compare with the optimum, each scored by the independent simulator.

- ``eco_coasting``: the industrial baseline of Farooqi 2018 Table 6.1: full traction up to the
  limits, hold the limits, and from a coasting point on coast (braking only to respect a limit
  and to stop); the coasting point is the earliest one whose simulated arrival meets the time.
- ``mareco``: a margin-distribution heuristic in the style of OSRD's MARECO (ecostudy/heuristics/mareco.py):
  cap the top speed, coast before braking and before steep descents, the cap searched so that
  the simulated running time meets the timetable.

A strategy's profile becomes forces per interval (clipped to the envelopes), then handles, and
is re-simulated over time; reported times and energies are the simulated ones. Its last braking is
then scaled so that the simulated run stands at the stop, as a driver brakes to the platform
(:func:`landed`).
"""
import numpy as np

from ecostudy.analysis.tables import handles
from ecostudy.core import kinematics
from ecostudy.core.errors import InfeasibleError
from ecostudy.core.simulate import Driven, simulate
from ecostudy.core.units import apart
from ecostudy.heuristics.mareco import mareco as heuristic

LAND_M = 0.01  # a rule of thumb's run stands this near its stop [m] (:func:`landed`)


def drive(case, speeds):
    """Handles realising a speed profile on the grid, and their simulation."""
    ft, fb = kinematics.forces_for(speeds, case.segment, case.train, case.nodes)
    u = handles(case.train, speeds, ft, fb)
    return u, simulate(case.segment, case.train, case.nodes, u)[0]


def eco_coasting(case, running_time):
    """Cruise at the limits, coast from the earliest point whose simulated arrival meets the time."""
    def profile(c):
        return kinematics.coasting_profile(case.segment, case.train, case.nodes, case.limits, case.envelope, c)

    def arrival(c):
        return drive(case, profile(c))[1].arrival_time

    last = len(case.nodes) - 1
    fastest = arrival(last)
    if fastest > running_time:  # the digits that tell them apart: not "cannot meet 71.8 s" for 71.75 s
        asked, itself = apart(running_time, fastest)
        raise InfeasibleError(f"eco-drive coasting cannot meet {asked} s: without coasting it arrives at {itself} s")
    c = kinematics.earliest_coasting_point(lambda k: arrival(k) <= running_time, last)
    return Driven("eco-drive coasting", *landed(case, *drive(case, profile(c))))


def mareco(case, running_time):
    """MARECO-style run meeting ``running_time`` (see :mod:`ecostudy.mareco`)."""
    v1, u, trace = heuristic(case, running_time, drive)
    return Driven("MARECO-style", *landed(case, u, trace))


def landed(case, u, trace, tries=12):
    """(handles, trace) with the run's last braking (the handles below 0 that end it) scaled so the
    simulated run stands within :data:`LAND_M` of the stop, as a driver brakes to the platform: the
    profile's braking, turned into handles on the grid's trapezoidal recursion, stands metres short
    or long of the stop on a coarse grid (about 0.8 m at K = 500 on the Amsterdam metro, 10-20 m at
    K = 10 to 40). Braking harder stops sooner, about as the braking distance falls with the braking
    force: each try scales the braking by the distance it took over the distance it has (a secant
    step once two tries are known). A run no scale lands in ``tries`` (its strongest braking still
    overruns) is returned as it was."""
    u = np.asarray(u, float)
    distance = case.segment.distance
    first = len(u)
    while first > 0 and u[first - 1] < 0.0:
        first -= 1
    start = float(case.nodes[first]) if first < len(u) else distance
    strongest = 1.0 / float(np.max(-u[first:])) if first < len(u) else 1.0
    scale, tried = 1.0, []
    for _ in range(tries):
        tried.append((scale, trace.stop_position - distance))
        if abs(tried[-1][1]) <= LAND_M or first == len(u):
            return (u if scale == 1.0 else scaled), trace
        if len(tried) > 1 and tried[-1][1] != tried[-2][1]:  # secant on the miss
            (s0, m0), (s1, m1) = tried[-2:]
            scale = s1 - m1 * (s1 - s0) / (m1 - m0)
        else:
            scale *= (trace.stop_position - start) / max(distance - start, 1e-9)
        scale = min(max(scale, 1e-3), strongest)
        if scale == tried[-1][0]:  # at the strongest braking, still past the stop
            break
        scaled = u.copy()
        scaled[first:] = np.maximum(u[first:] * scale, -1.0)
        trace = simulate(case.segment, case.train, case.nodes, scaled)[0]
    return u, simulate(case.segment, case.train, case.nodes, u)[0]
