"""DAS run as a MINLP: binaries choose the mode of every phase (move blocking, Farooqi 2018 §4.2).

The phases of ``ocp/phases.py`` are blocks of variable length; here the mode of each block is a
choice among all DAS modes (traction levels, cruise, coast, braking levels) by binaries z[q, j]
with sum_j z[q, j] = 1, enforced by big-M constraints on the forces of the block's intervals:

    F_T <= F_T,max sum(z traction, z cruise),   F_B <= F_B,max sum(z brake, z cruise)
    |F_T - l_j F_T,max(v)| <= F_T,max (1 - z[q, j])            (traction at level l_j)
    |F_B + l_j F_B,max(v)| <= F_B,max (1 - z[q, j])            (braking at level l_j < 0; at
                                                                  l_j = -1 F_B <= F_B,max(v) holds already)
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
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Protocol

import numpy as np
import pyomo.core as pyo

from ecostudy.core.deadline import run_until
from ecostudy.core.progress import stage, step
from ecostudy.core.units import to_kwh
from ecostudy.core.grid import Segment
from ecostudy.core.types import Train
from ecostudy.ocp import phases, session
from ecostudy.ocp.solver import IPOPT, Model
from ecostudy.ocp.space import FORCE_SCALE


def define_mode_choice(m: Model, layout: phases.Layout, train: Train) -> None:
    """Binaries per phase and the big-M constraints tying each interval's forces to them."""
    modes = phases.all_modes(train)
    m.J = pyo.RangeSet(0, len(modes) - 1)

    def start(m: Model, q: int, j: int) -> float:
        mine = layout.phases[q][1]
        return 1.0 if (mine.kind == modes[j].kind and (mine.kind == "cruise" or mine.level == modes[j].level)) else 0.0

    m.z = pyo.Var(m.Q, m.J, domain=pyo.Binary, initialize=start)
    m.one_mode = pyo.Constraint(m.Q, rule=lambda m, q: sum(m.z[q, j] for j in m.J) == 1)
    t_max, b_max = train.traction.peak / FORCE_SCALE, train.braking.peak / FORCE_SCALE
    v_max = float(max(s.limit for s in layout.sectors))
    trac = [j for j, md in enumerate(modes) if md.kind == "traction"]
    cruise = next(j for j, md in enumerate(modes) if md.kind == "cruise")
    brakes = [j for j, md in enumerate(modes) if md.kind == "brake"]
    m.choice = pyo.ConstraintList()
    for i in range(layout.intervals):
        q = i // layout.substeps
        z = {j: m.z[q, j] for j in m.J}
        m.choice.add(m.ft[i] <= m.mean_t[i])
        m.choice.add(m.fb[i] <= m.mean_b[i])
        m.choice.add(m.ft[i] <= t_max * (sum(z[j] for j in trac) + z[cruise]))
        m.choice.add(m.fb[i] <= b_max * (sum(z[j] for j in brakes) + z[cruise]))
        for j in trac:
            m.choice.add(m.ft[i] - modes[j].level * m.mean_t[i] <= t_max * (1 - z[j]))
            m.choice.add(modes[j].level * m.mean_t[i] - m.ft[i] <= t_max * (1 - z[j]))
        for j in brakes:
            m.choice.add(-modes[j].level * m.mean_b[i] - m.fb[i] <= b_max * (1 - z[j]))
            if modes[j].level > -1.0:
                m.choice.add(m.fb[i] + modes[j].level * m.mean_b[i] <= b_max * (1 - z[j]))
        m.choice.add(m.v[i + 1] - m.v[i] <= v_max * (1 - z[cruise]))
        m.choice.add(m.v[i] - m.v[i + 1] <= v_max * (1 - z[cruise]))


@dataclass
class Searched:
    """How a MINLP search ended. ``model`` holds the best pattern found (its binaries and the NLP
    solution with them) when ``found``; otherwise its starting pattern. ``termination``: MindtPy's
    word, or ``stopped at its ... time limit`` when the search was killed at its deadline, or
    ``failed: ...``. ``upper``/``lower``: MindtPy's bounds on the scaled objective (NaN: none).
    ``limited``: the time limit ended the search (killed, or MindtPy stopped at its own limit)."""

    model: Model
    layout: phases.Layout
    termination: str
    seconds: float
    found: bool
    upper: float = float("nan")
    lower: float = float("nan")
    iterations: int = 0
    stopped: bool = False
    limited: bool = False


class SolvedRun(Protocol):
    """The ATO run a search starts from (an ``analysis.single.RunResult``): its segment, train and
    summary (the running time to keep)."""

    segment: Segment
    train: Train
    summary: dict[str, Any]


GRACE_S = 2.0  # MindtPy's own limit comes this much earlier (at most a fifth of the limit): time to hand back


def search(result: SolvedRun, start_model: Model, start_layout: phases.Layout, objective: str, time_limit: float,
           points: int) -> Searched:
    """MindtPy OA from the phases solution on a coarse sub-grid, in a child process killed at
    ``time_limit`` [s] (MindtPy checks its own limit, :data:`GRACE_S` earlier, only between its
    iterations): a :class:`Searched` with the best pattern found so far."""
    seg, train = result.segment, result.train
    layout = phases.Layout(start_layout.sectors, start_layout.phases,
                           phases.substeps_for(points, len(start_layout.phases), least=3))
    lengths, x, v, *_ = phases.solution(start_model, start_layout)
    coarse_v = np.interp(phases.node_positions(layout, lengths), x, v)
    m = phases.build(seg, train, layout, (lengths, coarse_v), running_time=result.summary["running_time_s"],
                     objective=objective, extend=define_mode_choice)
    own = max(1, int(time_limit - min(GRACE_S, 0.2 * time_limit)))  # MindtPy's limit: whole seconds
    stage("MINLP search", total=float(time_limit), unit="s")  # the time limit spent
    ended = run_until(float(time_limit), _mindtpy, m, own, tick=lambda t, posts: step(t, _found(posts, m.energy_ref)))
    incumbents = [p for p in ended.posts if p[0] == "incumbent"]
    iterations = sum(1 for p in ended.posts if p[0] == "master")
    if ended.finished:
        termination, upper, lower, values, elapsed = ended.value
        _load(m, values)
        return Searched(m, layout, termination, ended.seconds, found=bool(incumbents) or np.isfinite(upper),
                        upper=upper, lower=lower, iterations=iterations, limited=elapsed >= own)
    if incumbents:
        _load(m, incumbents[-1][2])
    termination = (f"stopped at its {time_limit:g} s time limit" if ended.stopped
                   else f"failed: {ended.error.splitlines()[0] if ended.error else 'no answer'}")
    return Searched(m, layout, termination, ended.seconds, found=bool(incumbents),
                    upper=incumbents[-1][1] if incumbents else float("nan"), iterations=iterations,
                    stopped=ended.stopped, limited=ended.stopped)


def _found(posts: list[tuple[Any, ...]], energy_ref: float) -> str:
    """What the search has found so far, from its posts: the best pattern's objective and the OA
    iterations (master problems) solved."""
    better = [p[1] for p in posts if p[0] == "incumbent"]
    masters = sum(1 for p in posts if p[0] == "master")
    best = f"best {to_kwh(better[-1] * energy_ref):.3f} kWh" if better else "no pattern yet"
    return best + (f", OA iteration {masters}" if masters else "")


def _values(model: Model) -> dict[str, float | None]:
    return {v.name: v.value for v in model.component_data_objects(pyo.Var, descend_into=True)
            if not v.name.startswith("MindtPy_utils")}


def _load(m: Model, values: Mapping[str, float | None]) -> None:
    for name, value in values.items():
        var = m.find_component(name)
        if var is not None and value is not None:
            var.set_value(value, skip_validation=True)


def _mindtpy(post: Callable[[tuple[Any, ...]], None], m: Model,
             time_limit: int) -> tuple[str, float, float, dict[str, float | None], float]:
    """In the child: MindtPy OA, posting every better NLP solution (``incumbent``) and every master
    problem solved (``master``) as it goes; returns (termination, upper, lower, values, seconds)."""
    t0 = time.perf_counter()
    logging.getLogger("pyomo").setLevel(logging.ERROR)
    session.repeatable()  # its NLP subproblems in the same order of solves repeat (unless the time limit cuts in)
    best = [np.inf]

    def feasible(fixed_nlp: Model) -> None:
        value = pyo.value(fixed_nlp.MindtPy_utils.objective_list[-1].expr)  # what MindtPy's upper bound reads
        if value < best[0]:
            best[0] = value
            post(("incumbent", value, _values(fixed_nlp)))

    import pyomo.environ as environ  # MindtPy and its subsolvers' plugins: only this search needs them (ocp.solver.prepare)

    res = environ.SolverFactory("mindtpy").solve(
        m, strategy="OA", init_strategy="initial_binary", mip_solver="appsi_highs", nlp_solver="cyipopt",
        nlp_solver_args={"options": dict(IPOPT["mode_choice"])},
        time_limit=time_limit, iteration_limit=50, heuristic_nonconvex=True, add_no_good_cuts=True,
        calculate_dual_at_solution=False, tee=False, call_after_subproblem_feasible=feasible,
        call_after_main_solve=lambda *_: post(("master",)))
    upper, lower = res.problem.upper_bound, res.problem.lower_bound
    return (str(res.solver.termination_condition), float(upper if upper is not None else np.nan),
            float(lower if lower is not None else np.nan), _values(m), time.perf_counter() - t0)
