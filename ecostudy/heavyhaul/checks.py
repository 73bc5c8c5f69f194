"""What a heavy-haul study checks before it runs: can the consist start on the route's ruling grade
without breaking a coupler, does the horizon fit the trip, and what of the line the plant leaves out."""
from dataclasses import replace

import numpy as np

from ecostudy.core.physics import GRAVITY
from ecostudy.heavyhaul.loop import STANDING


def ruling_grade(segment, train_length, step=50.0):
    """The steepest uphill gradient [-] averaged over the train's length anywhere on the segment."""
    heads = np.arange(0.0, segment.distance + step, step)
    return float(np.max(segment.gradient.mean_over(heads - 0.5 * train_length, train_length)))


def starting_coupler_force(consist, grade):
    """(largest |in-train force| [N], traction needed [N]) when the consist starts from rest on
    ``grade``: the locomotives together just overcome the train's weight component and its
    speed-independent resistance, each in proportion to its largest traction; every coupler then
    carries the net force of the cars ahead of it (no acceleration yet)."""
    held = consist.mass * (GRAVITY * grade + consist.resistance[:, 0])
    strength = np.array([e.max_force if e is not None else 0.0 for e in consist.traction])
    needed = float(held.sum())
    efforts = strength / strength.sum() * needed
    forces = np.cumsum(efforts - held)[:-1]
    return float(np.max(np.abs(forces))), needed


def reference_problems(reference, segment, tolerance, end_speed=True):
    """What makes a reference (:class:`~ecostudy.heavyhaul.reference.Reference`) unfollowable on
    ``segment``: it does not start from rest or stop at its end (faster than
    :data:`~ecostudy.heavyhaul.loop.STANDING`, the speed under which a train stands, whatever the
    overspeed tolerance; the end left out with ``end_speed=False``, where the end is not at the stop:
    :func:`end_off`), stands on the way, or asks for more than the train's limit at the head by more
    than ``tolerance`` [m/s]. A list of messages (empty: fine)."""
    out = []
    end = float(reference.distance[-1])
    v = np.asarray(reference.speeds, float)
    if v[0] >= STANDING:
        out.append(f"starts at {3.6 * v[0]:.3g} km/h: the train starts from rest (0 at {reference.distance[0]:.0f} m; "
                   f"standing is under {3.6 * STANDING:g} km/h)")
    if end_speed and v[-1] >= STANDING:
        out.append(f"ends at {3.6 * v[-1]:.3g} km/h at {end:.0f} m: a run to a stop ends at 0 there (standing is under "
                   f"{3.6 * STANDING:g} km/h; the train would run past the stop)")
    standing = np.flatnonzero(v[1:-1] <= 0.0)
    if standing.size:
        out.append(f"0 km/h at {reference.distance[standing[0] + 1]:.0f} m: the train would stand there, short of "
                   "its stop (a run stops only at its end)")
    # the reference is linear between its points and the limit constant between its changes: the
    # largest excess is at a point of either (a change read on both sides)
    changes = segment.limit.starts[(segment.limit.starts > 0) & (segment.limit.starts < end)]
    at = np.unique(np.concatenate([reference.distance, changes, np.maximum(changes - 1e-6, 0.0)]))
    speeds = reference.speed(at)
    excess = speeds - segment.limit(at)
    worst = int(np.argmax(excess))
    if excess[worst] > tolerance:
        out.append(f"{3.6 * speeds[worst]:.0f} km/h at {at[worst]:.0f} m is above the "
                   f"train's limit there ({3.6 * segment.limit(at[worst]):.0f} km/h): it cannot be followed")
    return out


def end_off(reference, segment, reach):
    """Why a reference (:class:`~ecostudy.heavyhaul.reference.Reference`) does not end at the stop of
    ``segment``, or None: its end is farther than ``reach`` [m] from it (a study's stop tolerance). The
    train follows a reference to its end and stands within about 0.1 m of it, so such a reference
    leaves every run off its stop, flagged."""
    end = float(reference.distance[-1])
    off = end - segment.distance
    if abs(off) <= reach:
        return None
    return (f"{end:g}: the table ends {abs(off):.3g} m {'before' if off < 0 else 'beyond'} the stop at "
            f"{segment.distance:g} m, farther than stop_tolerance_m ({reach:g} m): a train following it stops "
            "there, off its stop (the table must end at the stop)")


def braking_asked(reference, utmost, service):
    """What a reference (:class:`~ecostudy.heavyhaul.reference.Reference`) asks of the train's brakes
    on its hardest braking piece, or None within ``service`` [m/s^2] (the service deceleration): (where,
    what, refused), refused when it asks more than ``utmost`` [m/s^2] (every brake at its full force
    over the train's mass, no grade or resistance counted): the train cannot follow it."""
    rates = reference.decelerations
    i = int(np.argmax(rates))
    if rates[i] <= service:
        return None
    where = (f"{reference.distance[i]:.0f}-{reference.distance[i + 1]:.0f} m ({3.6 * reference.speeds[i]:.0f} to "
             f"{3.6 * reference.speeds[i + 1]:.0f} km/h)")
    refused = bool(rates[i] > utmost)
    what = (f"asks {rates[i]:.2f} m/s^2 of braking, " + ("more than" if refused else "within")
            + f" the {utmost:.2f} m/s^2 the train's brakes give at the most (every brake at full force)"
            + (": it cannot be followed" if refused else f", beyond the {service:g} m/s^2 it brakes at in service "
               "(reference.service_deceleration_mps2)"))
    return where, what, refused


def samples_to_start(needed, rate, groups):
    """Samples the locomotives need to ramp from 0 to the traction ``needed`` [N] at ``rate`` [N per
    sample per locomotive (virtual) car], ``groups`` of them ramping together."""
    return needed / (rate * groups)


def unmodelled_tunnels(track, from_stop, to_stop):
    """(the track without its tunnels, those between the stops as 'start-end m, area m^2; ...' or
    None): neither the cascade plant nor its single-mass reference models tunnel resistance (a
    consist file has no field for it, unlike a train file's ``tunnel_resistance``), so a tunnel costs
    a heavy-haul run nothing; the track is cut without them and the study says so."""
    low, high = sorted((track.stops[from_stop], track.stops[to_stop]))
    on_run = [(p, n, a) for p, n, a in sorted(track.tunnels) if p < high and p + n > low]
    return replace(track, tunnels=()), "; ".join(f"{p:g}-{p + n:g} m, {a:g} m^2" for p, n, a in on_run) or None
