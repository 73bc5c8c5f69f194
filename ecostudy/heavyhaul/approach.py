"""The terminal approach with air brakes: the final brake application planned with the brake pipe's
delay and build-up (heavyhaul.airbrake; known from the consist file), as a driver of a long
air-braked train brakes ahead for them.

With instant brakes the stopping sample brakes for the constant deceleration v^2 / 2d (heavyhaul.loop;
where coasting would stand the train short, on a climb, its locomotives pull instead, pipe on or off).
With the pipe on, the wagons' brakes reach the last wagon d_i = 9.8 s after a command (the ore train at
250 m/s) and build up over tau_b = 8 s, so that rule, re-planned every second, stops the train tens of
metres past the mark, and a late, hard application runs the train in against its front wagons
(a 2120 kN buff force against the 2000 kN coupler limit, measured). Two changes, both on the pipe's
own model:

* :func:`braked_distance`: how far the train runs until it stands with efforts held, as one mass
  (every car's mass summed, the resistance, grades and curves it feels now), the locomotives'
  dynamic brakes acting at once and the wagons' brakes as the pipe delivers them (each wagon's
  delay, lag and the commands still travelling, ``plant.brake_pipe``); :func:`stopping_share` finds by
  bisection the share s of every car's brake (u = s * the lowest efforts, the driver's graduated
  application of automatic and dynamic brake) that stands the head at the stop, or, where even
  coasting stands it short because the wagons' brakes are still releasing (tau_r after the pipe's
  delay: a sag into a stop on a climb), the share of the locomotives' traction that pulls it there.
* :func:`braking_point`: the final application starts at the first sample from which waiting one
  more sample (the train running v Ts further) would leave less than the distance the reference's
  own final deceleration needs with the pipe's delays: the application then starts no harder than
  the reference's (Zhang & Zhuan's v_r brakes at the service rate), which keeps the run-in of a
  train braked from its head within its couplers.
"""
import numpy as np

PREDICT_STEP = 0.25  # [s]: the one-mass prediction's time step
HORIZON = 600.0      # [s]: a train that has not stood by then does not stand (inf)
BISECTIONS = 30
CHUNK = 80           # time steps of the pipe read at once (20 s)


def braked_distance(plant, state, efforts):
    """(distance [m], time [s]) the train runs from ``state`` until it stands with ``efforts`` [N per
    car] held: one mass, the locomotives at once, the wagons' brakes through the pipe (instant with
    the pipe off), against the resistance and grades felt now ((inf, inf) if it never stands). The
    pipe's forces are read for a chunk of :data:`CHUNK` time steps at once."""
    c = plant.consist
    mass = float(c.mass.sum())
    held = float(plant.resistance(state.positions, state.speeds).sum())
    applied = plant.efforts(efforts, state.speeds)
    locos = float(applied[plant.loco].sum())
    pipe = plant.brake_pipe(state, efforts, HORIZON)
    v = float(np.dot(c.mass, state.speeds) / mass)
    x = t = 0.0
    while v > 0.0 and t < HORIZON:
        middles = t + (np.arange(CHUNK) + 0.5) * PREDICT_STEP
        wagons = (np.full(CHUNK, float(applied[~plant.loco].sum())) if pipe is None
                  else pipe.at(middles[:, None]).sum(axis=1))
        for a in (locos + wagons - held) / mass:
            if v + a * PREDICT_STEP <= 0.0:
                return float(x + v * v / (-2.0 * a)), float(t - v / a)
            x, v, t = x + (v + 0.5 * a * PREDICT_STEP) * PREDICT_STEP, v + a * PREDICT_STEP, t + PREDICT_STEP
    return (x, t) if v <= 0.0 else (np.inf, np.inf)


def brake_share(plant, state, effort, distance, pull=False):
    """(s in [0, 1], time to stand [s]): the share of every car's ``effort`` (N per car: the lowest
    efforts, every brake; with ``pull`` the highest, the locomotives' traction) that stands the train
    ``distance`` [m] on; an end of [0, 1] when even that one misses (braking: the whole brake runs
    further, 1, or coasting stands it short, 0; pulling: all the traction stands it short, 1, or
    coasting runs further, 0)."""
    lo, hi = 0.0, 1.0
    for share in (1.0, 0.0):
        run, seconds = braked_distance(plant, state, share * effort)
        if (run >= distance) == ((share == 1.0) != pull):
            return share, seconds
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if (braked_distance(plant, state, mid * effort)[0] > distance) != pull else (lo, mid)
    share = lo if pull else hi  # the end that stands the train within the distance
    return share, braked_distance(plant, state, share * effort)[1]


def stopping_share(plant, state, lowest, highest, distance):
    """(s, time to stand [s], pulling): the share s of every car's brake (``lowest``, N per car) that
    stands the train ``distance`` [m] on, or, where even coasting stands it short (a climb: the
    wagons' brakes still releasing through the pipe, tau_r, slow it), the share of every
    locomotive's traction (``highest``) that does (pulling True)."""
    share, seconds = brake_share(plant, state, lowest, distance)
    if share > 0.0:  # 0 only where coasting stands it short (brake_share's own coasting run)
        return share, seconds, False
    return (*brake_share(plant, state, highest, distance, pull=True), True)


def service_share(plant, state, lowest, deceleration):
    """The share of every car's brake whose steady force decelerates the train at ``deceleration``
    [m/s^2] against the resistance and grades felt now, within [0, 1]."""
    mass = float(plant.consist.mass.sum())
    held = float(plant.resistance(state.positions, state.speeds).sum())
    whole = -float(plant.efforts(lowest, state.speeds).sum())
    return float(np.clip((mass * deceleration - held) / max(whole, 1.0), 0.0, 1.0))


def braking_point(plant, state, lowest, distance, deceleration, ts):
    """True when, waiting one more sample ``ts`` [s] (the train running on at its speed), the brake
    share of the reference's final ``deceleration`` would no longer stand it within ``distance``."""
    speed = float(np.dot(plant.consist.mass, state.speeds) / plant.consist.mass.sum())
    share = service_share(plant, state, lowest, deceleration)
    return braked_distance(plant, state, share * lowest)[0] >= distance - speed * ts
