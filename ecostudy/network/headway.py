"""Whether a timetable lets each train keep ``buffer_m`` behind the train ahead: from the timetable
alone (:func:`timetable_conflict`: where a train stands, departs or arrives, its position is its
stop; while it runs, it is between its two stops), or with the train ahead's fastest start
(:func:`reach_conflict`: the furthest its leg NLP can take it by a clock step, a real Ipopt solve).

The first is decidable from the study file (stops, running times, dwell, departures, the train's
length, the buffer): a network study that fails it is refused before anything is solved. The
second needs the train's dynamics: the joint optimum, whose trains ahead are variables, says it
when Ipopt finds its NLP with the buffer's rows infeasible (``network.joint``).
"""
from types import SimpleNamespace

import numpy as np
import pyomo.environ as pyo

from ecostudy.network.fleet import departure_order, line_positions
from ecostudy.network.legs import BUFFER_SLACK_M
from ecostudy.ocp import session, timedomain


def _extremes(fleet, i):
    """Train ``i``'s line positions per clock step at the two ends of what its timetable allows
    (NaN off the line): at every step of a leg the run that leaves at once and the run that waits
    to the last step (equal where it stands, departs or arrives)."""
    early = [SimpleNamespace(s=np.r_[0.0, np.full(leg.steps, leg.case.segment.distance)]) for leg in fleet.legs[i]]
    late = [SimpleNamespace(s=np.r_[np.zeros(leg.steps), leg.case.segment.distance]) for leg in fleet.legs[i]]
    return line_positions(fleet, i, early), line_positions(fleet, i, late)


def _where(fleet, i, t):
    """What train ``i`` does at clock step ``t``, in words: departs, arrives at, runs between, stands at."""
    for k, leg in enumerate(fleet.legs[i]):
        seg = leg.case.segment
        if t < leg.start:
            break
        if t == leg.start:
            return f"departs {seg.from_stop}"
        if t == leg.start + leg.steps:
            return f"arrives at {seg.to_stop}"
        if leg.start < t < leg.start + leg.steps:
            return f"runs from {seg.from_stop} to {seg.to_stop}"
        if t > leg.start + leg.steps and (k + 1 == len(fleet.legs[i]) or t < fleet.legs[i][k + 1].start):
            return f"stands at {seg.to_stop}"
    return "is off the line"


def _least(fleet):
    """The gap a timetable must leave between a train's head and the tail of the one ahead [m]:
    ``buffer_m`` (0 without one: no overlap), less what Ipopt may leave a separation row violated."""
    return (fleet.buffer or 0.0) - BUFFER_SLACK_M


def _conflict(fleet, ahead, me, t, gap):
    return {"train": fleet.names[me], "ahead": fleet.names[ahead], "time_s": t * fleet.dt, "gap_m": float(gap),
            "doing": _where(fleet, me, t), "ahead_doing": _where(fleet, ahead, t)}


def timetable_conflict(fleet):
    """The earliest clock step where, whatever the trains' runs, a train's head is nearer the tail of
    the train ahead (departure order) than ``fleet.buffer`` (without one: where they overlap), from
    the timetable alone: {"train", "ahead", "time_s", "gap_m" (the largest gap any runs leave there),
    "doing", "ahead_doing"}; None where there is none. Only the legs are used (no run is solved)."""
    order = departure_order(fleet)
    length = fleet.legs[0][0].case.train.length
    found = None
    for ahead, me in zip(order[:-1], order[1:]):
        d = fleet.legs[me][0].direction  # along the line as ``scoring.separations`` measures it
        front, back = (d * np.stack(_extremes(fleet, i)) for i in (ahead, me))
        gap = np.max(front, axis=0) - np.min(back, axis=0) - length  # NaN where either is off the line
        close = np.flatnonzero(np.isfinite(gap) & (gap < _least(fleet)))
        if close.size and (found is None or close[0] * fleet.dt < found["time_s"]):
            found = _conflict(fleet, ahead, me, int(close[0]), gap[close[0]])
    return found


def _gap(c):
    """The largest gap of a conflict in words (a negative one: the trains overlap)."""
    if c["gap_m"] < 0:
        return f"{c['train']}'s head is at least {-c['gap_m']:.1f} m past {c['ahead']}'s tail (they overlap)"
    return f"{c['train']}'s head is at most {c['gap_m']:.1f} m behind {c['ahead']}'s tail"


def _asked(buffer):
    return f"buffer_m {buffer:g} m" if buffer else "no overlap"


def say_timetable(conflict, buffer):
    """A :func:`timetable_conflict` in words (what to change: the study's ``trains``, ``dwell_s``,
    ``running_times_s``)."""
    c = conflict
    return (f"train {c['train']} {c['doing']} at {c['time_s']:g} s while train {c['ahead']} {c['ahead_doing']}: "
            f"whatever both run, {_gap(c)}, where {_asked(buffer)} is asked; depart {c['train']} later "
            "(offset_s), or change dwell_s or running_times_s")


def furthest(leg, j):
    """The furthest [m] leg ``leg`` can take its train by its step ``j``: its leg NLP (the joint's
    rows, ``timedomain.add_leg``: the same stops, running time and limits) maximising s_j."""
    m = pyo.ConcreteModel()
    b = timedomain.add_leg(m, "leg", leg, None, one_handle=False)
    m.objective = pyo.Objective(expr=b.s[j], sense=pyo.maximize)
    outcome = session.solve(m)
    return float(pyo.value(b.s[j])) if outcome.usable else float(leg.case.segment.distance)


def reach_conflict(fleet):
    """The earliest clock step where a train departs or arrives (its head at its stop) and the train
    ahead, running, cannot be ``fleet.buffer`` ahead of it even on its fastest start (:func:`furthest`):
    :func:`timetable_conflict`'s dict with "furthest_m" (how far along its leg the train ahead can
    be); None where there is none (then no such bound explains an infeasible joint NLP)."""
    order = departure_order(fleet)
    length = fleet.legs[0][0].case.train.length
    steps = sorted({(leg.start + j, rank) for rank in range(1, len(order)) for leg in fleet.legs[order[rank]]
                    for j in (0, leg.steps)})
    at = {i: _extremes(fleet, i)[0] for i in order[1:]}  # where each train is; at its stops both extremes agree
    for t, rank in steps:
        ahead, me = order[rank - 1], order[rank]
        d = fleet.legs[me][0].direction
        mine = d * at[me][t]
        for leg in fleet.legs[ahead]:
            if leg.start < t < leg.start + leg.steps:  # the train ahead runs this leg at t
                far = furthest(leg, t - leg.start)
                gap = d * (leg.line_start + leg.direction * far) - mine - length
                if gap < _least(fleet):
                    return {**_conflict(fleet, ahead, me, t, gap), "furthest_m": far,
                            "since_s": (t - leg.start) * fleet.dt}
    return None


def say_reach(conflict, buffer):
    """A :func:`reach_conflict` in words."""
    c = conflict
    return (f"train {c['train']} {c['doing']} at {c['time_s']:g} s, when train {c['ahead']}, {c['since_s']:g} s "
            f"after it departed, can be at most {c['furthest_m']:.1f} m along its leg (its fastest start): "
            f"{_gap(c)}, where {_asked(buffer)} is asked (offset_s)")
