"""DAS advice by mode choice: the MINLP of :mod:`ecostudy.ocp.modechoice` started from the
``phases`` advice; the pattern it finds is solved again at the full resolution and the better of
the two, re-simulated as a driver follows it, is the advice."""
import numpy as np
import pyomo.environ as pyo

from ecostudy.core.units import to_kwh
from ecostudy.das.advice import DasRun, advice_outcome, objective_of, refine, solve_phases, summary_block
from ecostudy.ocp import phases
from ecostudy.ocp.modechoice import search


def das_minlp(result, points=None, time_limit=60.0):
    """The :class:`DasRun` of the better of ``phases`` and the MINLP's pattern."""
    points = points or len(result.nodes)
    objective = objective_of(result)
    # stage 1 of `phases` (the full sequence of every sector) is the MINLP's starting pattern
    m_ph, lay_ph, _ = solve_phases(result, points, stages=1)
    m_mi, lay_mi, res, seconds = search(result, m_ph, lay_ph, objective, time_limit, max(points // 4, 150))
    m_ph, lay_ph, _ = refine(result, m_ph, lay_ph, [md for _, md in lay_ph.phases], points)
    # the pattern found, solved again at the full resolution on the phases it drives
    modes = phases.all_modes(result.train)
    chosen = [modes[max(m_mi.J, key=lambda j: pyo.value(m_mi.z[q, j]))] for q in m_mi.Q]
    m_fine, fine, out_fine = refine(result, m_mi, lay_mi, chosen, points)
    candidates = [("phases start", m_ph, lay_ph)]
    if out_fine.usable:
        candidates.append(("MINLP pattern", m_fine, fine))
    scored = []
    for name, mod, lay in candidates:
        advice, sim, plan = advice_outcome("DAS minlp", result, lay, mod)
        row = sim.row(result.train, result.segment.distance)
        scored.append((row["net_energy_kWh" if objective == "net_energy" else "traction_energy_kWh"],
                       name, advice, sim, plan))
    best = min(scored, key=lambda r: r[0])
    _, name, advice, sim, plan = best
    upper, lower = res.problem.upper_bound, res.problem.lower_bound
    e_ref = m_mi.energy_ref
    best_kwh = best[0]
    oa_bound = to_kwh(lower * e_ref) if np.isfinite(lower) else None
    iterations = int(res.solver.iterations or 0)
    # a nonconvex OA master can cut off the incumbent itself; such a "bound" is no bound at all, and
    # neither is the 0 a search stopped before its first master problem reports
    valid = oa_bound is not None and 0 < oa_bound <= best_kwh * (1 + 1e-6) and iterations > 0
    over = seconds > time_limit + 1.0
    block = summary_block("minlp", result, sim, advice,
                       f"MindtPy {res.solver.termination_condition}; {name} re-simulated"
                       + (f"; the search took {seconds:.0f} s, over its {time_limit:g} s limit (MindtPy checks "
                          "the limit between its iterations, and its set-up cannot be cut short)" if over else ""),
                       planned_traction_energy_kWh=plan, search_s=seconds,
                       search_objective_kWh=to_kwh(upper * e_ref) if np.isfinite(upper) else None,
                       oa_master_bound_kWh=oa_bound, oa_iterations=iterations,
                       bound_note=("MindtPy OA master bound on the coarse model (nonconvex: not a proven "
                                   "global bound)" if valid else
                                   "no bound: the search stopped before a master problem bounded the energy; "
                                   "the ATO optimum is the relaxation" if oa_bound is None or oa_bound <= 0
                                   or iterations == 0 else
                                   "no valid bound: the nonconvex OA master cut off the incumbent "
                                   "(its bound exceeds the best solution); the ATO optimum is the relaxation"))
    block["bound_kWh"] = oa_bound if valid else None
    block["gap_pct"] = 100 * (best_kwh - oa_bound) / best_kwh if valid else None
    return DasRun(block, advice, sim)
