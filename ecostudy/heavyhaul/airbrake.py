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
else tau_r: closed form, continuous in time, so the plant's integrator needs no extra state. A step
shorter than the signal's run to the last wagon (the terminal approach's 1 s pieces against 9.8 s on
the ore train) leaves earlier commands still travelling: each wagon then sees, piece by piece, every
command in turn, d_i after it was sent (``flight``).
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
    """The wagons' brake forces over one step: at its start ``forces`` [N], the command every wagon
    sees at the step's start ``previous``, the commands sent after it and still travelling
    ``flight`` ((seconds before the step's start, command), oldest first) and from the step on
    ``current`` [N per car], ``delays`` [s], ``brake`` an :class:`~ecostudy.core.types.AirBrake`."""

    def __init__(self, forces, previous, current, delays, brake, flight=()):
        self.forces, self.previous, self.current = (np.asarray(a, float) for a in (forces, previous, current))
        self.delays, self.brake = delays, brake
        self.sent = [(float(-ago), np.asarray(u, float)) for ago, u in flight] + [(0.0, self.current)]

    def at(self, elapsed):
        """b_i [N] ``elapsed`` [s] after the step's start: each wagon's lag towards the command it
        sees, the seen command changing d_i after each was sent."""
        force, seen, since = self.forces, self.previous, np.zeros_like(self.forces)
        for sent, command in self.sent:
            arrives = sent + self.delays
            seen = np.where(arrives <= 0, command, seen)  # arrived before the step
            change = (arrives > 0) & (arrives <= elapsed)
            force = np.where(change, _lag(force, seen, arrives - since, self.brake), force)
            since, seen = np.where(change, arrives, since), np.where(change, command, seen)
        return _lag(force, seen, elapsed - since, self.brake)


def _wagons(consist):
    """(the wagons' mask, the brake signal's delay to every car [s])."""
    wagons = np.array([kind != "locomotive" for kind in consist.kinds])
    return wagons, signal_delays(consist, consist.air_brake.signal_speed)


def application_time(consist):
    """[s] the brake signal's run to the last wagon plus the build-up time constant: how much later
    than an instant brake a train braked from its head has its brakes (9.8 + 8 s on the ore train)."""
    wagons, delays = _wagons(consist)
    return float(delays[wagons].max(initial=0.0) + consist.air_brake.build_up)


def brake_lag(consist):
    """[s] how late the wagons' total brake force follows a command that grows steadily: the signal's
    mean delay over the wagons (weighted by their brake force) plus the build-up time constant (a
    first-order lag tau behind a delay d follows a ramp d + tau late; 4.9 + 8 s on the ore train).
    A train braked more and more as it runs onto a descent gains speed for that long."""
    wagons, delays = _wagons(consist)
    weights = np.asarray(consist.pneumatic_brake, float)[wagons]
    if not wagons.any() or weights.sum() <= 0:
        return 0.0
    return float(np.dot(delays[wagons], weights) / weights.sum() + consist.air_brake.build_up)
