"""Every strategy scored alike: runs on the per-step circuit solve (energies, balance), each leg
re-simulated by the independent simulator, separations between consecutive trains."""
import numpy as np
import pandas as pd

from ecostudy.analysis.tables import handles
from ecostudy.core.simulate import verify
from ecostudy.core.units import KWH
from ecostudy.network import circuit
from ecostudy.network.fleet import departure_order, line_positions, step_powers


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
            vbar = 0.5 * (run.v[j] + run.v[j + 1])
            rec = per_train[name]
            rec["traction_kWh"] += run.ft[j] * vbar * dt / KWH
            rec["braking_kWh"] += run.fb[j] * vbar * dt / KWH  # at the wheel, friction and electric
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


def verify_leg(leg, run):
    """Re-simulate a leg's controls with the independent simulator (``simulate.verify``).

    The step forces become handles on the space intervals the steps cover (steps at standstill
    cover none), so the simulator drives them by position as it drives every other run.
    """
    s, v, ft, fb = run.s, run.v, run.ft, run.fb
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
