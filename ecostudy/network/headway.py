"""Whether a timetable lets each train keep ``buffer_m`` behind the train ahead: from the timetable
alone (:func:`timetable_conflict`: where a train stands, departs or arrives, its position is its
stop; while it runs, it is between its two stops), or with the running train's dynamics
(:func:`reach_conflict`: the furthest the train ahead's leg NLP can take it by a clock step, or
the least far the train behind can be and still arrive on time, real Ipopt solves), or with both
trains' dynamics at once (:func:`running_conflict`: the largest gap any runs of both keep, where
both run, e.g. the train ahead slowed by a restriction the train behind has not reached).

The first is decidable from the study file (stops, running times, dwell, departures, the train's
length, the buffer): a network study that fails it is refused before anything is solved. The
second needs the train's dynamics: the joint optimum, whose trains ahead are variables, says it
when Ipopt finds its NLP with the buffer's rows infeasible (``network.joint``).
"""
from types import SimpleNamespace

import numpy as np
import pyomo.environ as pyo

from ecostudy.network.fleet import departure_order, following_legs, line_positions
from ecostudy.network.legs import BUFFER_SLACK_M, closest_reachable, head_to_tail
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
        gap = head_to_tail(np.max(front, axis=0), np.min(back, axis=0), length)  # NaN where either is off the line
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


def furthest(leg, j, least=False):
    """The furthest [m] leg ``leg`` can take its train by its step ``j``: its leg NLP (the joint's
    rows, ``timedomain.add_leg``: the same stops, running time and limits) maximising s_j; with
    ``least``, the least far it can be and still arrive on time (minimising s_j: its latest start)."""
    m = pyo.ConcreteModel()
    b = timedomain.add_leg(m, "leg", leg, None, one_handle=False)
    m.objective = pyo.Objective(expr=b.s[j], sense=pyo.minimize if least else pyo.maximize)
    outcome = session.solve(m)
    return float(pyo.value(b.s[j])) if outcome.usable else 0.0 if least else float(leg.case.segment.distance)


def reach_conflict(fleet):
    """The earliest clock step where a train's position is fixed by the timetable and the other of a
    pair, running, cannot keep ``fleet.buffer`` between them: a train departs or arrives (its head at
    its stop) while the train ahead, on its fastest start (:func:`furthest`), is still too near; or
    the train ahead stands at a stop for the last step (it departs, or leaves the line after its
    terminus dwell) while the train behind, on its latest start (``furthest(least=True)``), is
    already too near. :func:`timetable_conflict`'s dict with "furthest_m" (how far along its leg
    the running train can be at the most, or with "least", at the least) and "since_s" (since it
    departed); None where there is none (then no such bound explains an infeasible joint NLP)."""
    order = departure_order(fleet)
    length = fleet.legs[0][0].case.train.length
    fixed = {(leg.start + j, rank, False) for rank in range(1, len(order)) for leg in fleet.legs[order[rank]]
             for j in (0, leg.steps)}  # the train behind departs or arrives
    fixed |= {(t, rank, True) for rank in range(1, len(order)) for t in _last_standing(fleet, order[rank - 1])}
    at = {i: _extremes(fleet, i)[0] for i in order}  # where each train is; where it does not run both extremes agree
    for t, rank, behind_runs in sorted(fixed):
        ahead, me = order[rank - 1], order[rank]
        d = fleet.legs[me][0].direction
        runner = me if behind_runs else ahead
        for leg in fleet.legs[runner]:
            if leg.start < t < leg.start + leg.steps:  # it runs this leg at t
                far = furthest(leg, t - leg.start, least=behind_runs)
                there = d * (leg.line_start + leg.direction * far)
                gap = (head_to_tail(d * at[ahead][t], there, length) if behind_runs
                       else head_to_tail(there, d * at[me][t], length))
                if gap < _least(fleet):
                    return {**_conflict(fleet, ahead, me, t, gap), "furthest_m": far, "least": behind_runs,
                            "since_s": (t - leg.start) * fleet.dt}
    return None


def _last_standing(fleet, i):
    """The clock steps at which train ``i`` stands at a stop for the last time before it moves on:
    each departure after the first, and the last step of its terminus dwell."""
    legs = fleet.legs[i]
    return [leg.start for leg in legs[1:]] + [legs[-1].start + legs[-1].steps + fleet.dwell_steps]


def say_reach(conflict, buffer):
    """A :func:`reach_conflict` in words."""
    c = conflict
    if c.get("least"):
        return (f"train {c['train']} {c['doing']} at {c['time_s']:g} s, {c['since_s']:g} s after it departed, when "
                f"train {c['ahead']} {c['ahead_doing']}: to arrive on time it must be at least {c['furthest_m']:.1f} m "
                f"along its leg (its latest start): {_gap(c)}, where {_asked(buffer)} is asked (offset_s, dwell_s)")
    return (f"train {c['train']} {c['doing']} at {c['time_s']:g} s, when train {c['ahead']}, {c['since_s']:g} s "
            f"after it departed, can be at most {c['furthest_m']:.1f} m along its leg (its fastest start): "
            f"{_gap(c)}, where {_asked(buffer)} is asked (offset_s)")


def running_conflict(fleet):
    """Where no runs of the trains, all free (their leg NLPs: the joint's rows without its cost or
    circuit), keep ``fleet.buffer`` between a train's head and the tail of the one ahead, whatever
    each does (``legs.closest_reachable`` over every train's legs at once): a conflict while both
    run, which no bound of :func:`reach_conflict` names. :func:`timetable_conflict`'s dict at the
    first step where the gap is least, "gap_m" the largest gap any runs keep there; None where the
    buffer can be kept (or that NLP has no usable point)."""
    m = pyo.ConcreteModel()
    blocks = [[timedomain.add_leg(m, f"t{i}_leg{k}", leg, None, one_handle=False) for k, leg in enumerate(legs)]
              for i, legs in enumerate(fleet.legs)]
    pairs = list(following_legs(fleet, blocks))
    found = closest_reachable(m, [(leg, x, b.s) for _, _, leg, b, x in pairs], fleet.buffer)
    if found is None:
        return None
    gap, n, j = found
    me, ahead, leg, *_ = pairs[n]
    return _conflict(fleet, ahead, me, leg.start + j, gap)


def say_running(conflict, buffer):
    """A :func:`running_conflict` in words."""
    c = conflict
    return (f"train {c['train']} {c['doing']} at {c['time_s']:g} s while train {c['ahead']} {c['ahead_doing']}: "
            f"on any runs of both that keep the timetable, {_gap(c)} there, where {_asked(buffer)} is asked; "
            f"depart {c['train']} later (offset_s), or change running_times_s")
