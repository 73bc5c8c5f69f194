"""The DC supply of trains on one substation (Farooqi 2018 §7.2.1, eq. 7.8).

Every running train i is a node at pantograph voltage V_i, joined to the substation bus by the
line resistance R(x_i) = r |x_i - x_sub| (r per km, thesis: 25 mOhm/km); the bus is fed by the
source V_s through the internal resistance R_s (eq. 7.8 written for the bus voltage V_0):

    V_i = V_0 - R(x_i) I_i,      V_0 = V_s - R_s I_s,      I_s = sum_i I_i

A train draws the power p_i = V_i I_i (traction, I_i > 0) or feeds it (regeneration, I_i < 0).
The substation is a diode rectifier: I_s >= 0. When the trains feed more than the others draw,
the bus floats above V_s with I_s = 0, and a feeding train may not raise its voltage above
V_max (thesis: 685 V on a 600 V supply): what it cannot feed goes to its rheostat (lost).
Optional current limits per train (thesis Fig. 7.7: the largest traction and braking currents
at 600 / 685 V): traction beyond V_i I_max is not served, regeneration beyond V_i I_regen is lost.

Units inside the electrical model: kV, kA, MW, Ohm (kV = Ohm kA, MW = kV kA).
"""

import numpy as np
import pyomo.environ as pyo


def _current(v0, r, p):
    """Current [kA] drawn (p > 0) or fed (p < 0) at power p [MW] through r [Ohm] from bus v0 [kV]
    (arrays broadcast)."""
    r = np.maximum(r, 1e-12)
    disc = v0 * v0 - 4.0 * r * p
    beyond = disc < 0  # beyond the largest power the line can carry: the train takes what it can
    return np.where(beyond, v0 / (2.0 * r), 2.0 * p / (v0 + np.sqrt(np.where(beyond, 0.0, disc))))  # the small root


def _currents(v0, r, p, vmax, imax=np.inf, iregen=np.inf):
    """Currents [kA] at bus voltage v0 (one per instant, shape (T, 1)) of the trains (T, n): a feeding
    train is held at vmax (the rest is lost), and no train draws more than imax or feeds more than
    iregen [kA] (what is cut off is unserved traction or lost regeneration)."""
    ii = _current(v0, r, p)
    held = (p < 0) & (v0 - r * ii > vmax)
    ii = np.where(held, (v0 - vmax) / np.maximum(r, 1e-12), ii)
    return np.minimum(np.maximum(ii, -iregen), imax)


def _bisect(inside, lo, hi, iterations):
    """Per instant, the boundary between ``inside(v)`` True (below) and False (above) in [lo, hi]."""
    lo, hi = np.array(lo, float), np.array(hi, float)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        below = inside(mid)
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return lo, hi


def _arrays(supply, positions, powers):
    """(running mask, R(x) [Ohm], p [MW]) of trains (T, n); a NaN position is a train not running."""
    x = np.atleast_2d(np.asarray(positions, float))
    mask = np.isfinite(x)
    p = np.where(mask, np.atleast_2d(np.asarray(powers, float)), 0.0) / 1e6
    r = np.where(mask, supply.feeder(np.where(mask, x, supply.position)), 1.0)
    return mask, r, p


def solve_steps(supply, positions, powers):
    """Currents, voltages and flows of many instants at once.

    positions: line positions [m] of the trains, shape (T instants, n trains), NaN where a train is
    not running; powers: their pantograph powers [W] (negative: regeneration offered), same shape.
    Returns a dict of arrays in SI units (A, V, W): per train (T, n), NaN voltages where not
    running; per instant (T,)."""
    mask, r, p = _arrays(supply, positions, powers)
    vs, rs, vmax = supply.voltage / 1e3, supply.resistance, supply.max_voltage / 1e3
    limits = supply.max_current / 1e3, supply.max_regen_current / 1e3

    def net(v0, at=slice(None)):  # current drawn from the bus at bus voltage v0, instants ``at``
        return np.sum(_currents(v0[:, None], r[at], p[at], vmax, *limits), axis=1)

    v0 = np.full(len(p), vs)  # also where nobody is on the line
    # the trains feed at least what they draw: the diode blocks, the bus floats up to where the
    # trains' net current is zero (at most vmax: every feeder held there, the surplus lost)
    floating = (net(v0) <= 0.0) & mask.any(axis=1)
    drawing = ~floating & mask.any(axis=1)
    k = np.count_nonzero(floating)
    v0[floating] = _bisect(lambda v: net(v, floating) < 0, np.full(k, vs), np.full(k, vmax), 80)[1]
    # otherwise V_0 = V_s - R_s I_s(V_0): bisection between a collapsed bus and V_s
    k = np.count_nonzero(drawing)
    lo, hi = _bisect(lambda v: v < vs - rs * np.maximum(net(v, drawing), 0.0), np.full(k, 0.05 * vs), np.full(k, vs), 80)
    v0[drawing] = 0.5 * (lo + hi)
    i_s = np.where(drawing, np.maximum(net(v0), 0.0), 0.0)
    currents = np.where(mask, _currents(v0[:, None], r, p, vmax, *limits), 0.0)
    out = _flows(supply, r, currents, np.where(mask, v0[:, None] - r * currents, np.nan), p, vs, i_s)
    out["bus_voltage_V"] = v0 * 1e3
    return out


def solve_step(supply, positions, powers):
    """:func:`solve_steps` for one instant: the running trains' positions [m] and powers [W]."""
    out = solve_steps(supply, np.reshape(np.asarray(positions, float), (1, -1)),
                      np.reshape(np.asarray(powers, float), (1, -1)))
    return {k: (float(v[0]) if np.ndim(v) == 1 else v[0]) for k, v in out.items()}


def sensed_voltages(supply, positions, powers):
    """Pantograph voltages [V] of eq. 7.8 exactly as the thesis writes it: a receptive source
    (no diode, no V_max), V_0 = V_s - R_s sum I_i solved by bisection; trains (T, n) as in
    :func:`solve_steps` (NaN where not running), or the running trains of one instant (n,).

    This is the supervisor's view for rule 7.11 (Farooqi 2018 §7.2.1: regeneration is detected
    by the voltage change at the train nodes). On the real line (:func:`solve_steps`) a surplus that
    nobody draws carries no current, every node sits at the same voltage and the comparison
    V_i < V_(i-1) sees nothing, just when the energy is lost; here the feeding train is always
    above the others."""
    mask, r, p = _arrays(supply, positions, powers)
    vs, rs = supply.voltage / 1e3, supply.resistance
    count = len(p)

    def below(v0):  # excess(v0) < 0; excess is increasing in v0 wherever the line can carry the powers
        return v0 - vs + rs * np.sum(_current(v0[:, None], r, p), axis=1) < 0

    lo, hi = _bisect(below, np.full(count, 0.3 * vs), np.full(count, 2.0 * vs), 60)
    v0 = 0.5 * (lo + hi)
    volts = np.where(mask, v0[:, None] - r * _current(v0[:, None], r, p), np.nan) * 1e3
    return volts[0] if np.ndim(positions) == 1 else volts


def _flows(supply, r, currents, volts, p, vs, i_s):
    """Energy flows [W] per train (T, n) and per instant (T,) from the solved circuit (currents 0
    and voltages NaN where a train is not running)."""
    drawn = np.nan_to_num(volts) * currents  # MW at each pantograph
    offered = np.where(p < 0, -p, 0.0)
    fed = np.where(p < 0, -drawn, 0.0)
    return {
        "current_A": currents * 1e3, "voltage_V": volts * 1e3,
        "substation_W": vs * i_s * 1e6, "substation_current_A": i_s * 1e3,
        "traction_input_W": np.sum(np.where(p > 0, drawn, 0.0), axis=1) * 1e6,
        "regen_used_W": np.sum(fed, axis=1) * 1e6,
        "regen_lost_W": np.sum(offered - fed, axis=1) * 1e6,
        "line_loss_W": (np.sum(r * currents ** 2, axis=1) + supply.resistance * i_s ** 2) * 1e6,
        "unserved_W": np.sum(np.where(p > 0, p - drawn, 0.0), axis=1) * 1e6,
        "fed_W": fed * 1e6,
    }


def add_network(m, supply, steps, eps=1e-5, floating=False):
    """Pyomo constraints of eq. 7.8 on the joint model ``m`` (kV, kA, MW).

    ``steps``: for every clock step t, the list of (leg block, local step j, line start, direction)
    of the trains running then. Adds I_s[t], the bus voltage V0[t], I[t, q], V[t, q], the rheostat
    power [MW] and the expression m.substation_mw[t] = V_s I_s.

    The bus is written V_0 = V_s - R_s I_s with I_s >= 0 (default): where the trains feed more
    than the others draw, the feeders burn the surplus in their rheostats at V_0 = V_s instead of
    the bus floating above V_s. For given train powers this reaches the same substation energy as
    the real circuit (``solve_steps``): where the real substation supplies, its bus is on that line
    (the same state); where the real bus floats, I_s = 0 there and here alike, and a feeder at
    V_0 = V_s can deliver at least what it could from the higher floating bus (its voltage stays
    below V_max more easily). The NLP's rheostats and bus voltages at floating steps are then not
    the physical ones; every strategy is scored by ``solve_steps``. ``floating=True``: the bus as
    the diode makes it, V_0 = V_s - R_s I_s + u, u >= 0, I_s u <= ``eps`` [MW]: a complementarity
    at every step, which the joint optimum paid for with 125 / 1100 Ipopt iterations on 1 / 2 trains
    against 53 / 79 pinned (docs/benchmarks.md).
    """
    vs, rs = supply.voltage / 1e3, supply.resistance
    vmin, vmax = supply.min_voltage / 1e3, supply.max_voltage / 1e3
    index = [(t, q) for t, running in enumerate(steps) for q in range(len(running))]
    m.T_net = pyo.RangeSet(0, len(steps) - 1)
    fed, drawn = (supply.max_regen_current / 1e3, supply.max_current / 1e3)  # [kA], inf: no limit
    m.Ipan = pyo.Var(index, bounds=(-fed if np.isfinite(fed) else None, drawn if np.isfinite(drawn) else None),
                     initialize=0.0)
    m.Vpan = pyo.Var(index, bounds=(vmin, vmax), initialize=vs)
    if floating:
        # the diode: V_0 = V_s - R_s I_s + u with I_s, u >= 0 and I_s u <= eps (relaxed
        # complementarity: the bus floats above V_s only while I_s = 0). Measured: 294
        # Ipopt iterations on one train where the smooth max((V_s - V_0) / R_s, 0) over 1 A took 1307.
        m.V0 = pyo.Var(m.T_net, bounds=(vmin, vmax), initialize=vs)
        m.Is = pyo.Var(m.T_net, bounds=(0.0, None), initialize=0.0)
        m.float_up = pyo.Var(m.T_net, bounds=(0.0, None), initialize=0.0)
        m.bus = pyo.Constraint(m.T_net, rule=lambda m, t: m.V0[t] == vs - rs * m.Is[t] + m.float_up[t])
        m.diode = pyo.Constraint(m.T_net, rule=lambda m, t: m.Is[t] * m.float_up[t] <= eps)
    else:  # V_0 >= V_min bounds the substation current
        m.Is = pyo.Var(m.T_net, bounds=(0.0, (vs - vmin) / max(rs, 1e-12)), initialize=0.0)
        m.V0 = pyo.Expression(m.T_net, rule=lambda m, t: vs - rs * m.Is[t])

    def feeder(b, j, start, direction):
        x = start + direction * 0.5 * (b.s[j] + b.s[j + 1])
        return supply.line_resistance * ((x - supply.position) ** 2 + 1.0) ** 0.5

    m.kvl = pyo.Constraint(index, rule=lambda m, t, q: m.Vpan[t, q] == m.V0[t] - feeder(*steps[t][q]) * m.Ipan[t, q])
    # a feeding train burns in its rheostat what the line cannot take (>= 0; burning power while
    # motoring only costs substation energy, so the optimum never does it: no constraint needed)
    m.rheostat = pyo.Var(index, bounds=(0.0, None), initialize=0.0)
    m.power = pyo.Constraint(index, rule=lambda m, t, q: m.Vpan[t, q] * m.Ipan[t, q]
                             == steps[t][q][0].p[steps[t][q][1]] / 1e3 + m.rheostat[t, q])

    m.kcl = pyo.Constraint(m.T_net, rule=lambda m, t: sum(m.Ipan[t, q] for q in range(len(steps[t]))) == m.Is[t])
    m.substation_mw = pyo.Expression(m.T_net, rule=lambda m, t: vs * m.Is[t])
    return index
