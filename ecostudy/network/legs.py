"""One train's leg between two stops, solved against a cost per clock step (the supervisor rules'
traction weight and allowance, the regeneration credit) and a train ahead (:func:`solve_leg`).

Each task builds and writes its own NLP once (:class:`LegNLP`): the guards' cold solves, the relaxed first
solve and a warm retry solve the same NLP from another start or with other row bounds (one NLP re-solved
with the cost's coefficients as variables was dearer: docs/benchmarks.md, "Tried and not kept").
"""
import numpy as np
import pyomo.environ as pyo

from ecostudy.core.errors import SolverError
from ecostudy.ocp import session, space, timedomain
from ecostudy.ocp.solver import IPOPT

CREDIT_FLOOR_KW = 10.0  # [kW] a regeneration credit below this is none (the line takes next to nothing then)
TIE_BREAK = 0.05  # [-] the share of a leg's own net energy added to its cost (:func:`leg_cost`)

# a solve from a feasible run kept near it, and a leg's MUMPS options: measured where they are set
# (``ocp.solver.IPOPT``, with every problem family's options)
NEAR_START = IPOPT["near_start"]
KKT = IPOPT["leg"]


def leg_energy_ref(leg):
    """Objective scale of one leg [kWh s / h = kJ]: ``space.energy_reference`` of its segment."""
    return space.energy_reference(leg.case.train, leg.case.segment) / 1e3


def pumping_pays(train, weights=None, allowance=None, credit=None):
    """Per step, whether traction and braking together can lower :func:`leg_cost`: adding dF to both
    forces costs at least (w + TIE_BREAK) dF v / eta_T and earns at most (1 + TIE_BREAK) eta_R dF v,
    so only where w + TIE_BREAK < (1 + TIE_BREAK) eta_T eta_R, some traction is discounted (an
    ``allowance`` [kW] > 0) and some regeneration credited (``credit`` >= ``CREDIT_FLOOR_KW``).
    Arrays per step (None: w = 1, no cap)."""
    if weights is None:
        return False
    cycle = train.traction_efficiency * train.regeneration_efficiency
    pays = np.asarray(weights, float) + TIE_BREAK < (1.0 + TIE_BREAK) * cycle
    if allowance is not None:
        pays &= np.asarray(allowance, float) > 0.0
    if credit is not None:
        pays &= np.asarray(credit, float) >= CREDIT_FLOOR_KW
    return pays


def cost_coefficients(leg, weights=None, allowance=None, credit=None):
    """Per step of the leg, the rows (omega, alpha, a, rho, eta, c) of its cost [kW]
    omega P + alpha max(P - a, 0) - rho R + eta max(R - c, 0), traction P and regeneration R.

    ``weights``, ``allowance`` [kW], ``credit`` [kW]: per clock step (None: w = 1, no cap, all
    regeneration credited). Traction costs w min(P, a) + max(P - a, 0) = w P + (1 - w) max(P - a, 0),
    in full where nothing is offered (a <= 0); regeneration is credited up to c, min(R, c) =
    R - max(R - c, 0), and not at all below ``CREDIT_FLOOR_KW``."""
    span = slice(leg.start, leg.start + leg.steps)
    n = leg.steps
    w = np.ones(n) if weights is None else np.asarray(weights, float)[span]
    omega, alpha, a = w.copy(), np.zeros(n), np.zeros(n)
    if allowance is not None:
        offered = np.asarray(allowance, float)[span]
        omega[offered <= 0.0] = 1.0
        part = (offered > 0.0) & (w < 1.0)
        alpha[part], a[part] = 1.0 - w[part], offered[part]
    rho, eta, c = np.ones(n), np.zeros(n), np.zeros(n)
    if credit is not None:
        cap = np.asarray(credit, float)[span]
        capped = cap >= CREDIT_FLOOR_KW
        rho[~capped] = 0.0
        eta[capped], c[capped] = 1.0, cap[capped]
    return np.array([omega, alpha, a, rho, eta, c])


def leg_cost(b, coefficients):
    """Sum over a leg block's steps of the cost of :func:`cost_coefficients` [kW] plus
    :data:`TIE_BREAK` times the leg's own net power P - R.

    Each max(x, 0) is exact: a variable e >= 0 held by a row e >= x (its coefficient positive, the
    cost minimised), started at its value (:func:`start_maxima`); smoothed, they took 2-3x the
    iterations. The tie-break: with a weight near eta_T eta_R the cost is nearly flat between
    discounted traction and regenerating it back; the leg takes the run that draws the least itself
    (exact maxima alone ended rounds up to 0.9 % dearer: docs/speed.md, "Dissension's legs")."""
    omega, alpha, a, rho, eta, c = np.asarray(coefficients, float).tolist()  # Python floats for Pyomo
    out = sum((omega[j] + TIE_BREAK) * b.traction_kw[j] - (rho[j] + TIE_BREAK) * b.regen_kw[j] for j in b.I)
    for name, coefficient, cap, power in (("over_allowance", alpha, a, b.traction_kw), ("over_credit", eta, c, b.regen_kw)):
        steps = [j for j in b.I if coefficient[j] != 0.0]
        if steps:
            excess = pyo.Expression(steps, rule=lambda b, j, p=power, c=cap: p[j] - c[j])
            e = pyo.Var(steps, bounds=(0.0, None))
            b.add_component(name + "_x", excess)
            b.add_component(name, e)
            b.add_component(name + "_row", pyo.Constraint(steps, rule=lambda b, j, e=e, x=excess: e[j] >= x[j]))
            out = out + sum(coefficient[j] * e[j] for j in steps)
    start_maxima(b)
    return out


def start_maxima(b):
    """Set the exact maxima of a leg block's cost (:func:`leg_cost`) to their value at its point."""
    for name in ("over_allowance", "over_credit"):
        e = getattr(b, name, None)
        if e is not None:
            x = getattr(b, name + "_x")
            for j in e:
                e[j].set_value(max(float(pyo.value(x[j])), 0.0))


@space.gc_paused
def leg_model(task):
    """One leg's NLP from a :func:`solve_leg` task: (model, leg block) with the cost of
    :func:`cost_coefficients`, the one-handle constraint where :func:`pumping_pays`, and ``buffer``
    metres behind the tail of the train ``ahead``."""
    leg, _, dt, buffer, guess, _, weights, allowance, credit, ahead = task
    span = slice(leg.start, leg.start + leg.steps)
    held = pumping_pays(leg.case.train, *(None if a is None else np.asarray(a, float)[span]
                                          for a in (weights, allowance, credit)))
    m = pyo.ConcreteModel()
    b = timedomain.add_leg(m, "leg", leg, guess, one_handle=held)
    coefficients = cost_coefficients(leg, weights, allowance, credit)
    m.objective = pyo.Objective(expr=leg_cost(b, coefficients) * dt / leg_energy_ref(leg))
    if ahead is not None and buffer is not None:
        m.separation = pyo.ConstraintList()
        for row in separation_rows(leg, ahead, buffer, b.s):
            m.separation.add(row)
    return m, b


def solve_leg(task):
    """(leg, label, dt, buffer, guess, warm, weights, allowance, credit, ahead) -> (LegRun, solver
    outcome); a top-level function so a process pool can run it. ``warm``: False (cold, from
    ``guess``), True (warm from ``guess``, a previous run) or :data:`CHECKED`.

    A warm solve (from a previous run, the rounds) stays near its start (``NEAR_START``: measured
    2-3x fewer iterations on the regional study's hardest legs, 1130 -> 333 and 823 -> 441, and
    lower costs) for at most :data:`WARM_MAX_ITER` iterations; where that fails or stops there the
    leg is solved again with Ipopt's defaults (:func:`_solve`) before the failure is raised, and a
    point kept that Ipopt did not prove optimal is noted (``solver_status``; warm starts from the last
    solve's multipliers too: docs/benchmarks.md, "Tried and not kept").

    Three guards against local optima that pass the re-simulation but are not what the user wants
    (the run's ``notes`` say what they did):

    - a warm leg in the sample (``warm`` is :data:`CHECKED`, :func:`warmth`) is solved cold too, from the trapezoidal start;
      where the warm run costs more than :data:`DEARER` more, the cold run replaces it (a warm
      start that arrived early and stood ended 10 % dearer than the cold optimum);
    - a cold leg (``warm`` False, from the space run's guess) is solved from the trapezoidal start
      too, and the cheaper run kept (the guess's where they tie within :data:`TIE`);
    - a run that stands (below :data:`STAND_SPEED_MPS` for more than :data:`STAND_TIME_S`) before
      its last metre is solved again from the trapezoidal start, and replaced where that one
      does not stand; one that still stands fails its verification (``network.scoring``).
    """
    _check_departure_gap(task)
    nlp = LegNLP(task)
    checked = task[5] == CHECKED
    try:
        run, outcome, cost = _solve(nlp, retry=not checked)
    except SolverError as exc:
        raise SolverError(_why_not_kept(task, exc)) from None
    notes = {}
    restart = None  # the solve from the trapezoidal start, once made
    second = SECOND_START.get(task[5])  # a checked warm leg or a cold one: from the trapezoidal start too
    if second is not None:
        spread, replaced, margin = second
        restart = _solve(nlp, cold=True)
        # None: a capped warm solve with no usable point (nothing to compare; JSON has no inf)
        notes[spread] = None if run is None else 100 * (cost - restart[2]) / max(abs(restart[2]), 1e-9)
        capped = checked and (run is None or outcome.status == "max_iterations")  # stopped at the cap
        if capped:
            notes["warm_capped_at"] = outcome.iterations
        if capped or cost - restart[2] > margin * abs(restart[2]):
            run, outcome, cost = restart
            notes[replaced] = True
    stood = standing_s(run, task[0])
    if stood > STAND_TIME_S:
        notes["stood_s"] = stood
        restart = restart or _solve(nlp, cold=True)  # the same problem from the same start: solved once
        if standing_s(restart[0], task[0]) <= STAND_TIME_S:
            run, outcome, cost = restart
            notes["restarted"] = True
    if not outcome.optimal:  # a usable point Ipopt did not prove optimal: the strategy is flagged
        notes["solver_status"] = outcome.status
    return run._replace(notes=notes or None), outcome


def head_to_tail(ahead, behind, length, direction=1):
    """The gap [m] from a train's head to the tail of the train ahead (as long as it), of their head
    positions ``ahead`` and ``behind`` (numbers or arrays, NaN where off the line) along ``direction``
    (+1 or -1 times the line's): negative where they overlap. The one formula of every such gap."""
    return direction * (ahead - behind) - length


def separation(leg, ahead, buffer, j):
    """(the head of the train ahead at the leg's clock step ``j`` in the leg's own distance [m], NaN where
    it is off the line; the least distance the leg's head keeps behind it: ``buffer`` plus the train's length, head to
    tail, as the train ahead is as long)."""
    return leg.direction * (ahead[leg.start + j] - leg.line_start), buffer + leg.case.train.length


BUFFER_SLACK_M = 1e-3  # [m] a separation nearer than the buffer by more is missed: well beyond what Ipopt leaves a row violated


def separated_steps(leg, ahead, buffer):
    """(step j, :func:`separation` at j) for every step of the leg where the train ahead is on the
    line. ``ahead``: its line position per clock step, numbers (NaN: off the line) or, in the joint
    NLP, expressions of its own variables."""
    for j in range(leg.steps + 1):
        x_ahead, least = separation(leg, ahead, buffer, j)
        if not (isinstance(x_ahead, float) and np.isnan(x_ahead)):  # NaN: not on the line
            yield j, x_ahead, least


def separation_rows(leg, ahead, buffer, s, slack=0.0):
    """The rows keeping a leg's head (``s``: its distance per step, a leg block's variables) ``buffer``
    behind the tail of the train ahead (less ``slack``) at every step where that one is on the line
    (:func:`separated_steps`)."""
    for j, x_ahead, least in separated_steps(leg, ahead, buffer):
        yield x_ahead - s[j] >= least - slack


def _check_departure_gap(task):
    """A leg whose departure or arrival, fixed at its stops, is nearer the tail of the train ahead
    than ``buffer``: no run can keep the buffer there (Ipopt only reports the NLP infeasible), said so."""
    leg, label, _, buffer, *_, ahead = task
    if ahead is None or buffer is None:
        return
    for j, at, when in ((0, 0.0, "departs"), (leg.steps, leg.case.segment.distance, "arrives")):
        x_ahead, least = separation(leg, ahead, buffer, j)
        if np.isfinite(x_ahead) and x_ahead - at < least - BUFFER_SLACK_M:
            gap = head_to_tail(x_ahead, at, leg.case.train.length)
            where = f"{gap:.1f} m ahead of its head" if gap >= 0 else f"{-gap:.1f} m behind its head (they overlap)"
            raise SolverError(f"{label}: cannot keep buffer_m {buffer:g} m behind the train ahead, whose tail is "
                              f"{where} when this leg {when} at {(leg.start + j) * leg.dt:g} s (offset_s, dwell_s)")


def _why_not_kept(task, exc):
    """Ipopt's word ``exc`` for a leg kept ``buffer`` behind the train ahead, with the nearest any run
    of the leg must come to that train's tail and when, where that is nearer than the buffer
    (:func:`closest_reachable` of the leg alone, the train ahead's run given)."""
    leg, label, _, buffer, *_, ahead = task
    if ahead is None or buffer is None or "infeasible" not in str(exc):
        return str(exc)
    m = pyo.ConcreteModel()
    b = timedomain.add_leg(m, "leg", leg, None, one_handle=False)
    found = closest_reachable(m, [(leg, ahead, b.s)], buffer)
    if found is None:
        return str(exc)
    gap, _, j = found
    near = f"within {gap:.1f} m of" if gap >= 0 else f"{-gap:.1f} m past"
    return (f"{label}: cannot keep buffer_m {buffer:g} m behind the train ahead: on any run that arrives on time "
            f"its head comes {near} that train's tail, at {(leg.start + j) * leg.dt:g} s (offset_s, dwell_s) "
            f"({str(exc).removeprefix(label + ': ')})")


def closest_reachable(m, pairs, buffer):
    """The nearest runs of the legs in ``m`` (leg blocks without a cost; one handle relaxed) must
    come to the trains ahead: the NLP minimising the largest shortfall z of the separation rows
    (x_ahead - s_j >= buffer + length - z) of every (leg, ``ahead``, ``s``) in ``pairs``
    (:func:`separation_rows`; ``ahead``: numbers, or expressions of the model's variables where the
    trains ahead run too). (the largest gap head to tail those runs keep at their closest, buffer - z
    [m]; the index in ``pairs`` and the leg's step j of the row that binds first on the clock) where z exceeds
    :data:`BUFFER_SLACK_M`; None where the buffer can be kept or Ipopt finds no usable point."""
    m.z = pyo.Var(bounds=(0.0, None), initialize=buffer)
    m.rows = pyo.ConstraintList()
    terms = []  # (pair, step, the train ahead's head, the leg's distance) of every row
    for n, (leg, ahead, s) in enumerate(pairs):
        for row in separation_rows(leg, ahead, buffer, s, slack=m.z):
            m.rows.add(row)
        terms += [(n, j, x_ahead, s[j]) for j, x_ahead, _ in separated_steps(leg, ahead, buffer)]
    m.objective = pyo.Objective(expr=m.z)
    if not terms or not session.solve(m).usable or pyo.value(m.z) <= BUFFER_SLACK_M:
        return None
    room = [pyo.value(x_ahead - s) for _, _, x_ahead, s in terms]  # head to head, per row
    tied = [k for k, r in enumerate(room) if r <= min(room) + BUFFER_SLACK_M]  # the rows that bind
    n, j, *_ = terms[min(tied, key=lambda k: pairs[terms[k][0]][0].start + terms[k][1])]  # the earliest on the clock
    return buffer - pyo.value(m.z), n, j


STAND_SPEED_MPS = 0.1  # [m/s] below this a train stands
STAND_TIME_S = 1.0     # [s] standing longer than this before the last metre: arrived early and waits
DEARER = 0.01          # [-] a warm leg dearer than its cold solve by more than this is replaced
TIE = 1e-6             # [-] a cold leg's trapezoidal run replaces its guess's run only where cheaper by more
CHECK_EVERY = 3        # one warm leg in this many is also solved cold (:func:`warmth`)
# Ipopt iterations a warm solve may take (:func:`_solve`): a checked warm leg that stops there gives
# way to its cold solve, any other is solved again with Ipopt's defaults (measured: docs/network.md)
WARM_MAX_ITER = 500
CHECKED = "checked"    # a task's ``warm``: warm, and in the sample solved cold too
# per task ``warm``, the notes of its solve from the trapezoidal start (the cost difference [%],
# replaced) and the relative margin by which that solve must be cheaper to replace the first
SECOND_START = {CHECKED: ("warm_vs_cold_pct", "replaced_by_cold", DEARER),
                False: ("independent_vs_trapezoid_pct", "replaced_by_trapezoid", TIE)}


def warmth(train, leg):
    """A warm task's ``warm`` for leg ``leg`` of train ``train`` (indices): :data:`CHECKED` for one
    leg in :data:`CHECK_EVERY`, spread over the trains (the same legs in every round), else True."""
    return CHECKED if (train + leg) % CHECK_EVERY == 0 else True


def standing_s(run, leg):
    """Seconds a leg's run stands (speed below :data:`STAND_SPEED_MPS` over a whole step) before
    its last metre."""
    slow = (run.v[:-1] < STAND_SPEED_MPS) & (run.v[1:] < STAND_SPEED_MPS)
    early = run.s[1:] < leg.case.segment.distance - 1.0
    return float(np.count_nonzero(slow & early)) * leg.dt


RELAXED_ONE_HANDLE = 1.0  # [kN^2] the one-handle bound of a cold leg's first solve (:func:`_relaxed_first`)


class LegNLP:
    """A task's leg NLP (:func:`leg_model`), written once (``session.Session``) and solved from the
    task's own start or from the trapezoidal one (the same leg problem restarted cold), its one-handle
    rows at their own bound or relaxed. Each of these solves is the one a model built and written
    for it would make: the same rows in the same order, the start the values it would be written
    with, a relaxed row's bound the one it would be written with."""

    def __init__(self, task):
        self.task = task
        self.model, self.block = leg_model(task)
        self.session = session.Session(self.model)
        self.own = self.session.x.copy()  # the task's start, as the NL file holds it
        self.cold = None
        self.written = False  # whether a solve has reported the NL write's time

    def start(self, cold):
        """The primal start: the task's own, or (``cold``) the trapezoidal speed profile's."""
        if not cold:
            return self.own
        if self.cold is None:  # the block's values are those of the last solve, read out already
            timedomain.set_start(self.block, self.task[0])
            start_maxima(self.block)
            self.cold = np.array([var.value for var in self.session.variables], dtype=float)
        return self.cold

    def relax(self, bound):
        """Set the one-handle rows' bound [kN^2] in the model and the NLP; False where there are none."""
        if not timedomain.relax_one_handle(self.block, bound):
            return False
        self.session.set_row_uppers(list(self.block.one_handle.values()), bound)
        return True

    def solve(self, options, x0=None):
        """``Session.solve`` from ``x0`` (default: the last solution); the NL write's time is given
        to the first solve."""
        outcome = self.session.solve(options, x0)
        if not self.written:
            outcome.nl_seconds, self.written = self.session.nl_seconds, True
        return outcome


def _relaxed_first(nlp, x0):
    """The outcome of a cold solve of ``nlp`` from ``x0``: where the leg holds the one-handle
    complementarity, first with its rows relaxed to F_T F_B <= :data:`RELAXED_ONE_HANDLE`
    (Scholtes' regularisation), then with their own bound from there (near that start); else, or
    where that is not usable, in one go from ``x0``. Measured on the 3-train metro
    study's three hardest cold legs (rule 7.7, T3's second leg): 1167 / 1031 / 935 Ipopt iterations
    in one go, 283 + 142 / 367 + 71 / 419 + 89 relaxed first (2.3x less CPU), at costs 85 / 24 /
    1.6 % lower (an interior point started at the tight bound is caught by one of the
    complementarity's many local optima)."""
    if nlp.relax(RELAXED_ONE_HANDLE):
        first = nlp.solve(KKT, x0)
        nlp.relax(timedomain.ONE_HANDLE)
        if first.usable:
            outcome = nlp.solve({**NEAR_START, **KKT})
            if outcome.usable:
                outcome.iterations += first.iterations
                outcome.seconds += first.seconds
                outcome.nl_seconds += first.nl_seconds
                return outcome
    return nlp.solve(KKT, x0)


def _solve(nlp, cold=False, retry=True):
    """(LegRun, outcome, cost) of one solve of a task's NLP: warm from its own start, near it, for at
    most :data:`WARM_MAX_ITER` iterations; else cold (:func:`_relaxed_first`) from its own start or,
    ``cold``, the trapezoidal one. A warm solve that fails or stops at the cap is tried again with
    Ipopt's defaults where ``retry`` (a usable capped point kept only where that fails too); else
    (a checked warm leg, whose cold solve follows) the capped outcome, (None, outcome, inf) where it
    has no usable point."""
    (leg, label, dt), warm = nlp.task[:3], nlp.task[5] and not cold
    clock = f"{leg.steps} steps of {dt:g} s: time_step_s"
    x0 = nlp.start(cold)
    if not warm:
        outcome = _relaxed_first(nlp, x0)
        if not outcome.usable:
            raise outcome.failure(label, clock)
        return _kept(nlp, outcome)
    outcome = nlp.solve({**NEAR_START, **KKT, "max_iter": WARM_MAX_ITER}, x0)
    first = _kept(nlp, outcome) if outcome.usable else (None, outcome, float("inf"))
    if not retry or (outcome.usable and outcome.status != "max_iterations"):
        return first
    again = nlp.solve(KKT, x0)
    if again.usable:
        return _kept(nlp, again)
    if first[0] is not None:
        return first
    raise again.failure(label, clock)


def _kept(nlp, outcome):
    """(LegRun, outcome, cost) of the point the last solve of ``nlp`` left in its model."""
    return timedomain.leg_arrays(nlp.block), outcome, float(pyo.value(nlp.model.objective))
