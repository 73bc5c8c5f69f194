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
from ecostudy.core.simulate import Driven, simulate, worst_overspeed
from ecostudy.core.units import apart
from ecostudy.heuristics.mareco import mareco as heuristic

LAND_M = 0.01  # a rule of thumb's run stands this near its stop [m] (:func:`landed`)


def planned(case, speeds):
    """Handles realising a speed profile on the grid, and their simulation, as planned (unlanded)."""
    ft, fb = kinematics.forces_for(speeds, case.segment, case.train, case.nodes)
    u = handles(case.train, speeds, ft, fb)
    return u, simulate(case.segment, case.train, case.nodes, u)[0]


def drive(case, speeds):
    """:func:`planned`, the run's final braking landed on the stop (:func:`landed`)."""
    return landed(case, speeds, *planned(case, speeds))


def eco_coasting(case, running_time, steps=10):
    """Cruise at the limits, coast from the earliest point whose simulated arrival meets the time:
    found by bisection on the runs before their landing (one simulation each), then node by node
    (at most ``steps`` each way) on the landed runs, which arrive a little later or earlier."""
    def profile(c):
        return kinematics.coasting_profile(case.segment, case.train, case.nodes, case.limits, case.envelope, c)


    last = len(case.nodes) - 1
    fastest = drive(case, profile(last))[1].arrival_time
    if fastest > running_time:  # the digits that tell them apart: not "cannot meet 71.8 s" for 71.75 s
        asked, itself = apart(running_time, fastest)
        raise InfeasibleError(f"eco-drive coasting cannot meet {asked} s: without coasting it arrives at {itself} s")
    c = kinematics.earliest_coasting_point(lambda k: planned(case, profile(k))[1].arrival_time <= running_time, last)
    runs = {c: drive(case, profile(c))}
    for _ in range(steps):  # landed late: coast later
        if runs[c][1].arrival_time <= running_time or c >= last:
            break
        c += 1
        runs[c] = drive(case, profile(c))
    for _ in range(steps):  # landed in time: coasting earlier may still be
        if c <= 2 or runs[c][1].arrival_time > running_time:
            break
        earlier = drive(case, profile(c - 1))
        if earlier[1].arrival_time > running_time:
            break
        c -= 1
        runs[c] = earlier
    return Driven("eco-drive coasting", *runs[c])


def mareco(case, running_time):
    """MARECO-style run meeting ``running_time`` (see :mod:`ecostudy.mareco`), its target corrected
    on the landed runs."""
    v1, u, trace = heuristic(case, running_time, drive)
    return Driven("MARECO-style", u, trace)


def landed(case, speeds, u, trace, tries=12):
    """(handles, trace) with the run's final braking to the stop scaled so the simulated run stands
    within :data:`LAND_M` of it, as a driver brakes to the platform: the profile's braking, turned
    into handles on the grid's trapezoidal recursion, stands metres short or long of the stop on a
    coarse grid (about 0.8 m at K = 500 on the Amsterdam metro, 10-20 m at K = 10 to 40). The final
    braking is the handles below 0 that end the run over which the planned ``speeds`` fall (braking
    that holds a limit down a descent is not scaled). Braking harder stops sooner, about as the
    braking distance falls with the braking force: each try scales the braking by the distance it
    took over the distance it has (a secant step once two tries are known). A run that no scale lands
    in ``tries`` (its strongest braking still overruns), or that a landing would take over a speed
    limit, is returned as it was."""
    u = np.asarray(u, float)
    distance = case.segment.distance
    first = len(u)
    while first > 0 and u[first - 1] < 0.0 and speeds[first - 1] > speeds[first]:
        first -= 1
    if abs(trace.stop_position - distance) <= LAND_M or first == len(u):
        return u, trace
    start = float(case.nodes[first])
    strongest = 1.0 / float(np.max(-u[first:]))
    scale, tried, original, scaled = 1.0, [], trace, u
    for _ in range(tries):
        tried.append((scale, trace.stop_position - distance))
        if abs(tried[-1][1]) <= LAND_M:
            kept = worst_overspeed(case.segment, trace) <= worst_overspeed(case.segment, original) + 1e-3
            return (scaled, trace) if kept else (u, original)
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
    return u, original
