"""Controllers behind one interface: ``plan(measured state) -> handle`` until the next sample.

- :class:`OpenLoop`: the full-horizon ATO optimum replayed, by position or on its clock: the
  baseline that shows what feedback buys.
- :class:`Replanning`: the space-domain NLP re-solved from the measured state every sample
  (Yazhemsky 2017 §4.2, Alg. 1: the horizon recedes to the measured position; here with the
  movable NLP of ``ocp.restart`` instead of the SOCP of Ch. 6), its first control applied. One
  model and NL file for the whole trip, warm from the previous plan; a mass estimate, when one is
  given, changes the model's mass by a bound.
- :class:`Convex`: Yazhemsky 2017's real-time controller (Alg. 1): the SOCP 6.10 of
  ``ocp.convex`` solved from every measured state on the grid ahead, its first force applied;
  optionally following a leading train's clock (eq. 6.9) and fed by a mass estimator.
"""
import dataclasses
import time

import numpy as np

from ecostudy.analysis.tables import handles
from ecostudy.core.grid import interval_of
from ecostudy.control.fallback import Fallback
from ecostudy.control.loop import planned_handle
from ecostudy.core.types import State
from ecostudy.ocp.convex import EXACT
from ecostudy.ocp.restart import Replanner
from ecostudy.ocp.solver import IPOPT

REPLAN_OPTIONS = IPOPT["replan"]  # a re-plan that needs more has no plan worth waiting for
RELAXED = 1e-3  # a convex plan with max |rho s - 1| above this uses the relaxation materially


def from_departure(measured):
    """``measured`` with a noisy position reading behind the departure point read as at it."""
    return measured if measured.position >= 0.0 else State(0.0, measured.speed, measured.time)


def handle_of(train, speed, traction, braking):
    """Handle in [-1, 1] of a planned traction and braking force [N] at ``speed`` (analysis.tables.handles)."""
    return float(handles(train, np.array([speed, speed]), np.array([traction]), np.array([braking]))[0])


class OpenLoop(Fallback):
    """Replay a solved run's handle (``RunResult``): ``by="position"`` switches where the plan
    switches, ``by="time"`` on the plan's clock."""

    def __init__(self, result, by="position"):
        self.result, self.by = result, by
        self.key = result.nodes if by == "position" else result.trajectory.time
        self._start_records()

    def plan(self, measured):
        x = measured.position if self.by == "position" else measured.time
        self.without_solve("replay")
        return float(self.result.handle[interval_of(self.key, x)])


class ForceReplay(Fallback):
    """Replay a plan's force per interval of ``nodes`` [N] (traction > 0, braking < 0) by position,
    as the handle that asks for it at the measured speed: a full-horizon plan without feedback."""

    def __init__(self, train, nodes, force):
        self.train, self.nodes, self.force = train, np.asarray(nodes, float), np.asarray(force, float)
        self._start_records()

    def plan(self, measured):
        self.without_solve("replay")
        if measured.position >= self.nodes[-1]:
            return -1.0
        return force_handle(self.train, max(measured.speed, 0.0), self.force[interval_of(self.nodes, measured.position)])


class Replanning(Fallback):
    """Re-solve the energy-optimal run from every measured state (see the module docstring).

    ``arrival``: the timetabled arrival [s] on the trip's clock, kept as 'arrive by' so a plan
    exists while the train is early; a train too late for it re-plans to arrive within a minute
    more (``late`` counts those cycles). Near the stop (``final_m``), or when no plan reaches
    the stop at all (``failures``), the controller falls back (``control.fallback``: the last plan
    at the measured position, else full braking). ``brake_reserve``: the share of the braking
    envelope the plans leave unused, for the deviations between samples.
    """

    def __init__(self, case, arrival, estimator=None, final_m=1.0, brake_reserve=0.1, options=None):
        self.case, self.arrival, self.estimator, self.final_m = case, float(arrival), estimator, final_m
        # plan with a share of the service brake held back (Yazhemsky 2017 eq. 6.8's braking reserve):
        # between samples the handle is held, and a plan that brakes at the limit is then late
        model = case.train.with_brake_reserve(brake_reserve)
        self.replanner = Replanner(dataclasses.replace(case, train=model), window=(0.0, self.arrival),
                                   options={**REPLAN_OPTIONS, **(options or {})})
        self.last, self.late, self.iterations = 0.0, 0, []
        self._start_records()

    def plan(self, measured):
        distance, measured = self.case.segment.distance, from_departure(measured)
        if measured.position >= distance - self.final_m:
            self.without_solve("final", self.estimator)
            return -1.0
        scale = self.estimator.estimate if self.estimator is not None else None
        t0, late = time.perf_counter(), self.late
        try:
            plan = self.replanner.solve(measured, arrival=(0.0, max(self.arrival, measured.time + 1.0)),
                                        mass_scale=scale)
            if not plan.outcome.usable:  # late: arrive as soon as it can, within a minute more
                self.late += 1
                plan = self.replanner.solve(measured, arrival=(0.0, max(self.arrival, measured.time) + 60.0),
                                            mass_scale=scale)
        finally:
            self.solve_seconds.append(time.perf_counter() - t0)
        self.iterations.append(plan.outcome.iterations)
        status = plan.outcome.status
        if not plan.outcome.usable:  # no plan reaches the stop: the last one, else brake
            self.failures += 1
            self.last, kind = self.fall_back(measured)
        else:
            self.accept(self._held(plan))
            self.last, kind = self._held(plan)(measured), None
        self.record(status, self.solve_seconds[-1], fallback=kind, softened=("arrival_window",) if self.late > late else (),
                    estimator=self.estimator)
        return self.last

    def _held(self, plan):
        nodes, train, ft, fb = self.case.nodes, self.case.train, np.array(plan.ft), np.array(plan.fb)

        def handle_at(measured):
            k = interval_of(nodes, measured.position)
            return handle_of(train, max(measured.speed, 0.0), ft[k], fb[k])
        return handle_at


def force_handle(train, speed, force):
    """Handle in [-1, 1] that asks for ``force`` [N] (traction > 0, braking < 0) at ``speed``."""
    return handle_of(train, speed, max(force, 0.0), max(-force, 0.0))


class Convex(Fallback):
    """Yazhemsky 2017 Alg. 1: every sample, solve ``program`` (``ocp.convex.ConvexProgram``) from the
    measured state and apply the first interval's force as a handle held to the next sample.

    ``arrival``: (T_min, T_max) [s] on the trip's clock; ``lead``: a leading train's clock as a
    function of position (eq. 6.9, already shifted by the separation); a train at a stand waits
    while the leader is still within that separation of it. Within ``final_m`` of the stop the
    controller brakes in full (the final approach). A step without a plan to drive (no usable
    solve, ``max_iter`` Clarabel iterations or the ``budget`` [s] exceeded, or a plan that brakes
    and leans on the relaxation, max |rho s - 1| > 1e-3: no service brake stops the train as
    planned) falls back (``control.fallback``): the leaning braking plan to the brake reserve of
    eq. 6.8 in full (``reserve`` counts these samples; the solve showed that no plan, the shifted
    one included, stops the train with the planned brake), any other to the last accepted plan at
    the measured position while the train is within ``tracking`` [m/s] of its speed there, else
    to full braking. ``full_reserve=False`` is Yazhemsky 2017's controller, which drives the leaning plan.
    A plan with max |rho s - 1| above ``EXACT`` after the tightening rounds is driven and counted
    (``inexact``). Per solve it records the time, the gap and whether the arrival window had to be
    dropped.
    """

    def __init__(self, program, arrival=(0.0, np.inf), estimator=None, lead=None, final_m=0.05, hold=0.1,
                 full_reserve=True, max_iter=None, budget=None, tracking=0.5):
        self.program, self.arrival, self.estimator, self.lead, self.final_m = program, arrival, estimator, lead, final_m
        self.hold, self.full_reserve, self.max_iter, self.budget, self.tracking = (hold, full_reserve, max_iter,
                                                                                  budget, tracking)
        self.gaps, self.softened, self.reserve, self.inexact = [], 0, 0, 0
        self._start_records()

    def plan(self, measured):
        distance = self.program.segment.distance
        waiting = (self.lead is not None and measured.speed < 0.01
                   and float(self.lead(np.array([measured.position + 1.0]))[0]) > measured.time)
        if waiting or measured.position >= distance - self.final_m:
            self.without_solve("wait" if waiting else "final", self.estimator)
            return -1.0
        measured = from_departure(measured)
        scale = self.estimator.estimate if self.estimator is not None else 1.0
        self.program.limit(self.max_iter, self.budget)
        plan = self.program.solve(measured, self.arrival, mass_scale=scale, lead=self.lead, hold=self.hold)
        self.solve_seconds.append(plan.seconds)
        status, gap = plan.status, (plan.gap if plan.usable else None)
        if plan.usable:
            self.gaps.append(plan.gap)
            self.softened += int(plan.softened)
            self.inexact += int(plan.gap > EXACT)
            if self.budget is not None and plan.seconds > self.budget:
                status = "over_budget"
        if status == "over_budget" or not plan.usable:  # no plan to drive (in time): the fallback drives
            self.failures += 1
        # the plan brakes and needs the relaxation (rho s > 1: braking impulse no train has): it
        # cannot stop in time with the service brake it assumed
        leaning = plan.usable and self.full_reserve and plan.force[0] < 0.0 and plan.gap > RELAXED
        if plan.usable and status != "over_budget" and not leaning:
            self.accept(self._held(plan))
            handle, kind = force_handle(self.program.train, max(measured.speed, 0.0), plan.force[0]), None
        else:
            # a leaning plan is the program's proof that no plan, the shifted one included, stops the
            # train from the measured state with the service brake it plans with: the reserve
            handle, kind = self.fall_back(measured, reserve=-1.0 if leaning else None, shifted=not leaning)
            self.reserve += int(kind == "reserve")
        self.record(status, plan.seconds, gap, kind, ("arrival_window",) if plan.usable and plan.softened else (),
                    self.estimator)
        return handle

    def _held(self, plan):
        """The plan as a handle at a later measured state (None where it does not cover it)."""
        x, v, force, train = plan.nodes, plan.v, plan.force, self.program.train

        def handle_at(measured):
            p = measured.position
            if not x[0] - 1e-6 <= p < x[-1] or abs(measured.speed - float(np.interp(p, x, v))) > self.tracking:
                return None
            return force_handle(train, max(measured.speed, 0.0), force[interval_of(x, p)])
        return handle_at


def leader_clock(states, separation):
    """Eq. 6.9's T_buff as a function of position: the clock at which a leading train (its
    closed-loop ``states``) passed ``x + separation``; beyond its stop, the clock it stopped."""
    x = np.maximum.accumulate(np.array([s.position for s in states]))
    t = np.array([s.time for s in states])
    keep = np.concatenate([[True], np.diff(x) > 0])
    x, t = x[keep], t[keep]
    return lambda positions: np.interp(np.asarray(positions, float) + separation, x, t, left=t[0], right=t[-1])


class Quantised:
    """A driver-advisory loop: the ``controller``'s handle applied as the nearest of the train's
    DAS ``levels`` (Farooqi 2018 §3.1.2 and §4.4: {-1, 0, 0.5, 0.75, 1}), optionally ``delay``
    samples late (the driver's reaction time)."""

    def __init__(self, controller, levels, delay=0):
        self.controller, self.levels, self.delay = controller, np.asarray(sorted(levels), float), int(delay)
        self.pending = []

    @property
    def solve_seconds(self):
        return self.controller.solve_seconds

    def plan(self, measured):
        u = planned_handle(self.controller, measured)  # a handle outside [-1, 1] is refused, not snapped to a level
        self.pending.append(float(self.levels[np.argmin(np.abs(self.levels - u))]))
        return self.pending[-1 - self.delay] if len(self.pending) > self.delay else 0.0

    def observe(self, pieces, before, after):
        """Passed on to the controller if it observes (``run_loop``: the pieces hold the levels applied)."""
        if hasattr(self.controller, "observe"):
            self.controller.observe(pieces, before, after)
