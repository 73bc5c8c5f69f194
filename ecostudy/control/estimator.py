"""Mass estimators of the closed loop (``control.loop.run_loop`` calls ``observe`` once a cycle).

``MassEstimator``: the scalar Kalman filter of the train's mass (Yazhemsky 2017, "A real-time
capable adaptive optimal controller for a commuter train", §10.3, eqs. 10.5-10.8).

The state is the inverse mass, here normalised by the model's mass: e = M_model / M (eq. 10.5),
constant between cycles (M_A = 1, M_B = 0, eq. 10.6c). Each control cycle measures

    l_j = a_measured + g_j = C_j e_j + noise,     C_j = (F_applied - R_Davis(v)) / M_model

where g_j is the grade and curve acceleration (it does not depend on the mass: the static mass
scales with the inertial one) and C_j the net force the train was commanded over the last cycle,
per model mass (eq. 10.6b, 10.6e in this model's units: Yazhemsky 2017 writes the resistance per
unit mass, ecostudy as a force). The update is eqs. 10.7/10.8, with the two defects of the printed
text mended: eq. 10.7 swaps the process noise H and the measurement noise R (here: the prior
covariance grows by the process noise ``process``, the innovation covariance adds the measurement
noise ``measurement``), and eq. 10.8c is read as e + chi (l - C e).

``StateEstimator`` (``estimator: state`` in a study): an extended Kalman filter of position,
speed, inverse mass and the acceleration disturbance (:mod:`ecostudy.control.ekf`), for the
case the scalar filter cannot handle: a disturbance held over many cycles (Yazhemsky 2017 §10.1
holds it 1 s) that the controller reacts to, so that the commanded force correlates with it.
"""
from dataclasses import dataclass, field

from ecostudy.core.physics import davis_resistance


def net_per_mass(nominal, u, v):
    """The net force [N] of handle ``u`` at speed ``v`` on the model train, per model mass [m/s^2]
    (C_j of eq. 10.6d, with Davis resistance)."""
    train = nominal.train
    davis = davis_resistance(v, *train.davis)
    ft, fb = nominal.forces(v, u, davis)
    return (ft - fb - davis) / train.mass


@dataclass
class MassEstimator:
    """``estimate``: the mass as a multiple of the model's (1 / e). Cycles with a net force below
    ``min_force`` per model mass [m/s^2] carry no information and are skipped (a coasting train on
    level track, a standing train)."""

    covariance: float = 0.01     # E_0|0 of e
    measurement: float = 0.01    # R: variance of the measured acceleration [m^2/s^4]
    process: float = 1e-6        # H: how fast the mass may drift per cycle
    min_force: float = 0.05      # [m/s^2]
    e: float = 1.0               # e_0|0 = the model's mass over the initial guess
    history: list = field(default_factory=list)

    @property
    def estimate(self):
        return 1.0 / self.e

    def observe(self, nominal, u, before, after, reading):
        """One cycle from the measured states ``before`` and ``after`` the model train ``nominal``
        (a ``core.plant.Plant``) ran handle ``u``, and the accelerometer's ``reading`` of the
        cycle's mean acceleration: C_j as the mean of the cycle's ends (trapezoid)."""
        net = 0.5 * sum(net_per_mass(nominal, u, max(v, 0.0)) for v in (before.speed, after.speed))
        grade = nominal.grade_force(before.position) / nominal.train.mass
        return self.update(reading, grade, net, before.position)

    def update(self, acceleration, grade_acceleration, net_force_per_mass, position=None):
        """One cycle (eqs. 10.8a-e); returns the mass estimate as a multiple of the model's."""
        c = float(net_force_per_mass)
        if abs(c) >= self.min_force:
            prior = self.covariance + self.process                       # 10.8a
            gain = c * prior / (c * c * prior + self.measurement)         # 10.8b
            self.e += gain * (acceleration + grade_acceleration - c * self.e)  # 10.8c, mended
            self.covariance = prior * (1.0 - c * gain)                     # 10.8d
        self.history.append((position, self.estimate))
        return self.estimate                                               # 10.8e
