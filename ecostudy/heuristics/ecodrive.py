"""Driving strategies to compare with the optimum, each scored by the independent simulator.

- ``eco_coasting``: the industrial baseline of Farooqi 2018 Table 6.1: full traction up to the
  limits, hold the limits, and from a coasting point on coast (braking only to respect a limit
  and to stop); the coasting point is the earliest one whose simulated arrival meets the time.
- ``mareco``: a margin-distribution heuristic in the style of OSRD's MARECO (ecostudy/heuristics/mareco.py):
  cap the top speed, coast before braking and before steep descents, the cap searched so that
  the simulated running time meets the timetable.

A strategy's profile becomes forces per interval (clipped to the envelopes), then handles, and
is re-simulated over time; reported times and energies are the simulated ones.
"""

from ecostudy.analysis.tables import handles
from ecostudy.core import kinematics
from ecostudy.core.errors import InfeasibleError
from ecostudy.core.simulate import Driven, simulate
from ecostudy.core.units import apart
from ecostudy.heuristics.mareco import mareco as heuristic


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
    u, trace = drive(case, profile(c))
    return Driven("eco-drive coasting", u, trace)


def mareco(case, running_time):
    """MARECO-style run meeting ``running_time`` (see :mod:`ecostudy.mareco`)."""
    v1, u, trace = heuristic(case, running_time, drive)
    return Driven("MARECO-style", u, trace)


