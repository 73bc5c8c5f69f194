"""A journey's timetable refused, in one line and before any solve, where two of its times leave
less than the fastest run between them (``studies.journey``; the rule: ``ocp.problem.check_times_reachable``)."""
import numpy as np

from ecostudy.core import kinematics
from ecostudy.ocp.problem import Passing, check_times_reachable


def check_reachable(plan, cases):
    """Refuse, in one line, timing points no run can keep: for two points, the latest time of the
    later one minus the earliest of the earlier one must leave the fastest run between them (on
    the fastest-speed envelope, which no run exceeds) plus the least dwells in between."""
    passings = []
    fastest, dwells, start = 0.0, 0.0, 0.0
    for n, case in enumerate(cases):
        clock = kinematics.clock(case.envelope, case.nodes)
        dwells += plan.dwell[n]
        lo, hi = plan.departure[n] or (None, None)
        passings.append(Passing(("departure", n), f"the departure from {plan.stops[n]}", lo, hi, fastest, dwells,
                                _fields(n, lo, hi, departure=True)))
        for j, w in enumerate(plan.windows[n]):
            at = fastest + float(np.interp(w.distance, case.nodes, clock))
            row = f"windows[{plan.window_rows[n][j]}]" if plan.window_rows else "windows"
            passings.append(Passing(start + w.distance, f"the timing point at {start + w.distance:g} m", w.earliest,
                                    w.latest, at, dwells, (f"{row}.earliest_s", f"{row}.latest_s")))
        fastest += float(clock[-1])
        start += case.segment.distance
        passings.append(Passing(("arrival", n + 1), f"the arrival at {plan.stops[n + 1]}", *plan.arrival[n], fastest,
                                dwells, _fields(n + 1, *plan.arrival[n])))
    check_times_reachable(passings)


def _fields(n, lo, hi, departure=False):
    """(field of the earliest time, of the latest) of timetable stop ``n``'s departure or arrival:
    one fixed time, or a window's two bounds."""
    fixed, early, late = (("departure_s", "departure_earliest_s", "departure_latest_s") if departure
                          else ("arrival_s", "earliest_s", "latest_s"))
    if lo is not None and lo == hi:
        early = late = fixed
    return f"stops[{n}].{early}", f"stops[{n}].{late}"
