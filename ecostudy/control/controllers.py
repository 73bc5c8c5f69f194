"""Controllers behind one interface: ``plan(measured state) -> handle`` until the next sample.

- :class:`OpenLoop`: the full-horizon ATO optimum replayed, by position or on its clock: the
  baseline that shows what feedback buys.
- :class:`Replanning`: the space-domain NLP re-solved from the measured state every sample
  (thesis 001 §4.2, Alg. 1: the horizon recedes to the measured position; here with the
  movable NLP of ``ocp.restart`` instead of the SOCP of Ch. 6), its first control applied. One
  model and NL file for the whole trip, warm from the previous plan; a mass estimate, when one is
  given, changes the model's mass by a bound.
"""
import dataclasses
import time

import numpy as np

from ecostudy.analysis.tables import handles
from ecostudy.core.grid import interval_of
from ecostudy.ocp.restart import Replanner

REPLAN_OPTIONS = {"max_iter": 300}  # a re-plan that needs more has no plan worth waiting for


def handle_of(train, speed, traction, braking):
    """Handle in [-1, 1] of a planned traction and braking force [N] at ``speed`` (analysis.tables.handles)."""
    return float(handles(train, np.array([speed, speed]), np.array([traction]), np.array([braking]))[0])


class OpenLoop:
    """Replay a solved run's handle (``RunResult``): ``by="position"`` switches where the plan
    switches, ``by="time"`` on the plan's clock."""

    def __init__(self, result, by="position"):
        self.result, self.by = result, by
        self.key = result.nodes if by == "position" else result.trajectory.time
        self.solve_seconds = []

    def plan(self, measured):
        x = measured.position if self.by == "position" else measured.time
        self.solve_seconds.append(0.0)
        return float(self.result.handle[interval_of(self.key, x)])


class Replanning:
    """Re-solve the energy-optimal run from every measured state (see the module docstring).

    ``arrival``: the timetabled arrival [s] on the trip's clock, kept as 'arrive by' so a plan
    exists while the train is early; a train too late for it re-plans to arrive within a minute
    more (``late`` counts those cycles). Near the stop (``final_m``), or when no plan reaches
    the stop at all (``failures``), the controller brakes in full. ``brake_reserve``: the share of
    the braking envelope the plans leave unused, for the deviations between samples.
    """

    def __init__(self, case, arrival, estimator=None, final_m=1.0, brake_reserve=0.1, options=None):
        self.case, self.arrival, self.estimator, self.final_m = case, float(arrival), estimator, final_m
        # plan with a share of the service brake held back (thesis 001 eq. 6.8's braking reserve):
        # between samples the handle is held, and a plan that brakes at the limit is then late
        model = dataclasses.replace(case.train, braking=case.train.braking.scaled(1.0 - brake_reserve))
        self.replanner = Replanner(dataclasses.replace(case, train=model), window=(0.0, self.arrival),
                                   options={**REPLAN_OPTIONS, **(options or {})})
        self.last, self.failures, self.late, self.solve_seconds, self.iterations = 0.0, 0, 0, [], []

    def plan(self, measured):
        distance = self.case.segment.distance
        if measured.position >= distance - self.final_m or measured.position < 0.0:
            self.solve_seconds.append(0.0)
            return -1.0
        scale = self.estimator.estimate if self.estimator is not None else None
        t0 = time.perf_counter()
        try:
            plan = self.replanner.solve(measured, arrival=(0.0, max(self.arrival, measured.time + 1.0)),
                                        mass_scale=scale)
            if not plan.outcome.usable:  # late: arrive as soon as it can, within a minute more
                self.late += 1
                plan = self.replanner.solve(measured, arrival=(0.0, max(self.arrival, measured.time) + 60.0))
        finally:
            self.solve_seconds.append(time.perf_counter() - t0)
        self.iterations.append(plan.outcome.iterations)
        if not plan.outcome.usable:  # no plan reaches the stop: brake
            self.failures += 1
            self.last = -1.0
            return self.last
        k = interval_of(self.case.nodes, measured.position)
        self.last = handle_of(self.case.train, max(measured.speed, 0.0), plan.ft[k], plan.fb[k])
        return self.last
