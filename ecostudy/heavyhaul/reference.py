"""The reference speed of Zhang & Zhuan's controller (v_r of eqs. 4 and 7), from ecostudy itself: the
energy-optimal run of the whole consist as one mass (the space-domain NLP, verified by simulation)
between two stops for a running time, or a user's speed-distance table.

The single mass (Zhang & Zhuan eq. 1 summed over the cars, couplers cancelling): the consist's mass
(no rotating-mass share: eq. 1 has none), its length (the speed limits hold for the whole train;
the grades are averaged over it, :func:`spread_grades`),
Davis terms sum_i m_i (c0_i, c1_i, c2_i), Roeckl's curve resistance (as the cascade plant),
traction the locomotives' envelopes summed, braking their dynamic brakes plus the wagons'
pneumatic brakes, bounded by a service deceleration (a heavy train does not brake at its brakes'
full force in normal running: a setting). Energy: traction only (no regeneration), as Zhang & Zhuan
counts it.
"""
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ecostudy.analysis.single import solve_run
from ecostudy.core.errors import InputError, problem
from ecostudy.core.grid import Profile
from ecostudy.core.physics import Envelope, davis_resistance, gradient_force
from ecostudy.core.types import Timing, Train
from ecostudy.core.units import KMH


class Reference(NamedTuple):
    """A speed-distance reference: ``speed(distance)`` [m/s] at a head position [m] from the start,
    and its clock, with which the controller predicts the positions of its horizon (eq. 9)."""

    distance: np.ndarray   # [m] from the start stop, increasing
    speeds: np.ndarray     # [m/s]
    times: np.ndarray      # [s] at each distance, 0 at the start
    energy: float          # traction energy of the single mass [J] (nan for a user's table)

    @property
    def running_time(self):
        return float(self.times[-1])

    @property
    def final_approach(self):
        """Where the final deceleration to the end begins [m] (the speeds fall from there on)."""
        i = len(self.speeds) - 1
        while i > 0 and self.speeds[i - 1] > self.speeds[i]:
            i -= 1
        return float(self.distance[i])

    @property
    def decelerations(self):
        """The deceleration of every piece between two points [m/s^2, > 0 braking]: the speed lost
        over the piece's time (its mean speed, :func:`clock`)."""
        return (self.speeds[:-1] - self.speeds[1:]) / np.diff(self.times)

    @property
    def final_deceleration(self):
        """The deceleration of the reference's last piece into the stop [m/s^2, > 0]."""
        return float(self.decelerations[-1])

    def speed_in(self, seconds, head):
        """v_r [m/s] ``seconds`` after the reference passes ``head`` [m] (its clock): beyond the stop the
        final deceleration continued, below zero, the speed a braking effort held past the stop gives
        the controller's linear model (eq. 2). A held last move (Nc < Np) then brakes into the stop at
        the reference's rate rather than stopping within one sample to stand still for the rest (held
        at 0 the shipped runs stop short and crawl, 25 % late: docs/heavyhaul.md). The horizon's
        target only: the reference itself (:meth:`speed`) is 0 at the stop, and the plant's brakes,
        friction, never drive the train backwards."""
        times = self.time_at(head) + np.asarray(seconds, float)
        past = np.maximum(times - self.running_time, 0.0)
        return self.speed(self.position_at(times)) - self.final_deceleration * past

    def speed(self, distance):
        return np.interp(distance, self.distance, self.speeds)

    def time_at(self, distance):
        return np.interp(distance, self.distance, self.times)

    def position_at(self, time):
        return np.interp(time, self.times, self.distance)


def clock(distance, speeds):
    """Times [s] along a speed-distance profile (the mean speed over each piece); the distances
    increase and no two neighbouring speeds are 0 (:func:`table_reference` checks a user's table)."""
    mean = 0.5 * (speeds[1:] + speeds[:-1])
    return np.concatenate([[0.0], np.cumsum(np.diff(distance) / mean)])


def _summed(envelopes):
    """The force-power envelopes of several locomotives as one (forces and powers add)."""
    envelopes = [e for e in envelopes if e is not None]
    return Envelope("force_power", max_force=sum(e.max_force for e in envelopes),
                    max_power=sum(e.max_power for e in envelopes))


def single_mass(consist, service_deceleration):
    """The consist as one :class:`Train` (SI), braking bounded by ``service_deceleration`` [m/s^2]."""
    if not consist.locomotives:
        raise InputError(f"consist '{consist.name}': no locomotive (nothing can pull the train)")
    mass = float(consist.mass.sum())
    davis = tuple(float(v) for v in consist.mass @ consist.resistance)
    dynamic = _summed(consist.dynamic_brake)
    braking = Envelope("force_power", max_force=dynamic.max_force + float(consist.pneumatic_brake.sum()))
    return Train(name=f"{consist.name} (one mass)", mass=mass, static_mass=mass, length=float(consist.length.sum()),
                 davis=davis, traction=_summed(consist.traction), braking=braking,
                 max_deceleration=service_deceleration, curve_resistance="roeckl")


def spread_grades(track, length, forward=True, step=None):
    """The track with every gradient replaced by its mean over the train behind the head (``length``
    [m], behind = towards lower positions when running ``forward``), in pieces of ``step`` [m]
    (default a tenth of the train): the grade force of a long train whose mass is spread along it,
    as a single mass at the head feels it. (A 2.5 km train cresting a hill does not speed up when its
    head does.)"""
    step = step or max(length / 10, 10.0)
    starts = np.arange(0.0, track.length, step)
    middles = np.minimum(starts + 0.5 * step, track.length)
    profile = Profile(np.asarray(track.gradient_positions, float), np.asarray(track.gradients, float))
    centres = middles - 0.5 * length if forward else middles + 0.5 * length
    return replace(track, gradient_positions=starts, gradients=profile.mean_over(centres, length))


def advanced_limits(track, seconds, forward=True):
    """The track with every drop of the speed limit moved ``seconds`` of running at the lower limit
    towards the start of the run (``forward``: towards lower positions): a train that follows the
    result is at the lower limit that long before its head reaches the drop. Rises stay where they
    are. (Zhang & Zhuan design v_r below the limits; a controller that tracks v_r only at its samples
    Ts apart crosses a drop between two of them, so v_r must be at the lower limit a sample before.)"""
    if seconds <= 0:
        return track
    p, limit = np.asarray(track.limit_positions, float), np.asarray(track.limits, float)
    ends = np.append(p[1:], np.inf)
    lead = limit * seconds
    moved = p - lead if forward else ends + lead
    starts = np.unique(np.concatenate([p, moved[np.isfinite(moved) & (moved > p[0])]]))
    if forward:  # piece j is ahead within its own lead of x
        seen = (p[None, :] <= starts[:, None] + lead[None, :]) & (ends[None, :] > starts[:, None])
    else:
        seen = (p[None, :] <= starts[:, None]) & (ends[None, :] + lead[None, :] > starts[:, None])
    return _with_limits(track, starts, np.where(seen, limit[None, :], np.inf).min(axis=1))


def descent_margins(track, train, lag, forward=True):
    """The track with each speed limit lowered where the grade (spread over the train, as
    :func:`spread_grades` leaves it) needs braking at that limit, by the speed the train gains while
    its brakes lag ``lag`` [s] behind (:func:`~ecostudy.heavyhaul.airbrake.brake_lag`): (g s -
    R(v_lim) / m) lag, s the descent [-] and R the Davis resistance at the limit (curves left out:
    the larger margin). A controller whose model has instant brakes (eq. 2) riding a limit down a
    descent asks for the brakes it needs as it needs them, and an air brake delivers them that late.
    A descent of several pieces under one limit keeps its largest margin throughout: the reference
    does not speed up and slow down again with every change of the spread grade (each a new braking
    the pipe would deliver late), and the single-mass NLP is not given steps of tenths of a km/h
    every tenth of a train (on Vasteras - Kolback its all-out solve then stopped at Ipopt's
    iteration limit)."""
    if lag <= 0:
        return track
    grades = Profile(np.asarray(track.gradient_positions, float), np.asarray(track.gradients, float))
    limits = Profile(np.asarray(track.limit_positions, float), np.asarray(track.limits, float))
    starts = np.unique(np.concatenate([grades.starts, limits.starts]))
    starts = starts[(starts >= limits.starts[0]) & (starts < track.length)]
    limit, descent = limits(starts), -grades(starts) * (1.0 if forward else -1.0)
    pull = gradient_force(train.static_mass, descent) - davis_resistance(limit, *train.davis)
    need = np.maximum(pull / train.mass, 0.0)
    values = limit - need * lag
    lowered = need > 0
    change = np.concatenate([[True], (lowered[1:] != lowered[:-1]) | (limit[1:] != limit[:-1])])
    runs = np.cumsum(change) - 1  # the run of pieces alike lowered (or not) under one limit each is in
    return _with_limits(track, starts, np.where(lowered, np.minimum.reduceat(values, np.flatnonzero(change))[runs], values))


def _with_limits(track, starts, values):
    """``track`` with the speed limit ``values`` from ``starts`` on, repeated pieces merged."""
    keep = np.concatenate([[True], np.diff(values) != 0])
    return replace(track, limit_positions=starts[keep], limits=values[keep])


def optimal_reference(consist, track, from_stop, to_stop, running_time=None, supplement=None, points=500,
                      service_deceleration=0.3, limit_lead=0.0, brake_lag=0.0):
    """The energy-optimal single-mass run for ``running_time`` [s] (or a ``supplement`` [-] over the
    all-out time), on the grades spread over the train (:func:`spread_grades`) and below the limits
    with each drop moved ``limit_lead`` [s] of running at the lower limit ahead
    (:func:`advanced_limits`) and, with a ``brake_lag`` [s], lowered on descents
    (:func:`descent_margins`), verified by simulation; returns a :class:`Reference` and the
    :class:`RunResult`."""
    train = single_mass(consist, service_deceleration)
    forward = track.stops[to_stop] >= track.stops[from_stop]
    track = advanced_limits(spread_grades(track, train.length, forward), limit_lead, forward)
    track = descent_margins(track, train, brake_lag, forward)
    timing = Timing(running_time=running_time) if running_time is not None else Timing(supplement=supplement)
    run = solve_run(track, train, from_stop, to_stop, timing, points=points)
    t = run.trajectory
    return Reference(t.nodes, t.v, t.time, float(np.sum(t.ft * np.diff(t.nodes)))), run


def _bad_row(distance_m, speed_kmh):
    """The first bad row of a speed-distance table as (row, column, what), rows numbered as a spreadsheet
    shows them (the header is row 1), or None: the distances start at 0 (the start stop: they are
    measured from it, and the run's clock and roll-back start there) and increase, no value is below
    0, the speed is 0 only at single points (a train that stands never arrives)."""
    columns = {"distance_m": np.asarray(distance_m, float), "speed_kmh": np.asarray(speed_kmh, float)}
    distance, speed = columns["distance_m"], columns["speed_kmh"]
    found = [(0, "distance_m", f"{distance[0]:g}: the first distance must be 0 (the start stop; the distances "
              "are measured from it)")] if distance.size and distance[0] > 0 else []
    found += [(i + 1, "distance_m", f"{distance[i + 1]:g} after {distance[i]:g}: the distances must increase")
              for i in np.flatnonzero(np.diff(distance) <= 0)[:1]]
    found += [(i, column, f"{values[i]:g} is below 0") for column, values in columns.items()
              for i in np.flatnonzero(values < 0)[:1]]
    found += [(i + 1, "speed_kmh", "0 after 0: the speed may be 0 only at single points (a train that stands "
               "never arrives)") for i in np.flatnonzero((speed[1:] == 0) & (speed[:-1] == 0))[:1]]
    if not found:
        return None
    i, column, what = min(found)
    return i + 2, column, what


def table_reference(distance_m, speed_kmh, where="reference table"):
    """A user's speed-distance table (distance from the start [m], speed [km/h]) read from ``where``;
    a bad row is refused naming it (the first by row)."""
    bad = _bad_row(distance_m, speed_kmh)
    if bad:
        row, column, what = bad
        raise InputError(problem(where, f"{column}, row {row}", what))
    distance, speeds = np.asarray(distance_m, float), np.asarray(speed_kmh, float) * KMH
    return Reference(distance, speeds, clock(distance, speeds), float("nan"))
