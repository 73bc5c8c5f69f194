"""An extended Kalman filter of the train's position, speed, mass and acceleration disturbance.

Yazhemsky 2017 ("A real-time capable adaptive optimal controller for a commuter train") closes
§10.3 with the scalar mass filter of eqs. 10.5-10.8 (``estimator.MassEstimator``) and names an
estimator of more than one parameter as the next step. The scalar filter reads each cycle's
acceleration as C_j e + white noise (eq. 10.6b); the disturbance of §10.1 is held for 1 s, and a
controller that holds a speed answers it within a cycle or two, so the commanded force C_j
correlates with the error term and the estimate drifts (a closed-loop identification bias:
docs/closed_loop.md, "The mass estimator over 20 noise seeds").

This filter carries the disturbance as a state. State s = (x, v, e, d): position [m], speed
[m/s], e = M_model / M (eq. 10.5) and the acceleration disturbance d [m/s^2], a first-order
Gauss-Markov process with the noise's hold time as its time constant (d_k+1 = phi d_k + w,
phi = exp(-T / tau), var w = sigma_d^2 (1 - phi^2)). The model is eq. 10.6b's read as dynamics:

    a = C(v, u) e - g(x) + d,    x_k+1 = x_k + T v_k + T^2 a / 2,    v_k+1 = v_k + T a

with C(v, u) the net force of the handle per model mass (eq. 10.6d with Davis resistance) and
g the grade and curve acceleration. Per cycle: the accelerometer's reading of the last cycle's
mean acceleration updates the state at the cycle's start (measurement a at the cycle's mid
speed), the state is predicted to the cycle's end with the Jacobian of the model, and the
measured position and speed update it there. The mass is constant on a trip: no process noise
on e.
"""
import math

import numpy as np

from ecostudy.control.estimator import net_per_mass

FLOOR = 1e-3  # the smallest standard deviation a sensor is given (a noiseless sensor makes R singular)


class StateEstimator:
    """EKF of (position, speed, e, disturbance); ``estimate``: the mass as a multiple of the
    model's (1 / e). The noise levels are standard deviations (Yazhemsky 2017 §10.1's defaults):
    ``position`` [m], ``speed`` [m/s], ``accelerometer`` [m/s^2], ``disturbance`` [m/s^2] held
    about ``hold`` [s]; ``covariance``: the prior variance of e (E_0|0 of eq. 10.7b)."""

    def __init__(self, position=0.01, speed=0.01, accelerometer=0.01, disturbance=0.05, hold=1.0,
                 covariance=0.01, model_error=1e-3):
        self.r_xv = np.diag([max(position, FLOOR) ** 2, max(speed, FLOOR) ** 2])
        self.r_a = max(accelerometer, FLOOR) ** 2
        self.sigma_d, self.hold, self.model_error = max(disturbance, FLOOR), max(hold, 1e-3), model_error
        self.p_e = covariance
        self.s, self.P, self.history = None, None, []

    @classmethod
    def for_noise(cls, noise):
        """The filter for a loop's ``core.plant.Noise`` (its standard deviations; a disturbance drawn
        every step is given the hold of one 0.1 s cycle)."""
        return cls(noise.position, noise.speed, noise.accelerometer, noise.acceleration, noise.period or 0.1)

    @property
    def estimate(self):
        return 1.0 / self.s[2] if self.s is not None else 1.0

    def _acceleration(self, nominal, u, s, dt):
        """(a, da/dv, da/de) at the cycle's mid speed, with the state ``s``."""
        x, v, e, d = s
        grade = nominal.grade_force(x) / nominal.train.mass
        c0 = net_per_mass(nominal, u, max(v, 0.0))
        mid = max(v + 0.5 * dt * (c0 * e - grade + d), 0.0)
        c = net_per_mass(nominal, u, mid)
        h = 1e-3
        slope = (net_per_mass(nominal, u, mid + h) - net_per_mass(nominal, u, max(mid - h, 0.0))) / (mid + h - max(mid - h, 0.0))
        return c * e - grade + d, slope * e, c

    def observe(self, nominal, u, before, after, reading):
        """One cycle: the model train ``nominal`` (a ``core.plant.Plant``) ran handle ``u`` from the
        measured state ``before`` to the measured state ``after``; ``reading``: the accelerometer's
        reading of the cycle's mean acceleration. Returns the mass estimate."""
        dt = after.time - before.time
        if self.s is None:
            self.s = np.array([before.position, max(before.speed, 0.0), 1.0, 0.0])
            self.P = np.diag([self.r_xv[0, 0], self.r_xv[1, 1], self.p_e, self.sigma_d ** 2])
        if dt > 0.0:
            self._accelerometer(nominal, u, dt, reading)
            self._predict(nominal, u, dt)
            self._update(np.array([after.position, after.speed]), np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]]),
                         self.r_xv, self.s[:2])
        self.history.append((before.position, self.estimate))
        return self.estimate

    def _accelerometer(self, nominal, u, dt, reading):
        a, da_dv, c = self._acceleration(nominal, u, self.s, dt)
        H = np.array([[0.0, da_dv, c, 1.0]])
        self._update(np.array([reading]), H, np.array([[self.r_a]]), np.array([a]))

    def _predict(self, nominal, u, dt):
        a, da_dv, c = self._acceleration(nominal, u, self.s, dt)
        phi = math.exp(-dt / self.hold)
        x, v, e, d = self.s
        self.s = np.array([x + dt * v + 0.5 * dt * dt * a, max(v + dt * a, 0.0), e, phi * d])
        F = np.array([[1.0, dt + 0.5 * dt * dt * da_dv, 0.5 * dt * dt * c, 0.5 * dt * dt],
                      [0.0, 1.0 + dt * da_dv, dt * c, dt],
                      [0.0, 0.0, 1.0, 0.0],
                      [0.0, 0.0, 0.0, phi]])
        q = (self.model_error * dt) ** 2
        Q = np.diag([q * dt * dt, q, 0.0, self.sigma_d ** 2 * (1.0 - phi * phi)])
        self.P = F @ self.P @ F.T + Q

    def _update(self, z, H, R, predicted):
        S = H @ self.P @ H.T + R
        K = self.P @ H.T @ np.linalg.inv(S)
        self.s = self.s + K @ (z - predicted)
        I_KH = np.eye(4) - K @ H
        self.P = I_KH @ self.P @ I_KH.T + K @ R @ K.T  # Joseph form: stays symmetric positive
