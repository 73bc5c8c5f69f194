"""Every strategy scored alike: runs on the per-step circuit solve (energies, balance), each leg
re-simulated by the independent simulator, separations between consecutive trains."""
import numpy as np
import pandas as pd

from ecostudy.analysis.tables import handles
from ecostudy.core.simulate import verify
from ecostudy.core.units import KWH
from ecostudy.network import circuit
from ecostudy.network.fleet import departure_order, line_positions, step_arrays
from ecostudy.network.legs import BUFFER_SLACK_M, STAND_TIME_S, head_to_tail, standing_s


def evaluate(fleet, runs_by_train):
    """Score runs on the network: per-step flows, per-train and substation totals [kWh]."""
    dt = fleet.dt
    x, p = step_arrays(fleet, runs_by_train)
    flows = circuit.solve_steps(fleet.supply, x, p)
    offered = np.maximum(-p, 0.0) * dt / KWH
    used = flows["fed_W"] * dt / KWH
    line_input = np.maximum(np.nan_to_num(flows["voltage_V"]) * flows["current_A"], 0.0) * dt / KWH
    per_train = {}
    for i, name in enumerate(fleet.names):
        vbar = [0.5 * (run.v[:-1] + run.v[1:]) for run in runs_by_train[i]]
        per_train[name] = {"traction_kWh": sum(float(run.ft @ v) for run, v in zip(runs_by_train[i], vbar)) * dt / KWH,
                           # at the wheel, friction and electric
                           "braking_kWh": sum(float(run.fb @ v) for run, v in zip(runs_by_train[i], vbar)) * dt / KWH,
                           "braking_regen_offered_kWh": float(offered[:, i].sum()),
                           "regen_used_kWh": float(used[:, i].sum()), "regen_lost_kWh": float((offered[:, i] - used[:, i]).sum()),
                           "line_input_kWh": float(line_input[:, i].sum())}
    running = np.isfinite(x).any(axis=1)
    volts = flows["voltage_V"]  # NaN where a train is not running
    on_line = np.where(running[:, None], volts, 0.0)  # no all-NaN row for nanmin / nanmax
    low, high = np.nanmin(on_line, axis=1), np.nanmax(on_line, axis=1)
    steps = pd.DataFrame({"time_s": np.arange(fleet.steps) * dt, "substation_kW": flows["substation_W"] / 1e3,
                          "traction_input_kW": flows["traction_input_W"] / 1e3, "regen_used_kW": flows["regen_used_W"] / 1e3,
                          "regen_lost_kW": flows["regen_lost_W"] / 1e3, "line_loss_kW": flows["line_loss_W"] / 1e3,
                          "unserved_kW": flows["unserved_W"] / 1e3,
                          "voltage_min_V": np.where(running, low, np.nan), "voltage_max_V": np.where(running, high, np.nan),
                          **{f"voltage_{name}_V": volts[:, i] for i, name in enumerate(fleet.names)}})
    e = {k: float(steps[k].sum() * dt / 3600) for k in ("substation_kW", "traction_input_kW", "regen_used_kW",
                                                          "regen_lost_kW", "line_loss_kW", "unserved_kW")}
    lhs, rhs = e["substation_kW"] + e["regen_used_kW"], e["traction_input_kW"] + e["line_loss_kW"]
    totals = {"substation_kWh": e["substation_kW"], "traction_input_kWh": e["traction_input_kW"],
              "regen_used_kWh": e["regen_used_kW"], "regen_lost_kWh": e["regen_lost_kW"],
              "line_losses_kWh": e["line_loss_kW"], "unserved_kWh": e["unserved_kW"],
              "balance_error_pct": 100 * (lhs - rhs) / max(rhs, 1e-9),
              "voltage_min_V": float(steps["voltage_min_V"].min()), "voltage_max_V": float(steps["voltage_max_V"].max())}
    return steps, per_train, totals


def verify_leg(leg, run):
    """Re-simulate a leg's controls with the independent simulator (``simulate.verify``).

    The step forces become handles on the space intervals the steps cover (steps at standstill
    cover none), so the simulator drives them by position as it drives every other run; an interval
    is cut at each track change inside it (gradient, curve, limit, tunnel), each part under the
    interval's handle, so the simulator integrates the track's own piecewise force over it.
    """
    s, v, ft, fb = run.s, run.v, run.ft, run.fb
    # a step that covers less than 0.1 mm stands still: the solver's tolerance once left 2e-6 m
    # steps at the stop, with the traction that holds the train on its gradient (a handle the
    # simulator then drove off the stop)
    moving = np.diff(s) > 1e-4
    nodes = np.concatenate([[s[0]], s[1:][moving]])
    speeds = np.concatenate([[v[0]], v[1:][moving]])
    u = handles(leg.case.train, speeds, ft[moving], fb[moving])
    nodes, u = split_at(nodes, u, leg.case.segment.breakpoints())
    energy = float(np.sum(ft * np.diff(s)))
    out = verify(leg.case.segment, leg.case.train, nodes, u, leg.running_time, energy)[0]
    # a run that arrives early and stands passes the re-simulation, but is not a run to drive
    out["stood_before_stop_s"] = standing_s(run, leg)
    out["passed"] = bool(out["passed"] and out["stood_before_stop_s"] <= STAND_TIME_S)
    return out


def split_at(nodes, values, points):
    """Intervals of ``nodes`` cut at each of ``points`` strictly inside one (more than 1 mm from its
    ends): (the new nodes, each part's value = its interval's value of ``values``)."""
    nodes, values, points = np.asarray(nodes, float), np.asarray(values, float), np.asarray(points, float)
    k = np.searchsorted(nodes, points, side="right") - 1  # the interval each point falls in
    inside = (k >= 0) & (k < len(values))
    k, points = k[inside], points[inside]
    clear = (points - nodes[k] > 1e-3) & (nodes[k + 1] - points > 1e-3)
    all_nodes = np.concatenate([nodes, points[clear]])
    order = np.argsort(all_nodes, kind="stable")
    owner = np.concatenate([np.arange(len(nodes)), k[clear]])[order]  # the interval each new node starts
    return all_nodes[order], values[np.minimum(owner, len(values) - 1)][:-1]


def _gaps(fleet, runs_by_train):
    """Per consecutive pair in departure order: (train ahead, train behind, the gap [m] from the
    behind train's head to the tail of the one ahead per clock step, NaN where either is off the
    line, the behind train's head per clock step [m])."""
    order = departure_order(fleet)
    length = fleet.legs[0][0].case.train.length
    for ahead, me in zip(order[:-1], order[1:]):
        mine = line_positions(fleet, me, runs_by_train[me])
        gap = head_to_tail(line_positions(fleet, ahead, runs_by_train[ahead]), mine, length, fleet.legs[me][0].direction)
        yield ahead, me, gap, mine


def separations(fleet, runs_by_train):
    """Smallest gap [m] from each train's head to the tail of the train ahead while both are on
    the line (None for the first train); negative: the trains would overlap."""
    out = {fleet.names[departure_order(fleet)[0]]: None}
    for _, me, gap, _ in _gaps(fleet, runs_by_train):
        both = np.isfinite(gap)
        out[fleet.names[me]] = float(gap[both].min()) if both.any() else None
    return out


def closest_approach(fleet, runs_by_train):
    """The smallest gap of :func:`separations` over every pair: {"gap_m", "train" (behind), "ahead",
    "time_s" (on the study's clock), "position_m" (the behind train's head on the line)}; None where
    no two consecutive trains share the line."""
    best = None
    for ahead, me, gap, mine in _gaps(fleet, runs_by_train):
        both = np.flatnonzero(np.isfinite(gap))
        if both.size:
            t = int(both[np.argmin(gap[both])])
            if best is None or gap[t] < best["gap_m"]:
                best = {"gap_m": float(gap[t]), "train": fleet.names[me], "ahead": fleet.names[ahead],
                        "time_s": t * fleet.dt, "position_m": float(mine[t])}
    return best


def buffer_missed(fleet, runs_by_train, closest=None):
    """The closest approach (:func:`closest_approach`, or ``closest`` where already found) where it
    is nearer than ``fleet.buffer`` (beyond what Ipopt leaves a separation row violated,
    ``legs.BUFFER_SLACK_M``), else None."""
    if not fleet.buffer:
        return None
    closest = closest or closest_approach(fleet, runs_by_train)
    return closest if closest is not None and closest["gap_m"] < fleet.buffer - BUFFER_SLACK_M else None
