"""Air-brake propagation as TrainDy-class simulators model it at its simplest: the brake pipe signal
runs from the head at a speed c (UIC leaflet 540: at least 250 m/s), so a wagon at distance x_i
behind the head's front sees a command change x_i / c later; its brake force then follows the
command as a first-order lag, time constant tau_b while it rises and tau_r while it falls (Cantone,
"TrainDy: the new Union Internationale des Chemins de Fer software for freight train
interoperability", Proc. IMechE F 225, 2011; Cole et al., "Modelling, simulation and applications
of longitudinal train dynamics", Vehicle System Dynamics 55(10), 2017, §4). Brake forces are <= 0.

The command is held over a step (the controller's sample), so within a step starting at t_k with
command u_k after u_k-1, wagon i's force is, s = t - t_k, d_i = x_i / c < the step:

    b_i(s) = u_k-1 + (b_i(t_k) - u_k-1) exp(-s / tau)               s < d_i
    b_i(s) = u_k + (b_i(t_k + d_i) - u_k) exp(-(s - d_i) / tau)     s >= d_i

tau = tau_b where the target is the larger brake force (|target| >= |b| at the start of the piece),
else tau_r: closed form, continuous in time, so the plant's integrator needs no extra state.
"""
import numpy as np


def signal_delays(consist, signal_speed):
    """d_i [s]: when the brake signal reaches each car's centre, from the head's front."""
    centres = np.cumsum(consist.length) - 0.5 * consist.length
    return centres / signal_speed


def _lag(start, target, elapsed, brake):
    """First-order approach of ``start`` to ``target`` after ``elapsed`` [s] (``brake`` an AirBrake)."""
    tau = np.where(np.abs(target) >= np.abs(start), brake.build_up, brake.release)
    return target + (start - target) * np.exp(-np.maximum(elapsed, 0.0) / tau)


class BrakePipe:
    """The wagons' brake forces over one step: at its start ``forces`` [N], the command before
    ``previous`` and from the step on ``current`` [N per car], ``delays`` [s], ``brake`` an
    :class:`~ecostudy.core.types.AirBrake`."""

    def __init__(self, forces, previous, current, delays, brake):
        self.forces, self.previous, self.current = (np.asarray(a, float) for a in (forces, previous, current))
        self.delays, self.brake = delays, brake
        self.reached = _lag(self.forces, self.previous, delays, brake)  # b_i(t_k + d_i)

    def at(self, elapsed):
        """b_i [N] ``elapsed`` [s] after the step's start."""
        before = _lag(self.forces, self.previous, elapsed, self.brake)
        after = _lag(self.reached, self.current, elapsed - self.delays, self.brake)
        return np.where(elapsed < self.delays, before, after)
