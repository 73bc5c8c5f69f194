"""SBPC: shrinking-horizon move-blocking predictive control (Farooqi 2018 Ch. 4, Farooqi, Fagiano & Colaneri).

Every sample k (T_s) the controller solves the FHOCP of ``ocp.blocked`` from the measured state
to the terminal sample k_f and applies the first predicted input (Alg. 1). One model and NL file
serve the whole trip; each solve starts from the previous solution, which with blocks aligned to
absolute multiples of L is exactly the shifted tail of Farooqi 2018 Prop. 4.2.1.

Variants:
- ``nominal`` (Alg. 1): the terminal set as a hard constraint (gamma = 0). When the plant has
  drifted so far that no input reaches it, the solve falls back to the two-step relaxation for
  that sample and counts it (``softened``);
- ``two_step`` (Alg. 2): first the smallest reachable terminal distance gamma (4.18), then the
  least energy within it (4.19);
- ``multi`` (4.31): least energy plus omega gamma in one solve.
After k_f, or at the stop, the controller brakes in full. A sample without a usable solve applies
the last accepted plan's handle for that sample (``control.fallback``; it covers every sample to
k_f), for at most ``fallback.SHIFT_SAMPLES`` samples in a row, then brakes in full.
"""
import dataclasses
import time

from ecostudy.control.fallback import Fallback
from ecostudy.core.types import State
from ecostudy.core.kinematics import samples
from ecostudy.ocp.blocked import Blocked, time_guess
from ecostudy.ocp.condensed import Condensed
from ecostudy.ocp.session import WARM_START
from ecostudy.ocp.solver import IPOPT

VARIANTS = ("nominal", "two_step", "multi")
# the FHOCP with the states as variables (Ipopt on ``ocp.blocked``), or condensed to the block
# handles (SLSQP on ``ocp.condensed``, as Farooqi 2018's fmincon: the time of a solve falls with L)
TRANSCRIPTIONS = ("simultaneous", "condensed")
# each solve starts from the previous one (the shifted tail), primal and dual (docs/closed_loop.md)
OPTIONS = {**IPOPT["receding"], **WARM_START}


class Sbpc(Fallback):
    """``case``: a prepared case (``ocp.problem.prepare``); ``guess_speeds``: a speed profile on its
    grid (e.g. the ATO optimum's) for the first solve; ``omega``: the weight of eq. 4.31 on the
    terminal distance [per metre], with J in kJ (Farooqi 2018 §4.4 uses 3505); ``transcription``: one
    of ``TRANSCRIPTIONS``."""

    def __init__(self, case, running_time, sample_time, block, guess_speeds, variant="nominal", omega=3505.0,
                 tolerance=1e-3, options=None, brake_reserve=0.0, transcription="simultaneous"):
        if variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, not {variant!r}")
        if transcription not in TRANSCRIPTIONS:
            raise ValueError(f"transcription must be one of {TRANSCRIPTIONS}, not {transcription!r}")
        self.case, self.ts, self.variant, self.omega, self.tolerance = case, sample_time, variant, omega, tolerance
        self.kf = samples(running_time, sample_time)
        self.options = {**OPTIONS, **(options or {})}
        # plan with ``brake_reserve`` of the brake held back; the handle is applied as planned, so a
        # train braking weaker than the model's still has the rest (the reserve of SPPC and RSPC)
        case = self.case = dataclasses.replace(case, train=case.train.with_brake_reserve(brake_reserve))
        t0 = time.perf_counter()
        guess = time_guess(case, guess_speeds, self.kf, sample_time)
        if transcription == "simultaneous":
            self.program = Blocked(case, sample_time, self.kf, block, guess, self.options)
        else:
            self.program = Condensed(case, sample_time, self.kf, block, guess)
        for _ in range(2):  # settle the grade and bounds on the first plan's own positions
            self.program.start(0, State())
            if self.program.solve(0.0, 1.0, None).usable:
                self.program.follow()
        self.setup_seconds = time.perf_counter() - t0
        self.gammas, self.iterations, self.softened = [], [], 0
        self._start_records()

    def _solve(self, alpha, omega, gamma_max):
        outcome = self.program.solve(alpha, omega, gamma_max)
        self.iterations.append(outcome.iterations)
        return outcome

    def _smallest_gamma(self):
        outcome = self._solve(0.0, 1.0, None)  # 4.18: the closest the terminal state can come
        if not outcome.usable:
            return None
        gamma = self.program.gamma
        return self._solve(1.0, 0.0, gamma + self.tolerance)  # 4.19: least energy within it

    def plan(self, measured):
        k = self._sample(measured)
        if k >= self.kf or measured.position >= self.case.segment.distance - 0.05:
            self.without_solve("final")
            return -1.0
        t0, softened = time.perf_counter(), ()
        self.program.start(k, measured)
        if self.variant == "nominal":
            outcome = self._solve(1.0, 0.0, 0.0)
            if not outcome.usable:
                self.softened += 1
                softened = ("terminal_set",)
                outcome = self._smallest_gamma()
        elif self.variant == "two_step":
            outcome = self._smallest_gamma()
        else:
            outcome = self._solve(1.0, self.omega, None)
        status, seconds, handle = self.settle(outcome, t0, measured)
        if handle is not None:
            return handle
        self.gammas.append(self.program.gamma)
        self.program.follow()  # the next sample's grade and bounds follow this prediction
        planned = self.program.handles(k)
        self.accept(lambda later: float(planned[j]) if 0 <= (j := self._sample(later) - k) < planned.size else None)
        self.record(status, seconds, softened=softened)
        return float(planned[0])

    def _sample(self, measured):
        return int(round(measured.time / self.ts))
