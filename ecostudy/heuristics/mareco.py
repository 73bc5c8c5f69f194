"""A margin-distribution heuristic in the style of OSRD's MARECO (the industrial eco-driving allowance).

For a speed cap v1 the profile is the fastest run capped at v1 (full traction, hold v1 or the
limit, full service braking), with coasting overlaid

- before every braking phase: the train coasts into the point where braking ends (or, if the
  braking goes below vf, where it passes vf) and brakes only from there;
- before every steep descent on a plateau (held at v1 or at a limit; one on which a coasting
  train accelerates): it coasts from before the descent so as to be back at the plateau speed at
  the descent's end, entering it no slower than MARECO's slope speed (:func:`slope_floor`).

A coast is traced backwards from its end until it meets the capped profile; where it would fall
below its floor the train coasts forward from the profile at that point instead. vf, the lowest speed worth coasting to, is MARECO's
vf = v1^2 R'(v1) / (v1 R'(v1) + R(v1)) with R the train's Davis resistance (OSRD's
``MarecoAllowance.computeVf``: wle = v1^2 R'(v1), vf = wle v1 / (wle + R(v1) v1)).
The cap v1 is searched so that the simulated running time meets the timetable.
"""
import numpy as np

from ecostudy.core.errors import InfeasibleError
from ecostudy.core.kinematics import braking_curve, envelope_speeds, interval_grade_force, running_time
from ecostudy.core.physics import davis_resistance

TOL = 1e-6  # [m/s]


def coasting_floor(train, v1):
    """vf [m/s] for the cap v1 (MARECO): below it coasting saves less than it costs in time."""
    _, b, c = train.davis
    slope = b + 2 * c * v1  # R'(v1)
    resistance = davis_resistance(v1, *train.davis)
    return v1 * v1 * slope / max(v1 * slope + resistance, 1e-12)


def _step(v, ds, resist_fixed, davis, mass, sign):
    """Coasting over one interval on the grid's trapezoidal recursion (ocp/space.py), so that the forces
    realising it (kinematics.forces_for) are zero: v_out^2 = v^2 + sign 2 ds R(mean) / M, fixed point."""
    a, b, c = davis
    out = v
    for _ in range(4):
        mean_r = a + b * 0.5 * (out + v) + c * 0.5 * (out * out + v * v) + resist_fixed
        out = np.sqrt(max(v * v + sign * 2 * ds * mean_r / mass, 0.0))
    return out


def coast_back(case, base, end, floor, fixed, start_speed=None):
    """A coast ending at node ``end``: (start node, speeds at nodes start+1, ...) or None.

    Traced backwards from ``end`` at ``base[end]`` (or ``start_speed``) until it meets ``base``.
    Where the backward trace would fall below ``floor`` (a descent before the end) the train
    instead starts coasting from ``base`` at that node and coasts forward (OSRD's coastFromEnd).
    ``fixed``: gradient and curve resistance per interval [N].
    """
    ds, train = np.diff(case.nodes), case.train
    w = {end: float(base[end] if start_speed is None else start_speed)}
    floor = min(floor, w[end])
    for k in range(end - 1, -1, -1):
        cur = _step(w[k + 1], ds[k], fixed[k], train.davis, train.mass, +1)
        if cur >= base[k] - TOL:
            return k, np.array([w[j] for j in range(k + 1, end + 1)])
        if cur < floor - TOL:
            return _coast_forward(case, base, k, end, fixed)
        w[k] = cur
    return None


def _coast_forward(case, base, start, end, fixed):
    """Coast from ``base[start]`` at node ``start`` until the speed is back on ``base`` (or ``end``)."""
    ds, train = np.diff(case.nodes), case.train
    v, out = float(base[start]), []
    for k in range(start, end):
        v = _step(v, ds[k], fixed[k], train.davis, train.mass, -1)
        if v >= base[k + 1] - TOL:
            break
        out.append(v)
    if not out:
        return None
    return start, np.array(out)


def opportunities(case, base, capped, v1, vf, fixed):
    """Coasts to try as (end node, speed there or None for base, floor): braking phases, and
    descents on a plateau (held at v1 or at a limit) where a coasting train accelerates."""
    bwd = braking_curve(case.segment, case.train, case.nodes, capped)
    braking = (np.abs(base - bwd) <= TOL) & (bwd < capped - TOL)
    braking[0] = False
    ends = []
    k, n = 1, len(base)
    while k < n:
        if not braking[k]:
            k += 1
            continue
        j = k
        while j + 1 < n and braking[j + 1]:
            j += 1
        end = min(j + 1, n - 1)  # the first node at the braking target (or the stop)
        if base[end] > vf:
            ends.append((end, None, vf))
        else:
            below = np.nonzero(base[k:end + 1] <= vf)[0]
            if below.size and base[k] > vf:
                e = k + int(below[0])
                ends.append((e, _through(case, base, e, vf, fixed), vf))
        k = j + 1
    held = (np.abs(np.diff(base)) <= TOL) & (np.abs(base[:-1] - capped[:-1]) <= TOL) & (base[:-1] > vf)
    natural = -(davis_resistance(base[:-1], *case.train.davis) + fixed) / case.train.mass
    downhill = held & (natural > 0)
    for i in np.nonzero(downhill & ~np.append(downhill[1:], False))[0]:
        j = i
        while j > 0 and downhill[j - 1]:
            j -= 1
        ends.append((int(i) + 1, None, slope_floor(case, base, natural, j, i, v1, vf)))
    return sorted(set(ends), key=lambda e: -e[0])


def slope_floor(case, base, natural, first, last, v1, vf):
    """Lowest speed worth entering a descent with (OSRD's AcceleratingSlopeCoast.computeV, MARECO).

    v = 1 / (1/v_l + R(v_l) / (w (1 - r))), w = R(v1) v1 vf / (v1 - vf), r = (coasting acceleration
    one train length before the descent, capped at 0) / (mean coasting acceleration on it).
    """
    train, x = case.train, case.nodes
    speed = float(base[first])
    rolling = lambda v: float(davis_resistance(v, *train.davis))  # noqa: E731
    before = int(np.searchsorted(x, x[first] - max(train.length, 1.0))) - 1
    previous = min(0.0, float(natural[max(before, 0)])) if first > 0 else 0.0
    ratio = previous / max(float(np.mean(natural[first:last + 1])), 1e-9)
    w = rolling(v1) * v1 * vf / max(v1 - vf, 1e-9)
    return 1.0 / (1.0 / speed + rolling(speed) / max(w * (1.0 - ratio), 1e-12))


def _through(case, base, e, vf, fixed):
    """Speed at node ``e`` of the coast that passes vf exactly where the braking curve does.

    The braking curve crosses vf inside the interval before ``e``; starting the coast from the
    node's braking speed instead would make the profile jump as v1 (and vf) move a node.
    """
    x, train = case.nodes, case.train
    hi, lo = base[e - 1] ** 2, base[e] ** 2
    share = (hi - vf * vf) / max(hi - lo, 1e-12)  # v^2 is linear in s under constant deceleration
    rest = (1 - share) * (x[e] - x[e - 1])
    a, b, c = train.davis
    resist = a + b * vf + c * vf * vf + fixed[e - 1]
    return float(np.sqrt(max(vf * vf - 2 * rest * resist / train.mass, 0.0)))


def profile(case, v1):
    """MARECO-style speeds on the grid for the cap ``v1`` [m/s]."""
    capped = np.minimum(case.limits, v1)
    base = envelope_speeds(case.segment, case.train, case.nodes, capped)
    vf = coasting_floor(case.train, v1)
    fixed = interval_grade_force(case.segment, case.train, case.nodes)
    out = base.copy()
    first = np.inf  # coasts are laid from the end; one that overlaps a later coast is skipped
    for end, start_speed, floor in opportunities(case, base, capped, v1, vf, fixed):
        if end > first:
            continue
        found = coast_back(case, base, end, floor, fixed, start_speed)
        if found is None:
            continue
        start, speeds = found
        stop = start + 1 + len(speeds)  # a forward coast may rejoin the profile before ``end``
        out[start + 1:stop] = np.minimum(out[start + 1:stop], speeds)
        first = start
    return out


def cap_ceiling(case):
    """A cap above which nothing changes: above the limits v1 only raises vf, and once vf reaches
    every limit nothing coasts (OSRD's computeInitialHighBound)."""
    hi = top = float(np.max(case.limits))
    while coasting_floor(case.train, hi) < top and hi < 1e3 * top:
        hi *= 2
    return hi


def cap_for(case, target, lo=None, hi=None, iterations=50):
    """The cap v1 whose grid running time is ``target`` (bisection; the time falls as v1 rises)."""
    lo = lo if lo is not None else 0.5
    hi = hi if hi is not None else cap_ceiling(case)
    if running_time(profile(case, hi), case.nodes) > target:
        return None
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if running_time(profile(case, mid), case.nodes) > target:
            lo = mid
        else:
            hi = mid
    return hi


def mareco(case, running_time_s, drive, rounds=3):
    """(cap v1 [m/s], handles, simulated trace) meeting ``running_time_s`` on the simulator.

    ``drive(case, speeds)`` turns speeds into handles and their simulation (strategies.drive).
    The grid time of a profile differs slightly from the simulated one, so the grid target is
    corrected by the simulated error a few times; the round whose simulated arrival is nearest the
    time is the run (a corrected target no cap meets ends the rounds).
    """
    target = running_time_s
    runs = []
    for _ in range(rounds):
        v1 = cap_for(case, target)
        if v1 is None and runs:
            break
        if v1 is None:
            raise InfeasibleError(f"the MARECO-style heuristic cannot meet {running_time_s:.6g} s")
        u, trace = drive(case, profile(case, v1))
        runs.append((v1, u, trace))
        error = trace.arrival_time - running_time_s
        if abs(error) <= 0.01:
            break
        target -= error
    return min(runs, key=lambda run: abs(run[2].arrival_time - running_time_s))
