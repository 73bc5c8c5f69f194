"""Zhang & Zhuan eq. 10: a discrete Kalman estimator of every (virtual) car's speed and coupler
extension from the locomotives' measured speeds (eq. 3: C picks the locomotives' speed rows),
in the one-step predictor form of the paper:

    x^(k+1|k) = A x^(k|k-1) + B u'(k) + L(k) (y(k) - C x^(k|k-1))
    L(k) = A P C^T (R + C P C^T)^-1,  P(k+1) = A (P - P C^T (R + C P C^T)^-1 C P) A^T + Q

with Q = q I and R = r I. The paper uses q = 50, r = 0.01 in units it does not state; in SI
(m/s, m) those leave the middle of the ore train's estimate 0.8 m/s off after 8 samples, so the
defaults here are q = 1e-3, r = 1e-4 (measured: docs/heavyhaul.md); a study sets its own
(``observer_q``, ``observer_r``). Sampled at Ts = 20 s the
coupler modes alias, yet the pair (A, C) stays observable (rank 43 of 43 for the 22 virtual cars);
the estimate converges within about 15 samples. Inputs u' are the shifted efforts of eq. 2 [N].
"""
import numpy as np

from ecostudy.io.heavyhaulfile import OBSERVER_Q, OBSERVER_R


class KalmanObserver:
    def __init__(self, model, kinds, q=OBSERVER_Q, r=OBSERVER_R, estimate=None, covariance=1.0):
        n = len(kinds)
        self.model = model
        self.C = np.zeros((sum(k == "locomotive" for k in kinds), 2 * n - 1))
        for row, i in enumerate(i for i, k in enumerate(kinds) if k == "locomotive"):
            self.C[row, i] = 1.0
        self.Q = q * np.eye(2 * n - 1)
        self.R = r * np.eye(self.C.shape[0])
        self.x = np.zeros(2 * n - 1) if estimate is None else np.asarray(estimate, float).copy()
        self.P = covariance * np.eye(2 * n - 1)

    def update(self, measured, shifted_input):
        """Take the locomotives' measured speeds y(k) and the applied u'(k); returns x^(k+1|k)."""
        A, B, C = self.model.A, self.model.B, self.C
        S = self.R + C @ self.P @ C.T
        L = A @ self.P @ C.T @ np.linalg.inv(S)
        self.x = A @ self.x + B @ shifted_input + L @ (np.asarray(measured, float) - C @ self.x)
        self.P = A @ (self.P - self.P @ C.T @ np.linalg.solve(S, C @ self.P)) @ A.T + self.Q
        return self.x.copy()
