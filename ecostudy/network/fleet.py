"""Several trains on one line and one substation: timetables, strategies, the joint optimum.

Every train runs the same stops with the same running times and dwells, offset by its departure
time, on one clock of step dt (``timedomain``). Strategies (thesis 000 Ch. 7-8, thesis 001 §6.2.3):

independent  each train minimises its own pantograph net energy, regeneration credited as if
             the line always took it (a): no collaboration
receptivity  the supervisor rounds below with no rule: each train's regeneration credited only
             up to what the line could take from it, given the others' runs (a baseline that
             shows what the rules add)
triggering   supervisor rule 7.7: while another train brakes, a train's traction is weighted
             (1 - gamma2) / (1 - gamma1) with the thesis' gamma1 = 0.71, gamma2 = 0.9 (b)
voltage      rule 7.11 as the thesis' text applies it, between consecutive trains: while the
             pantograph voltage of the train ahead is above a train's own (it regenerates),
             that train's traction weighs 0 (c); the voltages are those of eq. 7.8 as written
             (a receptive source, :func:`sensed`): on the line with the diode a surplus nobody
             draws carries no current and the comparison would see nothing
dissension   thesis 000 eqs. 8.14-8.17: each train's weight gamma_i follows a two-state Markov
             law whose rate away from "braking" grows with the number of braking neighbours;
             traction weighs gamma_i / gamma0 (d)
joint        one NLP over all trains and the network of eq. 7.8 minimising substation energy:
             the bound no rule can beat (e)
following    the independent runs, each train's head kept ``buffer`` metres behind the tail of
             the one ahead on the common clock (thesis 001 eq. 6.9), the leader's time-position
             profile fixed (f)

The rules (b), (c), (d) re-optimise one train at a time against the others' latest runs, for a
few supervisor rounds, keeping the timetable; their regeneration is credited only up to what the
line could take then (:func:`supervised`). Every strategy is scored by the same network solve
(``circuit.solve_step``).
"""
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pyomo.environ as pyo

from ecostudy.analysis.single import solve_run
from ecostudy.analysis.tables import handles
from ecostudy.core.errors import SolverError
from ecostudy.core.physics import hinge
from ecostudy.core.simulate import verify
from ecostudy.core.types import Timing
from ecostudy.core.units import KWH
from ecostudy.core.types import Supply
from ecostudy.network import circuit
from ecostudy.ocp import session
from ecostudy.ocp import space as formulation
from ecostudy.ocp import timedomain
from ecostudy.ocp.problem import prepare

GAMMA = (0.71, 0.9)  # thesis 000 Fig. 7.3: time weights without / with a braking neighbour


@dataclass
class Fleet:
    """The timetable of every train on the clock: legs[train][segment]."""

    names: list
    legs: list
    dt: float
    steps: int
    supply: Supply
    buffer: float = None
    results: dict = field(default_factory=dict)  # space-domain net-energy runs per segment (guesses)
    dwell_steps: int = 0


def plan(track, train, stops, running_times, dwell, offsets, names, dt, supply, points=500, buffer=None):
    """A :class:`Fleet`: running times and dwells rounded up to whole steps, departures offset."""
    cases = [prepare(track, train, a, b, points) for a, b in zip(stops[:-1], stops[1:])]
    steps = [int(np.ceil(t / dt - 1e-9)) for t in running_times]
    pause = int(np.ceil(dwell / dt - 1e-9))
    legs = []
    for offset in offsets:
        start, mine = int(round(offset / dt)), []
        for case, n, a in zip(cases, steps, stops[:-1]):
            b = stops[stops.index(a) + 1]
            direction = 1.0 if track.stops[b] >= track.stops[a] else -1.0
            mine.append(timedomain.Leg(case, start, n, dt, track.stops[a], direction))
            start += n + pause
        legs.append(mine)
    total = max(leg.start + leg.steps for mine in legs for leg in mine)
    results = {}
    for case, n in zip(cases, steps):
        seg = case.segment
        results[(seg.from_stop, seg.to_stop)] = solve_run(track, train, seg.from_stop, seg.to_stop,
                                                          Timing(running_time=n * dt), objective="net_energy",
                                                          points=points, verify_result=False)
    return Fleet(list(names), legs, dt, total, supply, buffer, results, pause)


def _guess(fleet, leg):
    seg = leg.case.segment
    return timedomain.guess_from_space(fleet.results[(seg.from_stop, seg.to_stop)], leg)


# the joint NLP starts from a feasible point (the independent runs on the solved network): keep
# Ipopt near it instead of pushing every variable at a bound 1 % inside
# (measured on the 2-train study: the adaptive barrier update left the start and took 3000
# iterations; a monotone one from mu 1e-3 converged in 730)
NEAR_START = {"bound_push": 1e-8, "bound_frac": 1e-8, "mu_strategy": "monotone", "mu_init": 1e-3}


REGULARISATION = 1e-3  # [-] weight of rheostat power and bus-voltage offset in the joint objective


def _solve(m, what, options=None):
    out = session.solve(m, options)
    if not out.usable:
        raise SolverError(f"{what}: Ipopt {out.status} after {out.iterations} iterations")
    return out


def _energy_ref(fleet):
    """Objective scale [kWh s / h = kJ]: model.energy_reference summed over one train's legs."""
    return sum(formulation.energy_reference(leg.case.train, leg.case.segment) for leg in fleet.legs[0]) / 1e3


def solve_train(fleet, i, weights=None, guesses=None, ahead=None, allowance=None, credit=None):
    """Train ``i`` alone: minimise sum (w_t traction - regeneration) dt over its legs.

    ``weights``: traction weight per clock step (default 1). ``allowance``: power [kW] per clock
    step that the weight applies to; traction above it costs in full:
    w min(P, a) + max(P - a, 0) = w P + (1 - w) max(P - a, 0). ``ahead``: the line position of the
    train ahead per clock step (NaN where it is not on the line) to stay ``fleet.buffer`` behind.
    Returns ([(s, v, ft, fb, fr, p) per leg], solver outcome).
    """
    m = pyo.ConcreteModel()
    blocks = []
    for k, leg in enumerate(fleet.legs[i]):
        guess = guesses[k][:5] if guesses is not None else _guess(fleet, leg)
        blocks.append(timedomain.add_leg(m, f"leg{k}", leg, guess, one_handle=weights is not None))
    w = np.ones(fleet.steps) if weights is None else weights

    def traction_cost(leg, b, j):
        wt = float(w[leg.start + j])
        if allowance is not None and allowance[leg.start + j] <= 0.0:
            return b.traction_kw[j]  # nothing offered: w min(P, 0) + max(P, 0) = P, no smoothing
        if allowance is None or wt >= 1.0:
            return wt * b.traction_kw[j]
        return wt * b.traction_kw[j] + (1 - wt) * hinge(b.traction_kw[j] - float(allowance[leg.start + j]), 10.0)

    def regen_credit(leg, b, j):  # min(regenerated, what the line takes) [kW], smooth over 10 kW
        if credit is None:
            return b.regen_kw[j]
        cap = float(credit[leg.start + j])
        return 0.0 if cap < 10.0 else b.regen_kw[j] - hinge(b.regen_kw[j] - cap, 10.0)

    cost = sum(traction_cost(leg, b, j) - regen_credit(leg, b, j) for leg, b in zip(fleet.legs[i], blocks) for j in b.I)
    m.objective = pyo.Objective(expr=cost * fleet.dt / _energy_ref(fleet))
    if ahead is not None and fleet.buffer is not None:
        m.separation = pyo.ConstraintList()
        for leg, b in zip(fleet.legs[i], blocks):
            for j in b.K:
                x_ahead = ahead[leg.start + j]
                if np.isfinite(x_ahead):  # head-to-tail: the train ahead is train.length long
                    m.separation.add(leg.direction * (x_ahead - leg.line_start) - b.s[j]
                                     >= fleet.buffer + leg.case.train.length)
    outcome = _solve(m, f"train {fleet.names[i]}")
    return [timedomain.leg_arrays(b) for b in blocks], outcome


def line_positions(fleet, i, runs):
    """Line position of train ``i`` per clock step (NaN before departure and after arrival)."""
    x = np.full(fleet.steps + fleet.dwell_steps + 1, np.nan)
    for k, (leg, run) in enumerate(zip(fleet.legs[i], runs)):
        x[leg.start:leg.start + leg.steps + 1] = leg.line_start + leg.direction * run[0]
        end = leg.start + leg.steps
        nxt = fleet.legs[i][k + 1].start if k + 1 < len(fleet.legs[i]) else end + fleet.dwell_steps + 1
        x[end:nxt] = leg.line_start + leg.direction * run[0][-1]  # dwelling (at the terminus too)
    return x


def step_powers(fleet, runs_by_train):
    """Per clock step: [(train, line position [m], power [W], local step, leg)] of the running trains."""
    out = [[] for _ in range(fleet.steps)]
    for i, runs in enumerate(runs_by_train):
        for k, (leg, run) in enumerate(zip(fleet.legs[i], runs)):
            s, p = run[0], run[5]
            for j in range(leg.steps):
                out[leg.start + j].append((i, leg.line_start + leg.direction * 0.5 * (s[j] + s[j + 1]), p[j], j, k))
    return out


def evaluate(fleet, runs_by_train):
    """Score runs on the network: per-step flows, per-train and substation totals [kWh]."""
    rows, per_train = [], {n: {"traction_kWh": 0.0, "braking_kWh": 0.0, "braking_regen_offered_kWh": 0.0,
                               "regen_used_kWh": 0.0, "regen_lost_kWh": 0.0, "line_input_kWh": 0.0}
                           for n in fleet.names}
    dt = fleet.dt
    for t, running in enumerate(step_powers(fleet, runs_by_train)):
        flows = circuit.solve_step(fleet.supply, [r[1] for r in running], [r[2] for r in running])
        for q, (i, _, p, j, k) in enumerate(running):
            name, run = fleet.names[i], runs_by_train[i][k]
            vbar = 0.5 * (run[1][j] + run[1][j + 1])
            rec = per_train[name]
            rec["traction_kWh"] += run[2][j] * vbar * dt / KWH
            rec["braking_kWh"] += run[3][j] * vbar * dt / KWH  # at the wheel, friction and electric
            rec["braking_regen_offered_kWh"] += max(-p, 0.0) * dt / KWH
            rec["regen_used_kWh"] += flows["fed_W"][q] * dt / KWH
            rec["regen_lost_kWh"] += (max(-p, 0.0) - flows["fed_W"][q]) * dt / KWH
            rec["line_input_kWh"] += max(flows["voltage_V"][q] * flows["current_A"][q], 0.0) * dt / KWH
        rows.append({"time_s": t * dt, "substation_kW": flows["substation_W"] / 1e3,
                     "traction_input_kW": flows["traction_input_W"] / 1e3, "regen_used_kW": flows["regen_used_W"] / 1e3,
                     "regen_lost_kW": flows["regen_lost_W"] / 1e3, "line_loss_kW": flows["line_loss_W"] / 1e3,
                     "unserved_kW": flows["unserved_W"] / 1e3,
                     "min_voltage_V": float(flows["voltage_V"].min()) if len(running) else np.nan,
                     "max_voltage_V": float(flows["voltage_V"].max()) if len(running) else np.nan,
                     **{f"voltage_{fleet.names[i]}_V": float(flows["voltage_V"][q]) for q, (i, *_) in enumerate(running)}})
    steps = pd.DataFrame(rows)
    e = {k: float(steps[k].sum() * dt / 3600) for k in ("substation_kW", "traction_input_kW", "regen_used_kW",
                                                          "regen_lost_kW", "line_loss_kW", "unserved_kW")}
    lhs, rhs = e["substation_kW"] + e["regen_used_kW"], e["traction_input_kW"] + e["line_loss_kW"]
    totals = {"substation_kWh": e["substation_kW"], "traction_input_kWh": e["traction_input_kW"],
              "regen_used_kWh": e["regen_used_kW"], "regen_lost_kWh": e["regen_lost_kW"],
              "line_losses_kWh": e["line_loss_kW"], "unserved_kWh": e["unserved_kW"],
              "balance_error_pct": 100 * (lhs - rhs) / max(rhs, 1e-9),
              "min_voltage_V": float(steps["min_voltage_V"].min()), "max_voltage_V": float(steps["max_voltage_V"].max())}
    return steps, per_train, totals


def _braking_steps(fleet, runs_by_train, share=0.1):
    """Per train, the clock steps in which it regenerates more than ``share`` of its peak power."""
    out = []
    for i, runs in enumerate(runs_by_train):
        flag = np.zeros(fleet.steps, bool)
        for leg, run in zip(fleet.legs[i], runs):
            peak = max(float(np.max(-run[5])), 1.0)
            flag[leg.start:leg.start + leg.steps] = -run[5] > share * peak
        out.append(flag)
    return out


def departure_order(fleet):
    """Train indices in order of first departure: each one's train ahead is the one before it."""
    return [int(i) for i in np.argsort([legs[0].start for legs in fleet.legs], kind="stable")]


def _others(flags, i):
    return np.any([f for j, f in enumerate(flags) if j != i], axis=0) if len(flags) > 1 else np.zeros_like(flags[0])


def independent(fleet):
    return [solve_train(fleet, i)[0] for i in range(len(fleet.names))]


DISSENSION = {"gamma0": 0.5, "rate": 0.05, "influence": 0.15}  # [-], [1/s], [1/s]


def dissension_weights(fleet, flags):
    """Traction weights gamma_i(t) / gamma0 of the dissension strategy (thesis 000 eqs. 8.14-8.17).

    Each train's q_i = [gamma_i, 1 - gamma_i] follows q' = (Q^T + A_i^T) q with the two-state
    generator Q = [[-r, r], [r, -r]] (rest value gamma0 = 0.5) and the interaction rate
    a_12 = lambda_1 / (M - 1) * (number of other trains braking), lambda_2 = 0 (eq. 8.15-8.17):
    while others brake, gamma_i falls (to 0.29 with one of two neighbours braking, the thesis'
    0.5 -> 0.3), and it is reset to gamma0 at every departure. Integrated exactly per clock step.
    """
    g0, r, lam = DISSENSION["gamma0"], DISSENSION["rate"], DISSENSION["influence"]
    count = np.sum(flags, axis=0)
    out = []
    for i, legs in enumerate(fleet.legs):
        braking_others = count - flags[i]
        a12 = lam * braking_others / max(len(fleet.legs) - 1, 1)
        gamma = np.full(fleet.steps, g0)
        departures = {leg.start for leg in legs}
        g = g0
        for t in range(fleet.steps):
            if t in departures:
                g = g0
            total = 2 * r + a12[t]  # gamma' = -(r + a12) gamma + r (1 - gamma)
            target = r / total
            g = target + (g - target) * np.exp(-total * fleet.dt)
            gamma[t] = g
        out.append(gamma / g0)
    return out


def offered(fleet, runs_by_train):
    """Regenerated power each train offers per clock step [kW] (what its electric brake feeds)."""
    out = np.zeros((len(runs_by_train), fleet.steps))
    for i, runs in enumerate(runs_by_train):
        for leg, run in zip(fleet.legs[i], runs):
            out[i, leg.start:leg.start + leg.steps] = np.maximum(-run[5], 0.0) / 1e3
    return out


def _probe(fleet, runs_by_train, i, power_w):
    """For each clock step where train ``i`` runs beside another and ``power_w(t)`` is not None:
    (t, its index q, the circuit solved with train i at that power [W], the others as they run)."""
    for t, running in enumerate(step_powers(fleet, runs_by_train)):
        mine = [q for q, r in enumerate(running) if r[0] == i]
        power = power_w(t) if mine and len(running) > 1 else None
        if power is not None:
            ps = [r[2] for r in running]
            ps[mine[0]] = power
            yield t, mine[0], circuit.solve_step(fleet.supply, [r[1] for r in running], ps)


def deliverable(fleet, runs_by_train, i, offer_kw):
    """Per clock step, the part [kW] of ``offer_kw`` that train ``i`` could take over the line:
    the regeneration used with train i drawing the offer, less that with train i at rest, the
    others as they run (the circuit of ``circuit.solve_step``: line losses, V_max, the diode)."""
    def used(demand_w):  # regeneration used per step with train i drawing demand_w(t)
        return {t: flows["regen_used_W"] for t, _, flows in _probe(fleet, runs_by_train, i, demand_w)}

    drawing = used(lambda t: offer_kw[t] * 1e3 if offer_kw[t] > 0 else None)
    idle = used(lambda t: 0.0 if offer_kw[t] > 0 else None)
    out = np.zeros(fleet.steps)
    for t, watts in drawing.items():
        out[t] = max(watts - idle[t], 0.0) / 1e3
    return out


RECEPTIVITY_PROBE = 5e6  # [W] a regeneration no train offers: what the line takes of it is its limit


def receptivity(fleet, runs_by_train, i):
    """Per clock step, the regenerated power [kW] the line could take from train ``i`` while the
    others run as in ``runs_by_train`` (train i offering ``RECEPTIVITY_PROBE``; ``circuit.solve_step``)."""
    out = np.zeros(fleet.steps)
    for t, q, flows in _probe(fleet, runs_by_train, i, lambda t: -RECEPTIVITY_PROBE):
        out[t] = flows["fed_W"][q] / 1e3
    return out


def sensed(fleet, runs_by_train):
    """Pantograph voltages [V] per train and clock step as rule 7.11's supervisor sees them
    (``circuit.sensed_voltages``: eq. 7.8 with a receptive source); NaN where a train is not running."""
    out = np.full((len(runs_by_train), fleet.steps), np.nan)
    for t, running in enumerate(step_powers(fleet, runs_by_train)):
        if running:
            volts = circuit.sensed_voltages(fleet.supply, [r[1] for r in running], [r[2] for r in running])
            out[[r[0] for r in running], t] = volts
    return out


def rule_terms(fleet, rule, runs_by_train, i):
    """(traction weight, allowance [kW]) per clock step of train ``i`` under ``rule``, from the
    runs as they are now: 7.7 discounts by (1 - gamma2) / (1 - gamma1) while another train brakes,
    dissension by gamma_i / gamma0 (:func:`dissension_weights`), both up to the power the others
    offer; 7.11 (between consecutive trains, as the thesis' text applies it) weighs 0 while the
    voltage of the train ahead is above one's own (:func:`sensed`), up to what the line can
    deliver of that train's offer (:func:`deliverable`)."""
    if rule == "receptivity":  # no rule: the rounds' receptivity credit alone
        return np.ones(fleet.steps), np.zeros(fleet.steps)
    power = offered(fleet, runs_by_train)
    others = power.sum(axis=0) - power[i]
    if rule == "triggering":
        flags = _braking_steps(fleet, runs_by_train)
        return np.where(_others(flags, i), (1 - GAMMA[1]) / (1 - GAMMA[0]), 1.0), others
    if rule == "dissension":
        return dissension_weights(fleet, _braking_steps(fleet, runs_by_train))[i], others
    order = departure_order(fleet)
    rank = order.index(i)
    if rank == 0:
        return np.ones(fleet.steps), np.zeros(fleet.steps)
    ahead = order[rank - 1]
    volts = sensed(fleet, runs_by_train)
    higher = (volts[ahead] > volts[i] + 1.0) & (power[ahead] > 0)  # NaN (not running) compares False
    return np.where(higher, 0.0, 1.0), deliverable(fleet, runs_by_train, i, np.where(higher, power[ahead], 0.0))


def supervised(fleet, rule, start, rounds=3):
    """Rules (b), (c) and (d): supervisor rounds; in each, the trains in departure order are
    re-optimised one by one against the others' latest runs (Gauss-Seidel: a train never plans
    against a run that has already been replaced).

    With a ``fleet.buffer``, each train stays that far behind the tail of the one ahead, as that
    one now runs (thesis 001 eq. 6.9, as in :func:`following`).
    Each train minimises w traction (discounted up to an allowance, :func:`rule_terms`; a zero
    weight on unlimited traction only moves consumption to the substation) minus its regeneration
    credited up to what the line could take from it then (:func:`receptivity`; crediting all of it,
    as independent driving does, let a discounted train accelerate and brake harder and lose the
    extra braking: measured +1 % substation energy for rule 7.11 on the 2-train study). Returns
    (runs, rounds' substation kWh); the runs are those of the best round, the start included.
    """
    runs = list(start)
    _, _, totals = evaluate(fleet, runs)
    best = (totals["substation_kWh"], list(runs))
    history = [best[0]]
    order = departure_order(fleet)
    for _ in range(rounds):
        for rank, i in enumerate(order):
            weights, allowance = rule_terms(fleet, rule, runs, i)
            ahead = line_positions(fleet, order[rank - 1], runs[order[rank - 1]]) if rank and fleet.buffer else None
            runs[i] = solve_train(fleet, i, weights, guesses=runs[i], allowance=allowance,
                                  credit=receptivity(fleet, runs, i), ahead=ahead)[0]
        _, _, totals = evaluate(fleet, runs)
        history.append(totals["substation_kWh"])
        if history[-1] < best[0]:
            best = (history[-1], list(runs))
    return best[1], history


def following(fleet, start):
    """(f): trains in departure order, each kept ``fleet.buffer`` behind the one ahead."""
    order = departure_order(fleet)
    runs = list(start)
    for rank, i in enumerate(order):
        if rank == 0:
            continue
        ahead = line_positions(fleet, order[rank - 1], runs[order[rank - 1]])
        runs[i] = solve_train(fleet, i, guesses=runs[i], ahead=ahead)[0]
    return runs


def joint(fleet, start):
    """(e): all trains and the network in one NLP, substation energy minimised; from ``start``."""
    t0 = time.perf_counter()
    m = pyo.ConcreteModel()
    blocks = []
    for i, legs in enumerate(fleet.legs):
        blocks.append([timedomain.add_leg(m, f"t{i}_leg{k}", leg, start[i][k][:5]) for k, leg in enumerate(legs)])
    steps = [[] for _ in range(fleet.steps)]
    for i, legs in enumerate(fleet.legs):
        for leg, b in zip(legs, blocks[i]):
            for j in range(leg.steps):
                steps[leg.start + j].append((b, j, leg.line_start, leg.direction))
    if not all(steps):  # steps where no train runs carry no network variables
        keep = [t for t, s in enumerate(steps) if s]
        steps = [steps[t] for t in keep]
    circuit.add_network(m, fleet.supply, steps)
    _initialise_network(m, fleet, steps)
    # the rheostat and friction brakes are interchangeable, and with no current the bus voltage is
    # free: tiny costs on both remove these flat directions (Ipopt ran out of iterations on them)
    vs = fleet.supply.voltage / 1e3
    regular = REGULARISATION * (sum(m.rheostat[k] for k in m.rheostat) + sum((m.V0[t] - vs) ** 2 for t in m.T_net))
    m.objective = pyo.Objective(expr=(sum(m.substation_mw[t] for t in m.T_net) + regular) * 1e3 * fleet.dt
                                / _energy_ref(fleet))
    build_s = time.perf_counter() - t0
    outcome = _solve(m, "joint optimum", NEAR_START)
    runs = [[timedomain.leg_arrays(b) for b in bl] for bl in blocks]
    return runs, {"build_s": build_s, "solve_s": outcome.seconds + outcome.nl_seconds,
                  "iterations": outcome.iterations, "status": outcome.status,
                  "variables": sum(1 for _ in m.component_data_objects(pyo.Var, active=True))}


def _initialise_network(m, fleet, steps):
    """Network variables from the numeric solve of the start point (Ipopt starts near physics)."""
    for t, running in enumerate(steps):
        xs = [start + d * 0.5 * pyo.value(b.s[j] + b.s[j + 1]) for b, j, start, d in running]
        ps = [pyo.value(b.p[j]) * 1e3 for b, j, *_ in running]
        flows = circuit.solve_step(fleet.supply, xs, ps)
        vmin, vmax = fleet.supply.min_voltage / 1e3, fleet.supply.max_voltage / 1e3
        m.V0[t].set_value(float(np.clip(flows["bus_voltage_V"] / 1e3, vmin, vmax)))
        m.Is[t].set_value(flows["substation_current_A"] / 1e3)
        m.float_up[t].set_value(max(flows["bus_voltage_V"] / 1e3 - fleet.supply.voltage / 1e3
                                    + fleet.supply.resistance * flows["substation_current_A"] / 1e3, 0.0))
        for q, p in enumerate(ps):
            m.rheostat[t, q].set_value(max(-p - flows["fed_W"][q], 0.0) / 1e6)
            m.Ipan[t, q].set_value(float(flows["current_A"][q] / 1e3))
            m.Vpan[t, q].set_value(float(np.clip(flows["voltage_V"][q] / 1e3, vmin, vmax)))


def verify_leg(leg, run):
    """Re-simulate a leg's controls with the independent simulator (``simulate.verify``).

    The step forces become handles on the space intervals the steps cover (steps at standstill
    cover none), so the simulator drives them by position as it drives every other run.
    """
    s, v, ft, fb = run[:4]
    moving = np.diff(s) > 1e-6
    nodes = np.concatenate([[s[0]], s[1:][moving]])
    speeds = np.concatenate([[v[0]], v[1:][moving]])
    u = handles(leg.case.train, speeds, ft[moving], fb[moving])
    energy = float(np.sum(ft * np.diff(s)))
    return verify(leg.case.segment, leg.case.train, nodes, u, leg.running_time, energy)[0]


def separations(fleet, runs_by_train):
    """Smallest gap [m] from each train's head to the tail of the train ahead while both are on
    the line (None for the first train); negative: the trains would overlap."""
    order = departure_order(fleet)
    out = {fleet.names[order[0]]: None}
    length = fleet.legs[0][0].case.train.length
    for ahead, me in zip(order[:-1], order[1:]):
        gap = fleet.legs[me][0].direction * (line_positions(fleet, ahead, runs_by_train[ahead])
                                             - line_positions(fleet, me, runs_by_train[me])) - length
        both = np.isfinite(gap)
        out[fleet.names[me]] = float(gap[both].min()) if both.any() else None
    return out


def run_strategies(fleet, strategies, progress=print):
    """Every strategy on ``fleet``: {name: {"runs", "steps", "trains", "totals", "info"}}.

    The independent runs are solved first: they are strategy (a) and the start of the others.
    """
    out = {}
    t0 = time.perf_counter()
    ind = independent(fleet)
    base_s = time.perf_counter() - t0
    for name in strategies:
        t0 = time.perf_counter()
        info = {}
        try:
            if name == "independent":
                runs = ind
            elif name in ("receptivity", "triggering", "voltage", "dissension"):
                runs, history = supervised(fleet, name, ind)
                info["rounds_substation_kWh"] = history
            elif name == "joint":
                runs, info = joint(fleet, ind)
            elif name == "following":
                runs = following(fleet, ind)
            else:
                raise ValueError(f"unknown strategy {name!r}")
        except SolverError as exc:  # one strategy failing does not stop the study
            out[name] = {"failed": str(exc), "wall_s": time.perf_counter() - t0}
            if progress:
                progress(f"{name:12s} FAILED: {exc}")
            continue
        wall = time.perf_counter() - t0 + (base_s if name == "independent" else 0.0)
        steps, trains, totals = evaluate(fleet, runs)
        checks = [[verify_leg(leg, run) for leg, run in zip(fleet.legs[i], runs[i])] for i in range(len(runs))]
        gaps = separations(fleet, runs)
        for i, n in enumerate(fleet.names):
            ver = checks[i]
            last = fleet.legs[i][-1]
            trains[n].update(arrival_s=(last.start + last.steps) * fleet.dt,
                             worst_arrival_error_s=max(abs(v["arrival_time_error_s"]) for v in ver),
                             worst_stop_error_m=max(abs(v["stop_error_m"]) for v in ver),
                             worst_energy_error_pct=max(abs(v["energy_error_pct"]) for v in ver),
                             worst_overspeed_kmh=max(v["max_overspeed_kmh"] for v in ver),
                             verified=all(v["passed"] for v in ver), min_separation_m=gaps[n])
        totals.update(wall_s=wall, all_verified=all(t["verified"] for t in trains.values()),
                      min_separation_m=min([g for g in gaps.values() if g is not None], default=None))
        # only the joint optimum sees the circuit: another strategy's runs may ask for traction the
        # line cannot carry or a current limit forbids; it is not served and the result is flagged
        totals["status"] = "ok" if totals["unserved_kWh"] <= 1e-3 else (
            f"flagged: {totals['unserved_kWh']:.3f} kWh of traction not served (current limit or line)")
        out[name] = {"runs": runs, "steps": steps, "trains": trains, "totals": totals, "info": info}
        if progress:
            progress(f"{name:12s} substation {totals['substation_kWh']:.3f} kWh, {wall:.1f} s")
    return out
