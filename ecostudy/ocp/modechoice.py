"""DAS run as a MINLP: binaries choose the mode of every phase (move blocking, thesis 000 §4.2).

The phases of ``ocp/phases.py`` are blocks of variable length; here the mode of each block is a
choice among all DAS modes (traction levels, cruise, coast, full braking) by binaries z[q, j]
with sum_j z[q, j] = 1, enforced by big-M constraints on the forces of the block's intervals:

    F_T <= F_T,max sum(z traction, z cruise),   F_B <= F_B,max (z brake + z cruise)
    |F_T - l_j F_T,max(v)| <= F_T,max (1 - z[q, j])            (traction at level l_j)
    F_B >= F_B,max(v) - F_B,max (1 - z brake)                     (full service braking)
    |v_{k+1} - v_k| <= v_max (1 - z cruise)                       (cruise: speed held)

Feasible by construction: block lengths stay continuous (a block may shrink to zero), so the
fixed sequence of ``ocp/phases.py`` is one binary pattern with a feasible NLP, and it is the starting
point (MindtPy ``init_strategy='initial_binary'``). MindtPy's outer approximation alternates NLP
subproblems (cyipopt) with a MILP master (HiGHS). The model is nonconvex, so the master's bound
is the outer approximation's, not a proven global bound; it is reported as such.

The search runs on a coarser sub-grid; the best pattern is then solved again as a fixed-mode
phases NLP at the full resolution, and the better of that and the ``phases`` run is the advice.
"""
import logging
import time

import numpy as np
import pyomo.environ as pyo

from ecostudy.ocp import phases, session
from ecostudy.ocp.solver import IPOPT
from ecostudy.ocp.space import FORCE_SCALE


def define_mode_choice(m, layout, train):
    """Binaries per phase and the big-M constraints tying each interval's forces to them."""
    modes = phases.all_modes(train)
    m.J = pyo.RangeSet(0, len(modes) - 1)

    def start(m, q, j):
        mine = layout.phases[q][1]
        return 1.0 if (mine.kind == modes[j].kind and (mine.kind == "cruise" or mine.level == modes[j].level)) else 0.0

    m.z = pyo.Var(m.Q, m.J, domain=pyo.Binary, initialize=start)
    m.one_mode = pyo.Constraint(m.Q, rule=lambda m, q: sum(m.z[q, j] for j in m.J) == 1)
    t_max, b_max = train.traction.peak / FORCE_SCALE, train.braking.peak / FORCE_SCALE
    v_max = float(max(s.limit for s in layout.sectors))
    trac = [j for j, md in enumerate(modes) if md.kind == "traction"]
    cruise = next(j for j, md in enumerate(modes) if md.kind == "cruise")
    brake = next(j for j, md in enumerate(modes) if md.kind == "brake")
    m.choice = pyo.ConstraintList()
    for i in range(layout.intervals):
        q = i // layout.substeps
        z = {j: m.z[q, j] for j in m.J}
        m.choice.add(m.ft[i] <= m.mean_t[i])
        m.choice.add(m.fb[i] <= m.mean_b[i])
        m.choice.add(m.ft[i] <= t_max * (sum(z[j] for j in trac) + z[cruise]))
        m.choice.add(m.fb[i] <= b_max * (z[brake] + z[cruise]))
        for j in trac:
            m.choice.add(m.ft[i] - modes[j].level * m.mean_t[i] <= t_max * (1 - z[j]))
            m.choice.add(modes[j].level * m.mean_t[i] - m.ft[i] <= t_max * (1 - z[j]))
        m.choice.add(m.mean_b[i] - m.fb[i] <= b_max * (1 - z[brake]))
        m.choice.add(m.v[i + 1] - m.v[i] <= v_max * (1 - z[cruise]))
        m.choice.add(m.v[i] - m.v[i + 1] <= v_max * (1 - z[cruise]))


def search(result, start_model, start_layout, objective, time_limit, points):
    """MindtPy OA from the phases solution on a coarse sub-grid: (model, layout, results, seconds)."""
    seg, train = result.segment, result.train
    layout = phases.Layout(start_layout.sectors, start_layout.phases,
                           phases.substeps_for(points, len(start_layout.phases), least=3))
    lengths, x, v, *_ = phases.solution(start_model, start_layout)
    coarse_v = np.interp(phases.node_positions(layout, lengths), x, v)
    m = phases.build(seg, train, layout, (lengths, coarse_v), running_time=result.summary["running_time_s"],
                     objective=objective, extend=define_mode_choice)
    t0 = time.perf_counter()
    logging.getLogger("pyomo.contrib.mindtpy").setLevel(logging.ERROR)
    session.repeatable()  # its NLP subproblems in the same order of solves repeat (unless the time limit cuts in)
    res = pyo.SolverFactory("mindtpy").solve(
        m, strategy="OA", init_strategy="initial_binary", mip_solver="appsi_highs", nlp_solver="cyipopt",
        nlp_solver_args={"options": dict(IPOPT["mode_choice"])},
        time_limit=max(int(time_limit), 1), iteration_limit=50, heuristic_nonconvex=True, add_no_good_cuts=True,
        calculate_dual_at_solution=False, tee=False)
    return m, layout, res, time.perf_counter() - t0


