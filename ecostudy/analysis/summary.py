"""The layout of ``summary.json``: one place that names its keys (README, "Outputs")."""
from ecostudy.analysis import regimes
from ecostudy.core.units import KWH


def run_summary(case, totals, objective, t_allout, marginal, labels, costate, outcome, verification, stages):
    """The summary of one run: what was solved, its totals, regimes, Pontryagin check, solver and
    verification blocks, and the stage times."""
    segment, nodes = case.segment, case.nodes
    return {
        "track": case.track.name, "train": case.train.name, "from": segment.from_stop, "to": segment.to_stop,
        "distance_m": segment.distance, **totals, "points": len(nodes), "objective": objective,
        "all_out_time_s": t_allout,
        "marginal_energy_kWh_per_s": None if marginal is None else marginal / KWH,
        "regimes": regimes.block(labels, nodes),
        "pontryagin": costate,
        "solver": {"status": outcome.status, "iterations": outcome.iterations,
                   "wall_s": stages.get("solve", 0.0), "constraint_violation_max": outcome.max_violation},
        "verification": verification,
        "stages_s": {k: round(v_, 4) for k, v_ in stages.items() if k != "iterations"},
    }
