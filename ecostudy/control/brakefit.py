"""The train's braking measured during the run: the share of the model's service brake to stop on.

A terminal approach (``control.terminal``) brakes on a stopping curve integrated with a share c
of the model's service brake; the train stops on the mark when its own braking is at least c of
the model's, and a c below the train's own costs time: braking on the curve takes v / (c a_B)
instead of v / a_B (about 3 s at c = 0.8 from the Amsterdam case's 15.7 m/s). A fixed c must
cover the weakest train of the deviation bound d: a train (1 + d) heavier with (1 - d) of the
brake brakes at beta = (1 - d) / (1 + d) of the model (0.82 at d = 0.1). :class:`BrakeFit`
measures beta instead, as Yazhemsky 2017 eq. 6.8 sizes its reserve for what the model cannot see:

- every sample run under full service braking (u = -1, a DAS level; Farooqi 2018 §2.1, eq. 2.7
  for the motion) gives one reading of beta: the measured speed at the sample's end against the
  model's from the measured speed at its start, coasting and under full braking,
  beta_j = (v_coast - v_measured) / (v_coast - v_brake), so the model's resistance and grade
  stay the model's and all of the shortfall is put on the brake;
- after ``least`` readings, c = beta_hat - sigma - z sigma / sqrt(n): the mean less one
  reading's spread sigma (the acceleration disturbance the train meets on the rest of the curve,
  which the approach can only absorb by coasting: braking at c < beta leaves (beta - c) a_B spare)
  and z standard errors of the mean (the estimate's own error); sigma is the readings' sample
  deviation, at least ``spread`` (the Yazhemsky 2017 Ch. 10 acceleration disturbance, 0.05 m/s^2,
  over the model's 1.2 m/s^2 brake, rounded: 0.04), beta_hat clipped to the deviation bound's
  [(1 - d) / (1 + d), (1 + d) / (1 - d)];
- before that the prior 1 - ``reserve`` (the fixed reserve, covering the bound's weakest
  train); after, the fit on either side of it (a train at the bound's weakest gets
  0.82 - 2 sigma or so, more than the prior's 0.02 of spare braking).

Farooqi, Fagiano & Colaneri's convergence (Theorem 1: within gamma(d) of the terminal set) is the
plans' and is not changed; the approach's own argument (docs/closed_loop.md) holds for any curve
with c <= beta: from a state on or below the curve, full braking keeps the train below it and
coasting brings it back, so the only point at rest is the mark. A fitted curve that moves up
leaves the train below it (it coasts to it); one that moves down (a train found weaker than the
prior) may leave it above by the change, which full braking at beta > c recovers.
"""
import numpy as np

FULL = -1.0


class BrakeFit:
    """beta of ``model`` (a nominal ``core.plant.Plant``) from the full-brake samples, and the
    share c of the model's brake a stopping curve may use (``scale``); the prior 1 - ``reserve``
    until ``least`` readings."""

    def __init__(self, model, reserve=0.2, bound=0.1, spread=0.04, z=2.0, least=3):
        self.model, self.prior, self.spread, self.z, self.least = model, 1.0 - reserve, spread, z, int(least)
        self.bounds = ((1.0 - bound) / (1.0 + bound), (1.0 + bound) / (1.0 - bound))
        self.readings = []

    def observe(self, pieces, before, after):
        """A sample's ``pieces`` [(duration [s], handle)] run from the measured ``before`` to the
        measured ``after``: a reading of beta if the whole sample braked in full at speed (one
        that stood within it, or started below 1 m/s, tells the stop, not the brake)."""
        duration = sum(d for d, _ in pieces)
        if duration <= 0.0 or any(u > FULL + 1e-9 for _, u in pieces) or before.speed < 1.0 or after.speed < 0.5:
            return
        coast, brake = self.model.step(before, 0.0, duration), self.model.step(before, FULL, duration)
        drop = coast.state.speed - brake.state.speed
        if brake.stood is None and drop > 1e-3:
            self.readings.append((coast.state.speed - after.speed) / drop)

    @property
    def scale(self):
        """c: the share of the model's service brake the stopping curve uses (module docstring)."""
        n = len(self.readings)
        if n < self.least:
            return self.prior
        sigma = max(float(np.std(self.readings, ddof=1)), self.spread)
        beta = float(np.clip(np.mean(self.readings), *self.bounds))
        return beta - sigma - self.z * sigma / np.sqrt(n)
