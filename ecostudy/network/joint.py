"""Strategy (e): every train and the circuit of eq. 7.8 in one NLP minimising substation energy,
each train ``fleet.buffer`` behind the one ahead as the rules keep it: the bound no supervisor rule
can beat."""
import time

import numpy as np
import pyomo.environ as pyo

from ecostudy.core import kinematics
from ecostudy.core.errors import SolverError
from ecostudy.network import circuit, headway
from ecostudy.network.fleet import REGULARISATION, energy_ref, following_legs, solve_model
from ecostudy.network.legs import NEAR_START, separation_rows
from ecostudy.network.scoring import buffer_missed
from ecostudy.ocp import space, timedomain
from ecostudy.ocp.solver import IPOPT


# MUMPS's METIS ordering for the joint NLP: measured where it is set (``ocp.solver.IPOPT``)
ORDERING = IPOPT["joint"]


def joint(fleet, start, one_handle=False, floating=False):
    """(e): all trains and the network in one NLP, substation energy minimised; from ``start``.

    ``one_handle``: hold traction and braking apart in the NLP (a complementarity per train and
    step). Off by default: doing both never lowers the substation energy (it raises the train's
    draw), the solved legs are netted (``timedomain.leg_arrays``) and scored by the circuit.
    ``floating``: the bus with the diode's complementarity instead of pinned at V_s - R_s I_s
    (``circuit.add_network``: the same substation energy for given powers).

    The buffer's rows (``fleet.buffer``) are added only where the optimum without them comes nearer
    the train ahead than the buffer (``scoring.buffer_missed``), then the NLP is solved again with
    them from ``start``: where the buffer does not bind the optimum is that NLP's, and the rows,
    inactive, would only move Ipopt's path (the 3-train metro study's joint: 119 -> 149
    iterations and another local optimum, 44.345 -> 44.292 kWh, its trains 61.1 and 63.6 m apart
    at the closest with buffer_m 60).
    """
    try:
        runs, info = _solve(fleet, start, one_handle, floating, separated=False)
    except SolverError as exc:
        raise SolverError(why_not_powered(fleet, exc)) from None
    missed = buffer_missed(fleet, runs)
    if missed:  # the buffer binds: solved again with its rows
        try:
            runs, again = _solve(fleet, start, one_handle, floating, separated=True)
        except SolverError as exc:
            raise SolverError(why_not_separated(fleet, exc, missed)) from None
        info = {**again, **{k: info[k] + again[k] for k in ("build_s", "solve_s", "iterations")}}
    return runs, info


def why_not_powered(fleet, exc):
    """The reason the joint NLP has no usable point (``exc``: Ipopt's word), where the supply
    explains it: a lone train draws at most ``Supply.most_power`` at its pantograph (the substation's
    ``max_train_current_A``, or the line's voltage drop with the pantograph held at ``min_voltage_V``),
    at most eta_T times that at its wheels, and a segment whose fastest run under that power where
    the line gives most (``kinematics.envelope_speeds``) takes longer than its running time has no
    run at all. Else ``exc`` as it is."""
    supply = fleet.supply
    for leg in fleet.legs[0]:  # every train runs the same segment times
        case, seg = leg.case, leg.case.segment
        ends = sorted((leg.line_start, leg.line_start + leg.direction * seg.distance))
        nearest = max(ends[0] - supply.position, supply.position - ends[1], 0.0)
        drawn = supply.most_power(nearest)
        if not np.isfinite(drawn):
            continue
        train = case.train
        cap = train.traction_efficiency * drawn
        slowest = kinematics.running_time(kinematics.envelope_speeds(
            seg, train, case.nodes, case.limits,
            traction=lambda v: min(train.traction.force(v), cap / max(v, 1e-9))), case.nodes)
        if slowest > leg.running_time:
            if drawn >= supply.voltage * supply.max_current:
                why = (f"max_train_current_A {supply.max_current:g} A lets a train draw at most {drawn / 1e3:.0f} kW "
                       f"at the substation's {supply.voltage:g} V")
                fields = "max_train_current_A"
            else:
                why = (f"the line lets a train draw at most {drawn / 1e3:.0f} kW at its pantograph between "
                       f"{seg.from_stop} and {seg.to_stop} (voltage_V {supply.voltage:g} V, pantograph at least "
                       f"min_voltage_V {supply.min_voltage:.0f} V, internal_resistance_ohm {supply.resistance:g}, "
                       f"{nearest:.0f} m of line at the nearest)")
                fields = "voltage_V, min_voltage_V or the resistances"
            return (f"{exc}: {why}, {cap / 1e3:.0f} kW at its wheels (traction efficiency {train.traction_efficiency:g}): "
                    f"its fastest run from {seg.from_stop} to {seg.to_stop} then takes {slowest:.1f} s, more than the "
                    f"segment's {leg.running_time:g} s running time ({fields}; supplement_percent or running_times_s)")
    return str(exc)


def why_not_separated(fleet, exc, missed):
    """The reason the joint NLP with the buffer's rows has no usable point (``exc``: Ipopt's word): a
    train that departs or arrives where the train ahead cannot be ``buffer_m`` ahead even on its
    fastest start, a train ahead that stands where the train behind is too near even on its latest
    start, or the timetable alone; or, both trains running, the nearest any runs must come
    (``network.headway``); else Ipopt's word with the closest approach ``missed`` of the optimum
    without the rows."""
    found = headway.timetable_conflict(fleet)
    if found is not None:
        return f"{headway.say_timetable(found, fleet.buffer)} ({exc})"
    found = headway.reach_conflict(fleet)
    if found is not None:
        return f"{headway.say_reach(found, fleet.buffer)} ({exc})"
    found = headway.running_conflict(fleet)
    if found is not None:
        return f"{headway.say_running(found, fleet.buffer)} ({exc})"
    return (f"{exc}; no departure or arrival inside buffer_m {fleet.buffer:g} m explains it (without the rows train "
            f"{missed['train']}'s head came within {missed['gap_m']:.1f} m of the tail of train {missed['ahead']} at "
            f"{missed['time_s']:g} s, {missed['position_m']:.0f} m along the line)")


def _solve(fleet, start, one_handle, floating, separated):
    """(runs, info) of the joint NLP from ``start``, with the buffer's rows where ``separated``."""
    t0 = time.perf_counter()
    m, blocks = _model(fleet, start, one_handle, floating, separated)
    build_s = time.perf_counter() - t0
    outcome = solve_model(m, "joint optimum" + (" with buffer_m's rows" if separated else ""), {**NEAR_START, **ORDERING})
    runs = [[timedomain.leg_arrays(b) for b in bl] for bl in blocks]
    own = sum(pyo.value(m.substation_mw[t]) for t in m.T_net) * fleet.dt / 3.6  # MW s -> kWh
    return runs, {"build_s": build_s, "solve_s": outcome.seconds + outcome.nl_seconds, "nlp_substation_kWh": own,
                  "iterations": outcome.iterations, "solver_status": outcome.status, "separation_rows": separated,
                  "variables": sum(1 for _ in m.component_data_objects(pyo.Var, active=True))}


@space.gc_paused
def _model(fleet, start, one_handle, floating, separated):
    """The joint NLP (every train's legs, the network, the objective; ``separated``: the buffer's
    rows) and its leg blocks [train][leg]."""
    m = pyo.ConcreteModel()
    blocks = []
    for i, legs in enumerate(fleet.legs):
        blocks.append([timedomain.add_leg(m, f"t{i}_leg{k}", leg, start[i][k][:5], one_handle=one_handle)
                       for k, leg in enumerate(legs)])
    steps = [[] for _ in range(fleet.steps)]
    for i, legs in enumerate(fleet.legs):
        for leg, b in zip(legs, blocks[i]):
            for j in range(leg.steps):
                steps[leg.start + j].append((b, j, leg.line_start, leg.direction))
    if separated:
        _add_separation(m, fleet, blocks)
    if not all(steps):  # steps where no train runs carry no network variables
        keep = [t for t, s in enumerate(steps) if s]
        steps = [steps[t] for t in keep]
    circuit.add_network(m, fleet.supply, steps, floating=floating)
    _initialise_network(m, fleet, steps, floating)
    # the rheostat and friction brakes are interchangeable, and a floating bus with no current is
    # free: tiny costs on both remove these flat directions (Ipopt ran out of iterations on them)
    vs = fleet.supply.voltage / 1e3
    regular = REGULARISATION * (sum(m.rheostat[k] for k in m.rheostat) +
                                (sum((m.V0[t] - vs) ** 2 for t in m.T_net) if floating else 0.0))
    m.objective = pyo.Objective(expr=(sum(m.substation_mw[t] for t in m.T_net) + regular) * 1e3 * fleet.dt
                                / energy_ref(fleet))
    return m, blocks


def _add_separation(m, fleet, blocks):
    """Each train's head ``fleet.buffer`` behind the tail of the one ahead (departure order) at
    every step both are on the line: the rows of ``legs.separation_rows``, the train ahead's
    positions expressions of its own leg variables (``fleet.following_legs``)."""
    m.separation = pyo.ConstraintList()
    for _, _, leg, b, x in following_legs(fleet, blocks):
        for row in separation_rows(leg, x, fleet.buffer, b.s):
            m.separation.add(row)


def _initialise_network(m, fleet, steps, floating):
    """Network variables from the numeric solve of the start point (Ipopt starts near physics;
    with the bus pinned, where the real bus floats the start is off by the float in eq. 7.8)."""
    width = max((len(running) for running in steps), default=0)
    xs, ps = np.full((len(steps), width), np.nan), np.zeros((len(steps), width))
    for t, running in enumerate(steps):
        for q, (b, j, start, d) in enumerate(running):
            xs[t, q] = start + d * 0.5 * pyo.value(b.s[j] + b.s[j + 1])
            ps[t, q] = pyo.value(b.p[j]) * 1e3
    flows = circuit.solve_steps(fleet.supply, xs, ps)
    vmin, vmax = fleet.supply.min_voltage / 1e3, fleet.supply.max_voltage / 1e3
    bus, i_s = flows["bus_voltage_V"] / 1e3, flows["substation_current_A"] / 1e3
    for t, running in enumerate(steps):
        m.Is[t].set_value(float(np.clip(i_s[t], m.Is[t].lb, m.Is[t].ub if m.Is[t].ub is not None else np.inf)))
        if floating:
            m.V0[t].set_value(float(np.clip(bus[t], vmin, vmax)))
            m.float_up[t].set_value(max(float(bus[t] - fleet.supply.voltage / 1e3 + fleet.supply.resistance * i_s[t]), 0.0))
        for q in range(len(running)):
            m.rheostat[t, q].set_value(max(-ps[t, q] - flows["fed_W"][t, q], 0.0) / 1e6)
            m.Ipan[t, q].set_value(float(flows["current_A"][t, q] / 1e3))
            m.Vpan[t, q].set_value(float(np.clip(flows["voltage_V"][t, q] / 1e3, vmin, vmax)))
