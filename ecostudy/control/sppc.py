"""SPPC: shrinking-horizon parametrised predictive control (Farooqi 2018 Ch. 5, Alg. 3 and Alg. 4).

Every sample the controller re-solves the phases NLP of ``ocp/phases.py`` (eqs. 5.7-5.13: the
track cut into sectors of constant gradient, curve and limit, each with a fixed sequence of DAS
modes whose lengths are the decision variables) from the measured state to the end of the
segment, and applies the mode of the phase it is in (eq. 5.15: u(k) = g(v*, 0, k)). One movable
model and NL file serve the whole trip: the sectors behind the train get share 0 and the sector
it is in the share still to run (``ocp.restart.set_phases_start``); each solve starts from the
previous plan, which is the shifted solution of Prop. 5.2.1's recursive-feasibility argument.

The terminal set X_f is the stop at the end of the segment, at a standstill, by the timetabled
arrival (arriving early is allowed; least energy then uses the time). Variants:
- ``nominal`` (Alg. 3): that terminal set as a hard constraint; a sample where no plan reaches it
  falls back to the two-step relaxation and is counted (``softened``);
- ``two_step`` (Alg. 4, eqs. 5.22-5.23): first the smallest distance gamma from X_f that the
  measured state can still reach: in this space-domain model the end position is reached by
  construction, so gamma is the speed at the end of the segment (a second phases model minimising
  it and then the arrival time, the clock free, written once too); then least energy with the end
  speed within gamma + ``tolerance`` and the arrival by the timetable or, if that plan was later,
  by its arrival.
  A train past the last point from which full service braking stops it (the handle is held for a
  sample, so the plant brakes later than the plan) gets the plan that overruns least.
  Step one is skipped while its answer is known: where the time-optimal run from the measured state
  (``control.reach.EarliestStand``, closed form) stands on the mark ``STEP_ONE_MARGIN`` before
  the timetable less the tolerance, gamma = 0 and the arrival is no bound, so step two is solved
  directly with the end speed within the tolerance and the arrival by the timetable (the NLP step
  two would be given); step one runs when that solve gives no plan, or near the limit.

A sample without a usable solve applies the last accepted plan's mode at the measured position
(``control.fallback``), then, with no plan left, brakes in full. A train over the limit where it
is, on a downgrade where coasting does not slow it (``EarliestStand.coasting_over_limit``: a
train at the limit read a few hundredths over it), has no plan of the NLP, whose sectors brake
only last and whose every node ahead is under its limit: no NLP is solved (each such solve had
ended "infeasible" after 31-183 Ipopt iterations).

Modes (Farooqi 2018 §3.1.2): traction at a DAS level, coasting and full service braking are applied
as their handle; cruise as the handle that holds the planned force at the measured speed.
"""
import time

import numpy as np

from ecostudy.analysis.regimes import guess_from_result
from ecostudy.control.controllers import force_handle, from_departure
from ecostudy.control.fallback import Fallback
from ecostudy.control.reach import EarliestStand
from ecostudy.ocp import phases
from ecostudy.ocp.restart import set_end, set_phases_start
from ecostudy.ocp.session import WARM_START, Session
from ecostudy.ocp.solver import IPOPT

VARIANTS = ("nominal", "two_step")
OPTIONS = {**IPOPT["receding"], **WARM_START, **IPOPT["sppc"]}  # from the previous plan (``ocp.solver.IPOPT``)
# [s]: how much earlier than the timetable less the tolerance the closed-form earliest stand must be for
# Alg. 4's step one to be skipped (it differed from step one's NLP arrival by at most 0.02 s over
# draw 0 of studies/metro_monte_carlo.yaml, docs/closed_loop.md)
STEP_ONE_MARGIN = 0.1


class Sppc(Fallback):
    """``ato``: the energy-optimal run of the segment (``analysis.single.solve_run``), whose regimes
    start the first plan; ``arrival``: the timetabled arrival [s] on the trip's clock; ``points``:
    about how many intervals the phases share (``phases.substeps_for``); ``lookahead`` [s]: the
    run ahead whose mode is applied (about half a sample); ``brake_reserve``: the share of the
    braking envelope the plans leave unused (0.1: stop error +2.3 m -> +0.19 m on the Amsterdam
    case at T_s = 0.38 s; docs/closed_loop.md)."""

    def __init__(self, ato, arrival, points=300, variant="nominal", tolerance=0.05, lookahead=0.2, brake_reserve=0.1,
                 options=None):
        if variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, not {variant!r}")
        self.segment, self.arrival = ato.segment, float(arrival)
        # plans brake at (1 - brake_reserve) of the envelope: the handle is held for a sample, so the
        # plant starts braking up to a sample later than planned and needs the rest to stop on the mark
        self.train = ato.train.with_brake_reserve(brake_reserve)
        self.variant, self.tolerance, self.lookahead = variant, tolerance, lookahead
        self.options = {**OPTIONS, **(options or {})}
        t0 = time.perf_counter()
        layout = phases.Layout.make(phases.sectors(self.segment, self.train), phases.sequence(self.train), 1)
        layout.substeps = phases.substeps_for(points, len(layout.phases))
        self.layout, self.guess = layout, guess_from_result(ato, layout)
        self.model = phases.build(self.segment, self.train, layout, self.guess, running_time=self.arrival,
                                  movable=True)
        self.session = Session(self.model)
        self.closest = None  # the end-speed model of the two-step relaxation, written when first needed
        self.reach = EarliestStand(self.segment, self.train)
        self.skipped = 0  # samples whose step one was known (skipped)
        self.setup_seconds = time.perf_counter() - t0
        self.iterations, self.modes, self.softened = [], [], 0
        self.unsolved = []  # (position, speed, clock, Ipopt status) of every solve without a plan
        self._start_records()

    def _solve(self, session, measured, arrival, end_speed=(0.0, 0.0)):
        set_phases_start(session, session.model, self.layout, measured)
        set_end(session, session.model, end_speed, arrival)
        outcome = session.solve(self.options)
        self.iterations.append(outcome.iterations)
        if not outcome.usable:
            self.unsolved.append((measured.position, measured.speed, measured.time, outcome.status))
        return outcome

    def _closest(self, measured):
        """Step one of Alg. 4 (5.22): (the smallest end speed gamma [m/s], that plan's arrival [s])."""
        if self.closest is None:
            model = phases.build(self.segment, self.train, self.layout, self.guess, running_time=self.arrival,
                                 objective="end_speed", movable=True)
            self.closest = Session(model)
            # from the last plan rather than the ATO guess: with step one skipped, it is first needed
            # late in the run (94-297 Ipopt iterations from the guess on draws 0-2 of metro_monte_carlo.yaml)
            place = {var.name: i for i, var in enumerate(self.session.variables)}
            self.closest.x = self.session.x[[place[var.name] for var in self.closest.variables]]
        m = self.closest.model
        outcome = self._solve(self.closest, measured, (measured.time, measured.time + 3600.0), m.base_bounds["v"][-1])
        return (float(m.v[len(m.K) - 1].value), float(m.T.value)) if outcome.usable else None

    def _relaxed(self, measured, skip=False):
        if skip and measured.time + self.reach(measured.position, measured.speed) \
                <= self.arrival - self.tolerance - STEP_ONE_MARGIN:
            outcome = self._solve(self.session, measured, (measured.time, self.arrival), (0.0, self.tolerance))
            if outcome.usable:
                self.skipped += 1
                return outcome
        closest = self._closest(measured)
        if closest is None:
            return None
        gamma, arrival = closest
        return self._solve(self.session, measured, (measured.time, max(self.arrival, arrival + self.tolerance)),
                           (0.0, gamma + self.tolerance))

    def plan(self, measured):
        measured = from_departure(measured)  # a noisy reading at the stand may be behind the start
        if measured.position >= self.segment.distance - 0.05:
            self.without_solve("final")
            return -1.0
        t0, softened, outcome = time.perf_counter(), (), None
        # over the limit where coasting does not slow the train: no plan exists, no NLP is solved
        if not self.reach.coasting_over_limit(measured.position, measured.speed):
            if self.variant == "nominal":
                outcome = self._solve(self.session, measured, (measured.time, self.arrival))
                if not outcome.usable:
                    self.softened += 1
                    softened = ("terminal_set",)
                    outcome = self._relaxed(measured)
            else:
                outcome = self._relaxed(measured, skip=True)
        status, seconds, handle = self.settle(outcome, t0, measured)
        if handle is not None:
            return handle
        lengths, _, _, _, ft, fb = phases.solution(self.model, self.layout)
        x = phases.node_positions(self.layout, lengths, origin=measured.position)
        self.accept(lambda later: self._mode_at(x, ft, fb, later) if x[0] <= later.position < x[-1] else None)
        self.record(status, seconds, softened=softened)
        return self._mode_at(x, ft, fb, measured)

    def _mode_at(self, x, ft, fb, measured):
        """The handle of the plan's phase (node positions ``x``, forces ``ft``, ``fb``) the train is
        in: the phase covering most of the next ``lookahead`` seconds' run (an interior-point
        solution leaves skipped phases a few micrometres long, so "the first phase of positive
        length" would often be a skipped one)."""
        n = self.layout.substeps
        ahead = measured.position + max(measured.speed * self.lookahead, 0.05)
        starts, ends = x[:-1:n], x[n::n]
        cover = np.minimum(ends, ahead) - np.maximum(starts, measured.position)
        q = int(np.argmax(cover))
        mode = self.layout.phases[q][1]
        self.modes.append(mode.kind if mode.kind != "traction" else f"traction {mode.level:g}")
        if mode.kind == "cruise":
            return force_handle(self.train, max(measured.speed, 0.0), ft[q * n] - fb[q * n])
        return float(mode.level)
