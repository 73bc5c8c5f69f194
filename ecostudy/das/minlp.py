"""DAS advice by mode choice: the MINLP of :mod:`ecostudy.ocp.modechoice` started from the
``phases`` advice; the pattern it finds is solved again at the full resolution and the better of
the two, re-simulated as a driver follows it (an ok one before one that is not: :func:`preferred`),
is the advice."""
from typing import Any, NamedTuple

import numpy as np
import pyomo.core as pyo

from ecostudy.core.defaults import DAS_TIME_LIMIT_S
from ecostudy.core.progress import stage
from ecostudy.core.status import Status
from ecostudy.core.units import to_kwh
from ecostudy.das.advice import (DasRun, advice_outcome, minimised, nlp_flags, objective_of, refine, solve_phases,
                                 summary_block)
from ecostudy.ocp import phases
from ecostudy.ocp.modechoice import search


def das_minlp(result, points=None, time_limit=DAS_TIME_LIMIT_S, options=None):
    """The :class:`DasRun` of the better of ``phases`` and the MINLP's pattern (:func:`preferred`).
    The search stops at ``time_limit`` [s] (:func:`ecostudy.ocp.modechoice.search`); a search stopped
    there gives the best pattern it found by then, and the status says it was stopped (``flagged``).
    The advice's NLP (Ipopt ``options``; the search's own are MindtPy's) not proven optimal is
    flagged too."""
    points = points or len(result.nodes)
    objective = objective_of(result)
    # stage 1 of `phases` (the full sequence of every sector) is the MINLP's starting pattern
    m_ph, lay_ph, _ = solve_phases(result, points, options, stages=1)
    found = search(result, m_ph, lay_ph, objective, time_limit, max(points // 4, 150))
    stage("DAS phases NLP (modes driven)")
    m_ph, lay_ph, out_ph = refine(result, m_ph, lay_ph, [md for _, md in lay_ph.phases], points, options)
    candidates = [("phases start", m_ph, lay_ph, out_ph)]
    if found.found:  # the pattern found, solved again at the full resolution on the phases it drives
        m_mi, modes = found.model, phases.all_modes(result.train)
        stage("DAS minlp pattern at full resolution")
        chosen = [modes[max(m_mi.J, key=lambda j: pyo.value(m_mi.z[q, j]))] for q in m_mi.Q]
        m_fine, fine, out_fine = refine(result, m_mi, found.layout, chosen, points, options)
        if out_fine.usable:
            candidates.append(("MINLP pattern", m_fine, fine, out_fine))
    scored = []
    for name, mod, lay, out in candidates:
        advice, sim, plan = advice_outcome("DAS minlp", result, lay, mod)
        own = summary_block("minlp", result, sim, advice, "", nlp_flags(f"the DAS {name} NLP", out))
        scored.append(Candidate(own[minimised(result)[0]], Status.parse(own["status"]).ok, name, advice, sim, plan,
                                out))
    best_kwh, _, name, advice, sim, plan, out = preferred(scored)
    e_ref = found.model.energy_ref
    oa_bound = to_kwh(found.lower * e_ref) if np.isfinite(found.lower) else None
    # a nonconvex OA master can cut off the incumbent itself; such a "bound" is no bound at all, and
    # neither is the 0 a search stopped before its first master problem reports
    valid = oa_bound is not None and 0 < oa_bound <= best_kwh * (1 + 1e-6) and found.iterations > 0
    solver, flags = _status(found, name, time_limit)
    if not valid and oa_bound is not None and found.iterations > 0 and not found.limited:  # its "optimal" rests on it
        flags += (f"the MINLP search's '{found.termination}' rests on an OA bound ({oa_bound:.3f} kWh) above the best "
                  f"advice ({best_kwh:.3f} kWh): the nonconvex master cut off the incumbent, so its pattern is not "
                  "proven",)
    flags += nlp_flags(f"the DAS {name} NLP", out)
    block = summary_block("minlp", result, sim, advice, solver, flags,
                          planned_traction_energy_kWh=plan, search_s=found.seconds,
                          search_objective_kWh=to_kwh(found.upper * e_ref) if np.isfinite(found.upper) else None,
                          oa_master_bound_kWh=oa_bound, oa_iterations=found.iterations,
                          search_time_limit_reached=found.limited, bound_note=_bound_note(valid, oa_bound, found))
    block["bound_kWh"] = oa_bound if valid else None
    block["gap_pct"] = 100 * (best_kwh - oa_bound) / best_kwh if valid else None
    return DasRun(block, advice, sim)


class Candidate(NamedTuple):
    """An advice the MINLP could give: its energy on the quantity the ATO run minimised [kWh], whether
    it is ok as driven (stop, time, limits, timing points; its own NLP proven optimal), its name, its
    advice table, driven run, planned energy and the outcome of its NLP."""

    kwh: float
    ok: bool
    name: str
    advice: Any
    sim: Any
    plan: float
    out: Any


def preferred(candidates):
    """The advice given of the ``candidates`` (:class:`Candidate`): an ok one before any that is not
    (a cheaper advice that misses its stop, its time or a limit saves what it did not drive), the
    cheapest among those alike."""
    return min(candidates, key=lambda c: (not c.ok, c.kwh))


def _status(found, name, time_limit):
    """(how the advice was made, the reasons to flag it): a search stopped at its time limit or
    failed is flagged."""
    if found.limited:
        how = "was stopped at" if found.stopped else "reached"
        pattern = "the best pattern it had found" if found.found else "no pattern found by then"
        return f"{name} re-simulated", (f"the MINLP search {how} its {time_limit:g} s time limit ({pattern}; "
                                        f"the advice is the {name}; --das-time-limit, or das_time_limit_s in a study, gives it longer)",)
    if found.termination.startswith("failed"):
        return f"{name} re-simulated", (f"the MINLP search {found.termination}",)
    return f"MindtPy {found.termination}; {name} re-simulated", ()


def _bound_note(valid, oa_bound, found):
    if valid:
        return "MindtPy OA master bound on the coarse model (nonconvex: not a proven global bound)"
    if found.limited and not valid:
        return "no bound: the search reached its time limit first; the ATO optimum is the relaxation"
    if oa_bound is None or oa_bound <= 0 or found.iterations == 0:
        return ("no bound: the search stopped before a master problem bounded the energy; the ATO optimum "
                "is the relaxation")
    return ("no valid bound: the nonconvex OA master cut off the incumbent (its bound exceeds the best "
            "solution); the ATO optimum is the relaxation")
