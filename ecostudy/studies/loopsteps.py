"""Per-step diagnostics of a closed-loop run (``steps.csv``) and their counts in the run's summary.

One row per sample: the true position and speed at the sample, the measured ones, the handle the
plant ran from that sample, and what the controller recorded for the call of ``plan`` it made at
that sample (``control.fallback.Step``): the solver's status, the solve time, the relaxation gap,
the fallback used, the rows softened and the mass estimate. With a measured computation delay a
sample that planned nothing has an empty controller part.
"""
import numpy as np
import pandas as pd

from ecostudy.control.fallback import KINDS, SOLVELESS
from ecostudy.core.status import PROVEN, unproven_columns

COLUMNS = ("sample", "time_s", "position_m", "speed_mps", "measured_position_m", "measured_speed_mps", "handle",
           "status", "solve_ms", "gap", "fallback", "softened", "mass_estimate")


def step_columns(result, planner):
    """The columns of ``steps.csv`` (lists, JSON-storable) of a loop ``result`` (``LoopResult``)
    driven by ``planner`` (a controller with ``steps``)."""
    n = len(result.handles)
    steps = list(getattr(planner, "step_log", []))
    steps += [None] * (n - len(steps))
    states, readings = result.states[:n], list(result.readings)[:n]

    def part(i):
        return (lambda s: None if s is None else s[i])

    return {
        "sample": list(range(n)),
        "time_s": [round(s.time, 4) for s in states],
        "position_m": [round(s.position, 4) for s in states],
        "speed_mps": [round(s.speed, 5) for s in states],
        "measured_position_m": [round(s.position, 4) for s in readings],
        "measured_speed_mps": [round(s.speed, 5) for s in readings],
        "handle": [round(float(u), 6) for u in result.handles],
        "status": [None if s is None else s.status for s in steps[:n]],
        "solve_ms": [None if s is None else round(1e3 * s.seconds, 3) for s in steps[:n]],
        "gap": list(map(part(2), steps[:n])),
        "fallback": list(map(part(3), steps[:n])),
        "softened": list(map(part(4), steps[:n])),
        "mass_estimate": list(map(part(5), steps[:n])),
    }


TIME_BUDGET_ENDS = ("over_budget", "MaxTime")  # a convex solve refused for its time_budget_s


def step_counts(planner):
    """Per run: the fallbacks by kind, the steps with a softened row (steps, not solver retries),
    the convex solves above the exactness bound, and full braking before the final approach
    (a ``full_brake`` or ``reserve`` fallback), and the steps that drove a plan its solver did not
    prove optimal (``unproven_solves_count``; ``unproven_solver_status``: how the solver ended them)."""
    steps = list(getattr(planner, "step_log", []))
    unproven = [s.status for s in steps if s.fallback is None and s.status not in SOLVELESS + PROVEN]
    kinds = [s.fallback for s in steps]
    gaps = np.array([s.gap for s in steps if s.gap is not None])
    return {**{f"fallback_{k}_count": kinds.count(k) for k in KINDS},
            "softened_steps": sum(1 for s in steps if s.softened),
            # refused for time_budget_s: over it after the solve, or stopped at it by Clarabel
            "over_time_budget_count": sum(1 for s in steps if s.status in TIME_BUDGET_ENDS),
            "inexact_solves_count": int(np.sum(gaps > 1e-6)) if gaps.size else 0,
            **unproven_columns(unproven),
            "full_brake_before_final_count": sum(1 for k in kinds if k in ("full_brake", "reserve"))}


def failures_reason(failures, over_time_budget, samples):
    """Why a run whose controller gave no usable plan on ``failures`` of its ``samples`` (the fallback
    drove them) is flagged: how many were solves refused for their ``time_budget_s``
    (``over_time_budget``, :data:`TIME_BUDGET_ENDS`) and how many gave no plan at all (a solver's end
    without one, RSPC with no admissible mode sequence), so a run with no time budget is not said to
    have run out of time."""
    def count(n, what):
        return f"{n} solve{'s' * (n != 1)} {what}"
    parts = ([count(failures - over_time_budget, "gave no usable plan")] if failures > over_time_budget else []) + (
        [count(over_time_budget, "went over time_budget_s")] if over_time_budget else [])
    return f"{' and '.join(parts)} in {samples} sample{'s' * (samples != 1)} (the fallback drove them)"


def steps_frame(columns):
    """``steps.csv`` as a table from :func:`step_columns`."""
    return pd.DataFrame({c: columns.get(c, []) for c in COLUMNS})
