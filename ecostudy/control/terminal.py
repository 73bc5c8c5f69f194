"""A terminal approach with a braking reserve, for any controller (the stop of SBPC and SPPC).

Farooqi 2018 proves SBPC's and SPPC's convergence to a terminal set, not to the stop: a plant off
the model ends metres from the mark (docs/closed_loop.md). RSPC's Alg. 6 row 3 stops on it:
the controller brakes in full when coasting one more sample would leave the train above the
stopping curve, and from then on brakes while that holds and coasts otherwise, re-checked every
sample on the measured position. :class:`TerminalApproach` gives any controller that final
approach: the stopping curve is integrated with the model's braking envelope less ``reserve``
(``kinematics.braking_curve``), so a train whose brakes are weaker than the model's (by less than
the reserve) still stops on the mark. Braking and coasting are the DAS levels -1 and 0, so the
approach needs no other handle on a driver-advisory loop. With ``fit`` the reserve is the prior
only: the curve is re-integrated with the share of the brake the train's full-brake samples show
(``control.brakefit``), so a train braking as the model does stops on a curve near its own brake
instead of 1 - reserve of it (the fixed reserve's lateness).

Before the approach, a handle that could take the train over the speed limit within the sample
is replaced by coasting, or full braking where coasting could too (``capped`` counts them): a
plan's mode is held for a whole sample and, with a computation delay, planned a sample ahead, so
a plan that accelerates up to the limit on the model overshoots on a train up to ``boost``
stronger, and a DAS loop rounds a plan's partial braking on a downgrade to coasting (SPPC
overspeeds of 1-2.6 km/h at +-10 %). The check: the model's speed at the sample's end under the
handle (traction a DAS level higher, ``level_step``; any handle above -0.5 as coasting), its gain
over the sample enlarged by ``boost``, against the lowest limit within the sample's run.
"""
import numpy as np

from ecostudy.control.brakefit import BrakeFit
from ecostudy.core import kinematics
from ecostudy.core.physics import davis_resistance
from ecostudy.core.plant import Plant


class TerminalApproach:
    """``inner`` (a controller with ``solve_seconds`` and ``record``) until the stopping curve of
    ``case`` (``ocp.problem.prepare``: segment, nominal train, grid) braking with (1 - ``reserve``)
    of the service brake is one ``sample_time`` ahead; then that curve (``engaged`` counts the
    samples). ``fit``: (1 - ``reserve``) is the prior of a :class:`BrakeFit` (``bound``: the
    deviation bound d) fed by ``observe``, and the curve follows its share (``scales``: the share
    at every sample of the approach)."""

    def __init__(self, inner, case, sample_time, reserve=0.2, boost=0.25, level_step=0.125, fit=False, bound=0.1):
        self.inner, self.ts, self.nodes, self.segment = inner, float(sample_time), case.nodes, case.segment
        self.boost, self.level_step, self.capped, self.train = boost, level_step, 0, case.train
        self.model = Plant(case.segment, case.train)
        self.fit = BrakeFit(self.model, reserve, bound) if fit else None
        self.scale = 1.0 - reserve
        self.prior_sq = self.stop_sq = self._curve(self.scale)
        self.engaged, self.scales = 0, []

    def _curve(self, scale):
        """The stopping curve's squared speeds on the grid, braking at ``scale`` of the service brake."""
        train = self.train.with_brake_reserve(1.0 - scale)
        return kinematics.braking_curve(self.segment, train, self.nodes, np.full_like(self.nodes, np.inf)) ** 2

    def observe(self, pieces, before, after):
        """The loop's report of a sample (``run_loop``): the pieces run, the measured states at its
        ends; with ``fit`` the curve is re-integrated when the fitted share moves by 0.001 or more."""
        if self.fit is None:
            return
        self.fit.observe(pieces, before, after)
        scale = round(self.fit.scale, 3)
        if scale != self.scale:
            self.scale, self.stop_sq = scale, self._curve(scale)

    @property
    def solve_seconds(self):
        return self.inner.solve_seconds

    def must_brake(self, position, speed, curve=None):
        """Coasting one more sample would leave the train above the stopping curve (``curve``: its
        squared speeds on the grid; the fitted one if not given)."""
        run = speed * self.ts
        x_mid = position + 0.5 * run
        coast = -(davis_resistance(speed, *self.model.davis) + self.model.grade_force(x_mid)) / self.model.mass
        return speed * speed + 2.0 * run * coast >= float(np.interp(position + run, self.nodes,
                                                                             self.stop_sq if curve is None else curve))

    def plan(self, measured):
        x, v = max(measured.position, 0.0), max(measured.speed, 0.0)
        # engaged on the lower of the prior's curve and the fitted one: a train found to brake better
        # than the prior coasts from the prior's curve to its own (half the braking time's loss)
        if not self.engaged and not (self.must_brake(x, v) or self.must_brake(x, v, self.prior_sq)):
            return self.below_limit(measured, float(self.inner.plan(measured)))
        self.engaged += 1
        self.scales.append(self.scale)
        brake = self.must_brake(x, v)
        self.inner.without_solve("terminal_brake" if brake else "terminal_coast")
        return -1.0 if brake else 0.0

    def below_limit(self, measured, handle):
        """``handle``, or the highest of coasting (0) and full braking (-1) that keeps the train
        under the limit in this sample where it could not (a DAS loop rounds a partial brake to
        coasting, so any handle above -0.5 is checked as coasting)."""
        if handle <= -0.5:
            return handle
        tried = (handle, 0.0) if handle > 0.0 else (handle,)
        safe = next((u for u in tried if self._stays_below(measured, u)), -1.0)
        self.capped += safe != handle
        return safe

    def _stays_below(self, measured, handle):
        """The speed at the sample's end under ``handle`` (a DAS level higher if traction), its
        gain enlarged by ``boost``, is within the lowest limit over the sample's run."""
        applied = min(handle + self.level_step, 1.0) if handle > 0.0 else 0.0
        state = self.model.step(measured, applied, self.ts).state
        v = max(measured.speed, 0.0)
        fastest = v + (1.0 + self.boost) * max(state.speed - v, 0.0)
        run = np.clip(measured.position + np.linspace(0.0, fastest * self.ts + 1.0, 9), 0.0, self.segment.distance)
        return fastest <= float(np.min(self.segment.limit(run)))
