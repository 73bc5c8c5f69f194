"""A terminal approach with a braking reserve, for any controller (the stop of SBPC and SPPC).

Farooqi 2018 proves SBPC's and SPPC's convergence to a terminal set, not to the stop: a plant off
the model ends metres from the mark (docs/closed_loop.md). RSPC's Alg. 6 row 3 stops on it:
the controller brakes in full when coasting one more sample would leave the train above the
stopping curve, and from then on brakes while that holds and coasts otherwise, re-checked every
sample on the measured position. :class:`TerminalApproach` gives any controller that final
approach: the stopping curve is integrated with the model's braking envelope less ``reserve``
(``kinematics.braking_curve``), so a train whose brakes are weaker than the model's (by less than
the reserve) still stops on the mark. Braking and coasting are the DAS levels -1 and 0, so the
approach needs no other handle on a driver-advisory loop.
"""
import numpy as np

from ecostudy.core import kinematics
from ecostudy.core.physics import davis_resistance
from ecostudy.core.plant import Plant


class TerminalApproach:
    """``inner`` (a controller with ``solve_seconds`` and ``record``) until the stopping curve of
    ``case`` (``ocp.problem.prepare``: segment, nominal train, grid) braking with (1 - ``reserve``)
    of the service brake is one ``sample_time`` ahead; then that curve (``engaged`` counts the
    samples)."""

    def __init__(self, inner, case, sample_time, reserve=0.2):
        self.inner, self.ts, self.nodes = inner, float(sample_time), case.nodes
        self.model = Plant(case.segment, case.train)
        reserved = case.train.with_brake_reserve(reserve)
        self.stop_sq = kinematics.braking_curve(case.segment, reserved, case.nodes,
                                                np.full_like(case.nodes, np.inf)) ** 2
        self.engaged = 0

    @property
    def solve_seconds(self):
        return self.inner.solve_seconds

    def must_brake(self, position, speed):
        """Coasting one more sample would leave the train above the stopping curve."""
        run = speed * self.ts
        x_mid = position + 0.5 * run
        coast = -(davis_resistance(speed, *self.model.davis) + self.model.grade_force(x_mid)) / self.model.mass
        return speed * speed + 2.0 * run * coast >= float(np.interp(position + run, self.nodes, self.stop_sq))

    def plan(self, measured):
        x, v = max(measured.position, 0.0), max(measured.speed, 0.0)
        if not self.engaged and not self.must_brake(x, v):
            return self.inner.plan(measured)
        self.engaged += 1
        brake = self.must_brake(x, v)
        self.inner.solve_seconds.append(0.0)
        self.inner.record("terminal_brake" if brake else "terminal_coast", 0.0)
        return -1.0 if brake else 0.0
