"""Test logs: the stepping plant (:mod:`ecostudy.core.plant`) with known parameters drives a run
between stops, a recorder samples it at 10 Hz and adds sensor noise.

The driver's handle is set by position (:meth:`Plant.drive`): full traction, coasting, part
traction, coasting, braking into the next stop, with phase lengths and levels drawn from the seed,
the handle held at most at the line's limit (a driver keeps to it: down a grade the brake takes
what the grade adds there; :class:`~ecostudy.core.plant.Cruise` with a handle).
The brake handle is a share drawn for level track plus the share that holds the train on the run's
steepest descent (:func:`brake_share`); braking starts where the speed meets that handle's braking
curve (:func:`ecostudy.core.kinematics.braking_curve`: braking force, running resistance, gradients
and curves of :mod:`ecostudy.core.physics`), and the plant's stop then moves the start by its miss.
The recorder writes speed and position at each sample, the force at the wheel at each sample,
and the powers at the wheel and at the pantograph as means over the sample interval (the plant's
work counters differenced, so the energy of the log is exact before noise). Noise: a normal
speed error (sigma 0.05 m/s by default) and a normal relative error on force and powers (1 %).
"""
from bisect import bisect_right
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from ecostudy.core.errors import InfeasibleError
from ecostudy.core.grid import Profile, intervals_of, make_segment
from ecostudy.io.loaders import track_from_dict
from ecostudy.core.kinematics import braking_curve, interval_grade_force, point_resistance
from ecostudy.core.physics import davis_resistance, gradient_force
from ecostudy.core.plant import Plant, controls_of


@dataclass(frozen=True)
class LogNoise:
    """Recorder noise: speed [m/s] (standard deviation), force and powers (relative), seeded."""

    speed: float = 0.05
    power: float = 0.01
    rate: float = 10.0      # samples per second [Hz]


def true_train(train, mass=1.0, rotating=1.0, davis=(1.0, 1.0, 1.0), efficiency=1.0, regeneration=1.0):
    """``train`` with its parameters times these factors: ``mass`` scales static and effective
    mass, ``rotating`` the rotating-mass allowance M - Ms, ``davis`` A, B and C, ``efficiency`` and
    ``regeneration`` the traction and regeneration efficiencies."""
    static = train.static_mass * mass
    effective = static + (train.mass - train.static_mass) * mass * rotating
    return replace(train, mass=effective, static_mass=static,
                   davis=tuple(float(c) * k for c, k in zip(train.davis, davis)),
                   traction_efficiency=train.traction_efficiency * efficiency,
                   regeneration_efficiency=train.regeneration_efficiency * regeneration)


def phases(distance, rng):
    """Handle by travel distance for one run: (node positions, handles); the braking start is the
    last node, found by :func:`brake_point`."""
    s1 = rng.uniform(0.18, 0.32)
    s2 = s1 + rng.uniform(0.08, 0.18)
    s3 = s2 + rng.uniform(0.08, 0.16)
    nodes = np.array([0.0, s1, s2, s3]) * distance
    return nodes, [1.0, 0.0, rng.uniform(0.4, 0.8), 0.0]


def braking_grid(segment, distance, step=1.0):
    """Nodes every ``step`` metres from the departure to the stop at ``distance`` [m], with every
    gradient and curve change of the segment on the way."""
    edges = segment.breakpoints()
    return np.union1d(np.linspace(0.0, distance, int(np.ceil(distance / step)) + 1), edges[edges < distance])


def brake_share(segment, train, distance, drawn):
    """The brake handle's share (0 to 1) of a run to ``distance``: ``drawn``, the share a driver
    takes on level track, plus the share that holds the train on the run's steepest descent (its
    gradient and curve pull over the braking force at standstill), at most 1."""
    pull = -float(np.min(interval_grade_force(segment, train, braking_grid(segment, distance))))
    return min(drawn + max(pull, 0.0) / float(train.braking.force(0.0)), 1.0)


def brake_point(plant, nodes, handle, brake, distance):
    """Where to start braking at ``brake`` (a handle < 0) to stop at ``distance``: the first place
    on the run without braking where the speed reaches the braking curve of that handle (the train's
    braking envelope scaled by it; gradients, curves and resistance counted)."""
    grid = braking_grid(plant.segment, distance)
    braked = replace(plant.train, braking=plant.train.braking.scaled(-brake))
    curve = braking_curve(plant.segment, braked, grid, np.full_like(grid, np.inf))
    _, _, (y, _, solutions) = drive(plant, np.append(nodes, distance + 50.0), handle)
    for sol in solutions:
        tt = np.linspace(sol.t[0], sol.t[-1], 200)
        x, v = sol.sol(tt)[:2]
        reach = (x >= distance) | (v >= np.interp(x, grid, curve))
        if np.any(reach):
            return float(x[np.argmax(reach)])
    return float(y[0])  # stopped while coasting: no braking needed


def drive(plant, nodes, handle):
    """:meth:`Plant.drive` on ``nodes`` refined by every gradient, curve and limit change of the
    segment (the plant holds the profile of each piece constant, so a change must start a piece),
    the handle held at most at the line's limit (a driver keeps to it: brakes down a grade there,
    eases off the traction): (nodes, the control of each interval, the drive)."""
    fine = np.union1d(nodes, plant.segment.breakpoints())
    fine = fine[fine <= nodes[-1]]
    index = intervals_of(nodes, fine[:-1])
    steps = [handle[i] for i in index]
    limits = plant.segment.limit(0.5 * (fine[:-1] + fine[1:]))
    return fine, controls_of(steps, limits, ceiling=True), plant.drive(fine, steps, limits, ceiling=True)


def sample_run(plant, run, times):
    """A drive (:func:`drive`'s result) sampled at ``times`` [s since departure]: position, speed,
    force at the wheel, wheel work and net line energy (counters) [m, m/s, N, J, J]."""
    nodes, controls, (_, t_stop, solutions) = run
    starts = np.array([s.t[0] for s in solutions])
    out = np.zeros((len(times), 5))
    node_list = nodes.tolist()
    clipped = np.minimum(times, t_stop)
    piece = np.maximum(np.searchsorted(starts, clipped, side="right") - 1, 0)
    states = np.zeros((6, len(times)))
    for i in np.unique(piece):
        sol = solutions[i]
        states[:, piece == i] = sol.sol(np.minimum(clipped[piece == i], sol.t[-1]))
    states[1] = np.where(clipped < t_stop, np.maximum(states[1], 0.0), 0.0)
    resists = davis_resistance(states[1], *plant.davis) + point_resistance(plant.segment, plant.train, states[0])
    for k, t in enumerate(clipped):
        x, v, wt, wb, _, line = states[:, k]
        control = controls[min(max(bisect_right(node_list, x) - 1, 0), len(controls) - 1)]
        resist = float(resists[k])
        ft, fb = plant.forces(v, control, resist) if t < t_stop else (0.0, 0.0)
        out[k] = x, v, ft - fb, wt - wb, line
    return out


def generate_log(track, train, stops, truth, seed=0, noise=LogNoise(), dwell=20.0, driver=phases):
    """A logged run of ``truth`` (a train, see :func:`true_train`) over the track's ``stops`` (names,
    in travel order), each run driven by ``driver(distance, rng)`` (node positions, handles; as
    :func:`phases`) and braked into the stop: a table with the columns of a log file (:mod:`ecostudy.io.logfile`) and the
    noise-free record (a dict of arrays: t, x, v, force, power_wheel, power_line, SI)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / noise.rate
    rows, position, clock, counters = [], track.stops[stops[0]], 0.0, np.zeros(2)
    for to_stop in stops[1:]:
        sign = 1.0 if track.stops[to_stop] >= position else -1.0
        far = min(max(track.stops[to_stop] + sign * 1000.0, 0.0), track.length)  # room to overrun
        segment = make_segment(replace(track, stops=dict(track.stops, _from=position, _far=far)), truth,
                               "_from", "_far")
        distance = abs(track.stops[to_stop] - position)
        plant = Plant(segment, truth)
        nodes, handle = driver(distance, rng)
        brake = -brake_share(segment, truth, distance, rng.uniform(0.5, 0.8))
        start = brake_point(plant, nodes, handle, brake, distance)
        for i in range(2):  # move the braking start by the stop's miss; the last drive is the run
            steps = np.append(nodes[nodes < start], [start, segment.distance])
            run = drive(plant, steps, handle[:len(steps) - 2] + [brake])
            start = float(np.clip(start + distance - float(run[2][0][0]), 0.0, distance))
        if not run[2][2][-1].t_events[0].size:  # ran off the segment: a log must not show a moving train standing
            raise InfeasibleError(f"the generated run to {to_stop} does not stop: it leaves the track "
                                  f"{run[2][0][0] - distance:.0f} m past the stop at {run[2][0][1]:.1f} m/s")
        times = np.arange(0.0, run[2][1] + dwell, dt)
        samples = sample_run(plant, run, times)
        rows.append(np.column_stack([clock + times, position + sign * samples[:, 0], samples[:, 1:3],
                                     counters + samples[:, 3:]]))
        clock += times[-1] + dt
        position += sign * samples[-1, 0]
        counters = counters + samples[-1, 3:]
    t, x, v, force, wheel_work, line_work = np.vstack(rows).T
    step = np.append(np.diff(t), dt)
    wheel = np.append(np.diff(wheel_work), 0.0) / step
    line = np.append(np.diff(line_work), 0.0) / step
    n = len(t)
    frame = pd.DataFrame({
        "time_s": t, "position_m": x,
        "speed_mps": v + rng.normal(0.0, noise.speed, n),
        "force_kN": force * (1 + rng.normal(0.0, noise.power, n)) / 1000.0,
        "power_wheel_kW": wheel * (1 + rng.normal(0.0, noise.power, n)) / 1000.0,
        "power_line_kW": line * (1 + rng.normal(0.0, noise.power, n)) / 1000.0,
    })
    return frame, {"t": t, "x": x, "v": v, "force": force, "power_wheel": wheel, "power_line": line}


def follow_work(record, track, truth, model):
    """Per run of a generated log (between stands): (the traction work [J] ``model`` needs to follow
    the noise-free speed of ``truth`` in ``record``, the true traction work [J]). Pointwise: the true
    acceleration from the recorded force, F = M a + R_v(v) + Ms g gradient of ``model`` at each
    sample, its positive part times the speed by the trapezoid rule; a check of
    :func:`ecostudy.calibration.validate.speed_reference` that shares none of its steps."""
    t, x, v, force = record["t"], record["x"], record["v"], record["force"]
    direction = np.sign(np.gradient(x))
    gradient = Profile(track.gradient_positions, track.gradients)(x) * np.where(direction == 0, 1.0, direction)

    def resistance(train):
        return davis_resistance(v, *train.davis) + gradient_force(train.static_mass, gradient)

    accel = np.where(v > 0, (force - resistance(truth)) / truth.mass, 0.0)
    power = np.where(v > 0, np.maximum(model.mass * accel + resistance(model), 0.0) * v, 0.0)
    dt = np.diff(t)
    work = record["power_wheel"][:-1] * dt
    stops = np.nonzero(np.diff((v > 0).astype(int)) == -1)[0] + 1
    out = []
    for s, e in zip(np.concatenate([[0], stops[:-1]]), stops):
        out.append((float(np.sum(0.5 * (power[s:e] + power[s + 1:e + 1]) * dt[s:e])),
                    float(np.sum(np.maximum(work[s:e], 0.0)))))
    return out


def level_track(track):
    """``track`` (its stops and length) without gradients, limited to 140 km/h."""
    return track_from_dict({"name": f"{track.name}, level", "source": "generated", "length_m": track.length,
                            "stops": [{"name": k, "position_m": float(v)} for k, v in track.stops.items()],
                            "gradients": [{"position_m": 0, "gradient_permille": 0}],
                            "speed_limits": [{"position_m": 0, "speed_kmh": 140}]})


def steep_track(permille):
    """A line of two descents of ``permille`` (2.1 km each) between three stops, Top, Mid and Bottom,
    on level track, limited to 140 km/h: the grades of a mountain or rack line (40 to 60 per mille)."""
    return track_from_dict({"name": f"steep {permille}", "source": "generated", "length_m": 6300,
                            "stops": [{"name": "Top", "position_m": 300}, {"name": "Mid", "position_m": 3000},
                                      {"name": "Bottom", "position_m": 5700}],
                            "gradients": [{"position_m": 0, "gradient_permille": 0},
                                          {"position_m": 600, "gradient_permille": -permille},
                                          {"position_m": 2700, "gradient_permille": 0},
                                          {"position_m": 3300, "gradient_permille": -permille},
                                          {"position_m": 5400, "gradient_permille": 0}],
                            "speed_limits": [{"position_m": 0, "speed_kmh": 140}]})


def steady_log(train, seed, level=25.0, hold=400.0, rate=0.8):
    """A log of ``train`` on level track at a constant speed: from rest at ``rate`` m/s^2 to ``level``
    m/s, ``hold`` seconds there, braking at ``rate`` to a stand; the wheel power the interval's energy
    balance (kinetic energy plus the Davis work over 10 sub-steps), 10 Hz, speed noise 0.05 m/s, 1 %."""
    rise = level / rate
    t = np.arange(0.0, 2 * rise + hold + 20.0, 0.1)
    fine = np.linspace(0.0, t[-1], 10 * (len(t) - 1) + 1)
    v = np.clip(np.minimum(rate * fine, level) - np.maximum(rate * (fine - rise - hold), 0.0), 0.0, None)
    resist = davis_resistance(v, *train.davis) * np.where(v > 0, v, 0.0)
    davis = np.add.reduceat(0.5 * (resist[1:] + resist[:-1]) * np.diff(fine), np.arange(0, len(fine) - 1, 10))
    vs = v[::10]
    work = 0.5 * train.mass * np.diff(vs ** 2) + davis
    x = 300.0 + np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(fine))])[::10]
    rng = np.random.default_rng(seed)
    return pd.DataFrame({"time_s": t, "position_m": x, "speed_mps": vs + rng.normal(0.0, 0.05, len(t)),
                         "power_wheel_kW": np.append(work / 0.1, 0.0) * (1 + rng.normal(0.0, 0.01, len(t))) / 1e3})
