"""What a controller does when a sample's solve gives no plan to drive, and what it records per step.

Every controller keeps its last accepted plan. A step whose solve is unusable (no optimum, the
iteration cap, an inexact braking plan) or over its time budget applies that plan shifted to the
present, i.e. what it planned for this sample (``shifted_plan``), as long as the plan still covers
the measured state and it has not been used more than ``shift_samples`` times in a row. Only
without such a plan does the controller brake: with the braking reserve of Yazhemsky 2017
eq. 6.8 (``reserve``: the share of the service brake the plans held back, used when a plan
needs more braking than it was allowed) or, with nothing else left, in full (``full_brake``).

Per call of ``plan`` a controller records a :class:`Step`; ``steps.csv`` of a closed-loop run
is these records next to the loop's states.
"""
import time
from typing import NamedTuple, Optional

KINDS = ("shifted_plan", "reserve", "full_brake")
# the statuses of steps that drove no solver's plan (a rule's step, or a step the fallback drove)
SOLVELESS = ("final", "replay", "wait", "none", "terminal_brake", "terminal_coast", "ok", "stopping_curve",
             "no_sequence", "no_plan", "over_budget")
SHIFT_SAMPLES = 10  # a plan older than this many samples is not driven any more


class Step(NamedTuple):
    """One call of a controller's ``plan``: the solver's status (``final`` inside the final
    approach, ``none`` without a solve), the solve time [s], the relaxation gap max |rho s - 1|
    (convex programs), the fallback used (one of ``KINDS``, or None), the rows softened
    (e.g. ``arrival_window``, ``terminal_set``; '' for none) and the mass estimate (a multiple of
    the model's; None without an estimator)."""

    status: str
    seconds: float
    gap: Optional[float] = None
    fallback: Optional[str] = None
    softened: str = ""
    mass_estimate: Optional[float] = None


class Fallback:
    """Mixin of the controllers: the last accepted plan, the fallback chain and the step records.

    A controller calls :meth:`accept` with ``handle_at(measured) -> handle or None`` (None: the
    plan does not hold for that state) after every usable solve, :meth:`fall_back` when a step has
    no plan, and :meth:`record` once per call of ``plan`` (:meth:`without_solve` for a step that
    solves nothing, :meth:`settle` after a step's solves)."""

    shift_samples = SHIFT_SAMPLES
    plans_from = None  # the solved run (a RunResult) it replays or plans from, if any: part of a run's status
    plan_ended = None  # how Clarabel ended the one convex plan it replays (``open_loop``), if any: likewise

    def _start_records(self):
        self.step_log, self.last_plan, self.shifts = [], None, 0
        self.fallbacks = dict.fromkeys(KINDS, 0)
        self.solve_seconds = []  # per call of ``plan``
        self.failures = 0  # steps without a usable plan

    def accept(self, handle_at):
        """Keep ``handle_at`` as the plan to fall back on."""
        self.last_plan, self.shifts = handle_at, 0

    def fall_back(self, measured, reserve=None, shifted=True):
        """(handle, kind) for a step without a usable plan: the last plan shifted to ``measured``
        if it holds there (``shifted=False``: the step's solve showed that no plan does), else
        ``reserve`` (a handle, the eq. 6.8 reserve) if given, else full braking. The use is
        counted by kind."""
        if shifted and self.last_plan is not None and self.shifts < self.shift_samples:
            handle = self.last_plan(measured)
            if handle is not None:
                self.shifts += 1
                return self._count(float(handle), "shifted_plan")
        if reserve is not None:
            return self._count(float(reserve), "reserve")
        return self._count(-1.0, "full_brake")

    def without_solve(self, status, estimator=None):
        """Record a step that solves nothing (``final``, ``replay``, ``wait``, a terminal rule's)."""
        self.solve_seconds.append(0.0)
        self.record(status, 0.0, estimator=estimator)

    def settle(self, outcome, t0, measured):
        """After a step's solves, started at ``t0`` (``outcome``: the last one's, None for none that
        gives a plan): their time kept; (status, seconds, handle), the handle the fallback's, with
        the failure counted and the step recorded, when ``outcome`` is not usable, else None (the
        controller accepts its plan and records the step)."""
        seconds = time.perf_counter() - t0
        self.solve_seconds.append(seconds)
        status = "no_plan" if outcome is None else outcome.status
        if outcome is not None and outcome.usable:
            return status, seconds, None
        self.failures += 1
        handle, kind = self.fall_back(measured)
        self.record(status, seconds, fallback=kind)
        return status, seconds, handle

    def _count(self, handle, kind):
        self.fallbacks[kind] += 1
        return handle, kind

    def record(self, status, seconds, gap=None, fallback=None, softened=(), estimator=None):
        """One :class:`Step` (``softened``: the names of the rows softened this step)."""
        mass = getattr(estimator, "estimate", None) if estimator is not None else None
        self.step_log.append(Step(str(status), float(seconds), None if gap is None else float(gap), fallback,
                               " ".join(softened), mass))
