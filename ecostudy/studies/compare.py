"""Strategies side by side on one scenario (thesis 000 Tables 4.2, 6.1): one table, one plot.

Every row is scored by the independent simulator (times, energies and stop errors are the
simulated ones), so optimised and heuristic strategies are measured alike.
"""
import pandas as pd

from ecostudy.analysis.single import solve_run
from ecostudy.core.defaults import RUN_POINTS
from ecostudy.core.errors import InfeasibleError
from ecostudy.core.types import Timing
from ecostudy.core.simulate import Driven
from ecostudy.core.status import driven_run, failed
from ecostudy.das.advice import das_phases, nearest_levels
from ecostudy.heuristics import ecodrive
from ecostudy.ocp.problem import prepare
from ecostudy.studies.workers import ticker


def compare(track, train, from_stop, to_stop, timing, points=RUN_POINTS, progress=None):
    """(table, outcomes): all-out, ATO optimum, eco-drive coasting, MARECO-style, DAS round and DAS phases.

    ``mode_changes`` counts the handle changes of each run (DAS runs: the advice rows minus one);
    ``progress(done, failed, remaining, total)`` after each strategy.
    """
    tick = ticker(progress, 6)
    allout = solve_run(track, train, from_stop, to_stop, Timing(), objective="time", points=points)
    tick()
    ato = solve_run(track, train, from_stop, to_stop, timing, points=points)
    tick()
    case = prepare(track, train, from_stop, to_stop, points)
    outcomes = [Driven("all-out", allout.handle, allout.trace),
                Driven("ATO optimum", ato.handle, ato.trace)]
    target = ato.summary["running_time_s"]
    rows_extra = []
    for name, heuristic in (("eco-drive coasting", ecodrive.eco_coasting), ("MARECO-style", ecodrive.mareco)):
        try:
            outcomes.append(heuristic(case, target))
        except InfeasibleError as exc:
            rows_extra.append({"strategy": name, "note": str(exc)})
        tick()
    outcomes.append(nearest_levels(case.segment, train, case.nodes, ato.handle))
    tick()
    block, _, phased = das_phases(ato, points)
    outcomes.append(phased)
    tick()
    rows = [o.row(train, case.segment.distance) for o in outcomes] + rows_extra
    rows[len(outcomes) - 1]["handle_changes"] = block["mode_changes"]
    table = pd.DataFrame(rows)
    e_allout = table["traction_energy_kWh"].iloc[0]
    e_opt = table["traction_energy_kWh"].iloc[1]
    table.insert(4, "saving_vs_all_out_pct", 100 * (1 - table["traction_energy_kWh"] / e_allout))
    table.insert(5, "gap_to_optimum_pct", 100 * (table["traction_energy_kWh"] / e_opt - 1))
    table.insert(2, "arrival_error_s", table["running_time_s"] - target)
    statuses = [allout.status, ato.status] + [driven_run(r["stop_error_m"], r["running_time_s"] - target)
                                              for r in rows[2:len(outcomes)]]
    statuses += [failed(r["note"]) for r in rows_extra]
    table["status"] = [str(st) for st in statuses]
    table.attrs.update(target_s=target, verified=bool(ato.summary["verification"]["passed"]
                                                     and allout.summary["verification"]["passed"]))
    return table, outcomes, case
