"""Cheap speed profiles on the grid: the envelope of fastest driving and capped-speed guesses.

Used as Ipopt's starting point and to estimate the all-out time before any NLP is solved.
"""
from typing import Any, Callable

import numpy as np

from ecostudy.core.errors import LineError, TractionError
from ecostudy.core.grid import Segment
from ecostudy.core.physics import davis_resistance, interval_resistance, running_resistance
from ecostudy.core.types import Train
from ecostudy.core.units import FloatArray, Numeric


def point_resistance(segment: Segment, train: Train, positions: Numeric) -> Numeric:
    """Speed-independent resistance (gradient and curve) at travel positions [N]."""
    return running_resistance(0.0, (0.0, 0.0, 0.0), train.static_mass, segment.gradient(positions),
                              train.curve_coefficient, segment.curvature(positions),
                              roeckl=train.curve_resistance == "roeckl")


def interval_grade_force(segment: Segment, train: Train, nodes: FloatArray) -> FloatArray:
    """Speed-independent resistance per interval (gradient and curve) at its middle [N]; on a
    clothoid the middle's curvature is the interval's mean curvature."""
    return np.asarray(point_resistance(segment, train, 0.5 * (nodes[:-1] + nodes[1:])), float)


def interval_davis(segment: Segment, train: Train, nodes: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Davis coefficients per interval (A, B, C_k) [N, N s/m, N s^2/m^2]: the train's C plus the
    tunnel coefficient where the interval's middle is in a tunnel (arrays of one per interval)."""
    a, b, c = train.davis
    n = len(nodes) - 1
    c_k = c + segment.tunnel(0.5 * (nodes[:-1] + nodes[1:]))
    return np.full(n, float(a)), np.full(n, float(b)), np.asarray(c_k, float)


def braking_curve(segment: Segment, train: Train, nodes: FloatArray, limits: FloatArray,
                  end_speed: float = 0.0) -> FloatArray:
    """Highest speeds from which full service braking still meets every limit and the stop [m/s]
    (``end_speed``: the speed allowed at the last node instead of the stop; inf: its limit)."""
    ds = np.diff(nodes)
    fixed = interval_grade_force(segment, train, nodes)
    a, b, c = interval_davis(segment, train, nodes)
    bwd = np.zeros_like(nodes)
    bwd[-1] = min(end_speed, limits[-1])
    target = (bwd[-1], nodes[-1])  # (speed, position) the braking curve leads to
    for k in range(len(ds) - 1, -1, -1):
        v = bwd[k + 1]
        held = train.braking.force(v) + davis_resistance(v, a[k], b[k], c[k]) + fixed[k]
        dec = min(held / train.mass, train.max_deceleration)
        # a train its brakes cannot slow here must enter slower (dec < 0): over a long enough descent, even
        # from standing it would leave faster than it may; where they can, at least 1e-3 m/s^2
        v2 = v * v + 2 * ds[k] * (dec if dec <= 0 else max(dec, 1e-3))
        if v2 < 0 or (v2 == 0 and k > 0):
            raise LineError(runaway_message(segment, nodes[k], train.braking.force(v), held, *target))
        reach = np.sqrt(v2)
        bwd[k] = min(reach, limits[k])
        if limits[k] < reach:  # a limit binds: what a runaway upstream would miss
            target = (limits[k], nodes[k])
    return bwd


def runaway_message(segment: Segment, position: float, braking: float, held: float, speed: float,
                    limit_at: float) -> str:
    """Why no driving keeps a limit or the stop: at full braking the train still gains speed (``held``:
    braking plus resistance plus gradient and curves [N], negative) on its way to ``speed`` [m/s] at
    ``limit_at`` [m] (0 at the end: the stop)."""
    start = segment.from_stop or "the start"
    where = f"{position:.0f} m after {start}"
    keep = ("stand at the stop" if speed == 0 else
            f"keep to {3.6 * speed:.0f} km/h at {limit_at:.0f} m after {start}")
    return (f"infeasible: the train runs away: at full braking ({braking / 1e3:.3g} kN) it still gains speed {where} "
            f"(the gradient and curves pull {-held / 1e3:,.0f} kN more than its brakes and resistance hold), so it "
            f"cannot {keep}")


def coast_speeds(segment: Segment, train: Train, nodes: FloatArray, limits: FloatArray, start: int,
                 v_start: float) -> FloatArray:
    """Speeds when coasting from node ``start`` at ``v_start``; held at limits by braking [m/s].

    Nodes before ``start`` are NaN; a train that stops while coasting stays at 0.
    """
    ds = np.diff(nodes)
    fixed = interval_grade_force(segment, train, nodes)
    a, b, c = interval_davis(segment, train, nodes)
    out = np.full_like(nodes, np.nan)
    out[start] = v_start
    for k in range(start, len(ds)):
        v = out[k]
        dec = (davis_resistance(v, a[k], b[k], c[k]) + fixed[k]) / train.mass
        out[k + 1] = min(np.sqrt(max(v * v - 2 * ds[k] * dec, 0.0)), limits[k + 1])
    return out


def coasting_profile(segment: Segment, train: Train, nodes: FloatArray, limits: FloatArray, fastest: FloatArray,
                     start: int) -> FloatArray:
    """``fastest`` (a profile ending at the stop) up to node ``start``, coasting from there, never
    above ``fastest``: the eco-drive coasting strategy's profile (Farooqi 2018 Table 6.1) [m/s]."""
    coast = coast_speeds(segment, train, nodes, limits, start, fastest[start])
    v = fastest.copy()
    v[start:] = np.minimum(coast[start:], fastest[start:])
    v[-1] = 0.0
    return v


def earliest_coasting_point(meets: Callable[[int], bool], last: int, first: int = 1) -> int:
    """The smallest node k in [first + 1, last] at which coasting from k still ``meets(k)`` the
    time (``meets`` true at ``last``; coasting later only arrives earlier), by bisection."""
    lo, hi = first, last
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if meets(mid) else (mid, hi)
    return hi


def envelope_speeds(segment: Segment, train: Train, nodes: FloatArray, limits: FloatArray,
                    traction: Callable[[float], float] | None = None) -> FloatArray:
    """Fastest speeds: max traction forward from the start, max braking back from the stop.
    ``traction``: the largest traction force [N] at a speed [m/s] if not the train's envelope (a
    supply that caps it).

    Raises :class:`~ecostudy.core.errors.LineError` when maximum traction cannot keep the train moving.
    """
    pull = traction if traction is not None else train.traction.force
    ds = np.diff(nodes)
    fixed = interval_grade_force(segment, train, nodes)
    a, b, c = interval_davis(segment, train, nodes)
    fwd = np.zeros_like(nodes)
    for k in range(len(ds)):
        v = fwd[k]
        acc = min((pull(v) - davis_resistance(v, a[k], b[k], c[k]) - fixed[k]) / train.mass, train.max_acceleration)
        v2 = v * v + 2 * ds[k] * acc
        if v2 <= 0 and k < len(ds) - 1:
            resistance = davis_resistance(v, a[k], b[k], c[k])
            climb = fixed[k] > 0 and pull(v) > resistance  # the line's grade is what stops it, else the train
            raise (LineError if climb else TractionError)(stall_message(segment, nodes[k], pull(v), resistance,
                                                                         fixed[k], v))
        fwd[k + 1] = min(np.sqrt(max(v2, 0.0)), limits[k + 1])
    out = np.minimum(fwd, braking_curve(segment, train, nodes, limits))
    out[0] = out[-1] = 0.0
    return out


def stall_message(segment: Segment, position: float, traction: float, resistance: float, grade: float,
                  speed: float) -> str:
    """Why no driving reaches the stop: where the train stops moving at full traction and the
    forces there [N] (grade: gradient and curves; positive uphill)."""
    what = ("the train cannot climb" if grade > 0 and traction > resistance
            else "the train cannot overcome its running resistance" if grade <= 0 else
            "the train cannot move against its resistance and the gradient")
    where = f"{position:.0f} m after {segment.from_stop or 'the start'}"
    return (f"infeasible: {what}: at full traction it stops {where} ({traction / 1e3:.3g} kN of traction at "
            f"{3.6 * speed:.0f} km/h against {resistance / 1e3:.3g} kN of running resistance and {grade / 1e3:.3g} kN "
            "of gradient and curves)")


def interval_time(v0: Any, v1: Any, ds: Any) -> Any:
    """Time over an interval of length ``ds`` [m] between speeds ``v0`` and ``v1`` [m/s]:
    2 ds / (v0 + v1) [s], exact for constant acceleration (Farooqi 2018, eq. 2.16).
    Written with ``+ /`` only, so the space NLP (Pyomo expressions) and the re-simulation share it."""
    return 2 * ds / (v0 + v1)


def interval_times(speeds: FloatArray, nodes: FloatArray) -> FloatArray:
    """:func:`interval_time` of every grid interval [s], the speed sum floored at 1e-9 m/s."""
    result: FloatArray = interval_time(0.0, np.maximum(speeds[:-1] + speeds[1:], 1e-9), np.diff(nodes))
    return result


def clock(speeds: FloatArray, nodes: FloatArray) -> FloatArray:
    """Clock at every node of a speed profile from its first node [s]."""
    return np.concatenate([[0.0], np.cumsum(interval_times(speeds, nodes))])


def running_time(speeds: FloatArray, nodes: FloatArray) -> float:
    """Running time of a speed profile on the grid [s]."""
    return float(np.sum(interval_times(speeds, nodes)))


def interval_power(force: FloatArray, speeds: FloatArray) -> FloatArray:
    """Power of a force per interval [W]: the force [N] times the interval's mean speed [m/s]
    (``profile.csv``'s ``power_kW``, and what a saved profile's is checked against)."""
    result: FloatArray = force * 0.5 * (speeds[:-1] + speeds[1:])
    return result


def cumulative_work(force: FloatArray, nodes: FloatArray) -> FloatArray:
    """Work of a force per interval [N] summed from the first node [J], one value per node
    (``profile.csv``'s ``cumulative_energy_kWh``, and what a saved profile's is checked against)."""
    return np.concatenate([[0.0], np.cumsum(force * np.diff(nodes))])


def capped_speeds(envelope: FloatArray, nodes: FloatArray, target: float) -> FloatArray:
    """Envelope capped at one cruise speed, the cap chosen so the running time is ``target``."""
    if target <= running_time(envelope, nodes):
        return envelope.copy()
    lo, hi = 1e-3, float(envelope.max())
    for _ in range(60):
        cap = 0.5 * (lo + hi)
        if running_time(np.minimum(envelope, cap), nodes) > target:
            lo = cap
        else:
            hi = cap
    return np.minimum(envelope, hi)


def net_force_needed(speeds: FloatArray, segment: Segment, train: Train, nodes: FloatArray) -> FloatArray:
    """F_T - F_B per interval [N] that takes the train from each node's speed to the next on the
    grid's speed recursion (the space NLP's equation of motion, Farooqi 2018 eq. 2.1 with the
    interval resistance of eq. 2.2): M (v1^2 - v0^2) / (2 ds) + R(v0, v1)."""
    ds = np.diff(nodes)
    v0, v1 = speeds[:-1], speeds[1:]
    resist = interval_resistance(v0, v1, interval_davis(segment, train, nodes), interval_grade_force(segment, train, nodes))
    return np.asarray(train.mass * (v1**2 - v0**2) / (2 * ds) + resist, float)


def forces_for(speeds: FloatArray, segment: Segment, train: Train, nodes: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Traction and braking forces per interval [N] that realise ``speeds`` (clipped to the envelopes)."""
    v0, v1 = speeds[:-1], speeds[1:]
    need = net_force_needed(speeds, segment, train, nodes)
    ft = np.clip(need, 0.0, np.minimum(train.traction.force(v0), train.traction.force(v1)))
    fb = np.clip(-need, 0.0, np.minimum(train.braking.force(v0), train.braking.force(v1)))
    return ft, fb


def samples(running_time: float, sample_time: float) -> int:
    """k_f = floor(t_f / T_s) (Farooqi 2018 §4.1)."""
    return int(np.floor(running_time / sample_time + 1e-9))
