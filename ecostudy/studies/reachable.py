"""A journey's timetable refused, in one line and before any solve, where two of its times leave
less than the fastest run between them (``studies.journey``)."""
import numpy as np

from ecostudy.core import kinematics
from ecostudy.core.errors import FieldError


def check_reachable(plan, cases):
    """Refuse, in one line, timing points no run can keep: for two points, the latest time of the
    later one minus the earliest of the earlier one must leave the fastest run between them (on
    the fastest-speed envelope, which no run exceeds) plus the least dwells in between."""
    events = []  # (where, earliest, latest, fastest clock since the start, dwells since the start, fields)
    fastest, dwells, start = 0.0, 0.0, 0.0
    for n, case in enumerate(cases):
        clock = kinematics.clock(case.envelope, case.nodes)
        dwells += plan.dwell[n]
        lo, hi = plan.departure[n] or (None, None)
        events.append((f"the departure from {plan.stops[n]}", lo, hi, fastest, dwells,
                       _fields(n, lo, hi, departure=True)))
        for j, w in enumerate(plan.windows[n]):
            at = fastest + float(np.interp(w.distance, case.nodes, clock))
            row = f"windows[{plan.window_rows[n][j]}]" if plan.window_rows else "windows"
            events.append((f"the timing point at {start + w.distance:g} m", w.earliest, w.latest, at, dwells,
                           (f"{row}.earliest_s", f"{row}.latest_s")))
        fastest += float(clock[-1])
        start += case.segment.distance
        events.append((f"the arrival at {plan.stops[n + 1]}", *plan.arrival[n], fastest, dwells,
                       _fields(n + 1, *plan.arrival[n])))
    worst = None
    for i, (a, lo, _, t_a, d_a, (field_a, _)) in enumerate(events):
        for b, _, hi, t_b, d_b, (_, field_b) in events[i + 1:]:
            if lo is not None and hi is not None:
                short = (t_b - t_a) + (d_b - d_a) - (hi - lo)
                if short > 1e-6 and (worst is None or short > worst[0]):
                    worst = (short, a, lo, b, hi, t_b - t_a, d_b - d_a, dict.fromkeys((field_a, field_b)))
    if worst is not None:
        short, a, lo, b, hi, need, dwelt, fields = worst
        raise FieldError(f"infeasible: {a} (not before {lo:g} s) and {b} (not after {hi:g} s) leave {hi - lo:g} s; the "
                         f"fastest run between them takes {need:.0f} s" + (f" and the dwells {dwelt:g} s" if dwelt > 0 else ""),
                         ", ".join(fields))


def _fields(n, lo, hi, departure=False):
    """(field of the earliest time, of the latest) of timetable stop ``n``'s departure or arrival:
    one fixed time, or a window's two bounds."""
    fixed, early, late = (("departure_s", "departure_earliest_s", "departure_latest_s") if departure
                          else ("arrival_s", "earliest_s", "latest_s"))
    if lo is not None and lo == hi:
        early = late = fixed
    return f"stops[{n}].{early}", f"stops[{n}].{late}"
