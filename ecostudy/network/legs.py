"""One train's leg between two stops, solved against a cost per clock step (the supervisor rules'
traction weight and allowance, the regeneration credit) and a train ahead.

The leg's NLP is written once per structure (segment, steps, step) and re-solved with changed
bounds (:class:`LegProgram`): the cost's coefficients are variables held by equal bounds, which
Ipopt makes parameters; the one-handle constraint F_T F_B <= 1e-3 kN^2 stands at every step, its bound lifted where doing
both cannot pay (:func:`pumping_pays`); the train ahead bounds the distance run. A leg driven for
itself (independent driving, following) is a one-off NLP of its own numbers: the reusable
program's extra terms cost it twice the time, and its free one-handle rows changed Ipopt's path
enough to stop at another local optimum, 4 % worse on one leg. A solve starts from a run (the
forces and the speeds) or from the primal and dual point of the leg's last solve.
"""
import hashlib
import pickle
from collections import OrderedDict

import numpy as np
import pyomo.environ as pyo

from ecostudy.core.errors import SolverError
from ecostudy.core.physics import hinge
from ecostudy.ocp import session, space, timedomain

HINGE_KW = 10.0  # [kW] width of the smooth min/max in a leg's cost (allowance, credit)

# a solve from a feasible run: keep Ipopt near it instead of pushing every variable at a bound
# 1 % inside (measured on the 2-train study's joint NLP: the adaptive barrier update left the
# start and took 3000 iterations; a monotone one from mu 1e-3 converged in 730)
NEAR_START = {"bound_push": 1e-8, "bound_frac": 1e-8, "mu_strategy": "monotone", "mu_init": 1e-3}

# a re-solve of a leg from its last solve's primal and dual point (:func:`solve_leg`)
WARM_DUALS = {**session.WARM_START, "mu_init": 1e-6, "mu_strategy": "monotone"}

HELD = 1e-3       # [kN^2] F_T F_B where the one-handle constraint holds (no bound elsewhere)
PROGRAMS = 32     # leg programs kept per process (about 11 MB each for 200 steps)


def leg_energy_ref(leg):
    """Objective scale of one leg [kWh s / h = kJ]: ``space.energy_reference`` of its segment."""
    return space.energy_reference(leg.case.train, leg.case.segment) / 1e3


def pumping_pays(train, weights=None, allowance=None, credit=None):
    """Per step, whether traction and braking together can lower a cost of w traction (traction
    above ``allowance`` [kW] in full) less regeneration credited up to ``credit`` [kW] (no credit
    below ``HINGE_KW``, the credit hinge's width): adding dF to both forces costs at least
    w dF v / eta_T and earns at most eta_R dF v, so only where w < eta_T eta_R, some traction is
    discounted and some regeneration credited (the cost of :func:`cost_coefficients`). Arrays per
    step (None: w = 1, no cap)."""
    if weights is None:
        return False
    pays = np.asarray(weights, float) < train.traction_efficiency * train.regeneration_efficiency
    if allowance is not None:
        pays &= np.asarray(allowance, float) > 0.0
    if credit is not None:
        pays &= np.asarray(credit, float) >= HINGE_KW
    return pays


def cost_coefficients(leg, weights=None, allowance=None, credit=None):
    """Per step of the leg, the rows (omega, alpha, a, rho, eta, c) of its cost [kW]
    omega P + alpha hinge(P - a) - rho R + eta hinge(R - c), traction P and regeneration R.

    ``weights``, ``allowance`` [kW], ``credit`` [kW]: per clock step (None: w = 1, no cap, all
    regeneration credited). Traction costs w min(P, a) + max(P - a, 0) = w P + (1 - w) max(P - a, 0),
    in full where nothing is offered (a <= 0); regeneration is credited up to c, min(R, c) =
    R - max(R - c, 0), and not at all below ``HINGE_KW``; each max smoothed over ``HINGE_KW``."""
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
        capped = cap >= HINGE_KW
        rho[~capped] = 0.0
        eta[capped], c[capped] = 1.0, cap[capped]
    return np.array([omega, alpha, a, rho, eta, c])


def leg_cost(b, coefficients):
    """Sum over a leg block's steps of the cost of :func:`cost_coefficients` [kW]: its rows as
    numbers (a hinge with coefficient 0 left out) or as per-step Pyomo variables."""
    omega, alpha, a, rho, eta, c = coefficients

    def term(x):  # numbers as Python floats (not numpy's) in Pyomo expressions
        return float(x) if isinstance(x, (float, np.floating)) else x

    def step(j):
        traction, regen = b.traction_kw[j], b.regen_kw[j]
        out = term(omega[j]) * traction - term(rho[j]) * regen
        if not (isinstance(alpha[j], float) and alpha[j] == 0.0):
            out = out + term(alpha[j]) * hinge(traction - term(a[j]), HINGE_KW)
        if not (isinstance(eta[j], float) and eta[j] == 0.0):
            out = out + term(eta[j]) * hinge(regen - term(c[j]), HINGE_KW)
        return out

    return sum(step(j) for j in b.I)


class LegProgram:
    """A leg's NLP: written once and solved for any cost, any steps held to one handle and any
    train ahead (``coefficients`` None; see the module's docstring), or a one-off NLP of the cost
    rows ``coefficients`` (:func:`cost_coefficients`, a hinge of coefficient 0 left out) with the
    one-handle constraint where ``held``, started from ``guess`` as ``timedomain.add_leg`` starts."""

    def __init__(self, leg, coefficients=None, held=False, guess=None):
        m = pyo.ConcreteModel()
        b = timedomain.add_leg(m, "leg", leg, guess, one_handle=False if coefficients is None else held)
        self.m, self.b, self.steps = m, b, leg.steps
        self._terms, self._pairs = [], None
        if coefficients is None:
            m.coefficient = pyo.Var(range(6), b.I, initialize=0.0)
            m.pair = pyo.Constraint(b.I, rule=lambda m, j: b.ft[j] * b.fb[j] <= HELD)
            coefficients = [[m.coefficient[r, j] for j in b.I] for r in range(6)]
            self._terms = [m.coefficient[r, j] for r in range(6) for j in b.I]
            self._pairs = [m.pair[j] for j in b.I]
        m.objective = pyo.Objective(expr=leg_cost(b, coefficients) * leg.dt / leg_energy_ref(leg))
        self.session = session.Session(m)
        self.unreported = self.session.nl_seconds  # the NL write, reported with the first solve
        inner = range(1, leg.steps)  # s and v are fixed at both ends
        self._s = [b.s[j] for j in inner]
        self._start = self._s + [b.v[j] for j in inner] + [x[j] for x in (b.ft, b.fb, b.fr) if not x[0].fixed for j in b.I]

    def solve(self, coefficients, held, distance_top, start, options):
        """Solve with the cost rows ``coefficients``, the one-handle constraint where ``held`` (per
        step), at most ``distance_top`` run per step boundary, from ``start``: a
        ``session.NamedPoint`` (with the multipliers), (s, v[, F_T, F_B, F_R]) arrays [m, m/s, N]
        or None (a one-off program's own start). A one-off program takes its own numbers."""
        nlp, b, n = self.session, self.b, self.steps
        if isinstance(start, session.NamedPoint):
            nlp.start_from(start)
        elif start is not None:
            forces = [np.asarray(f, float) / timedomain.FORCE_SCALE for f in start[2:5]] if len(start) >= 5 else [np.zeros(n)] * 3
            values = [start[0][1:n], start[1][1:n]] + [f for f, x in zip(forces, (b.ft, b.fb, b.fr)) if not x[0].fixed]
            nlp.set_start_values(self._start, np.concatenate(values))
        terms = np.ravel(coefficients) if self._terms else np.zeros(0)
        if self._pairs is not None:
            nlp.set_constraint_bounds(self._pairs, np.full(n, -np.inf), np.where(np.broadcast_to(held, (n,)), HELD, np.inf))
        nlp.set_many_bounds(self._terms + self._s, np.concatenate([terms, np.zeros(n - 1)]),
                            np.concatenate([terms, distance_top[1:n]]))
        outcome = nlp.solve(options)
        outcome.nl_seconds, self.unreported = self.unreported, 0.0
        return outcome

    def run(self):
        """The last solve as a ``timedomain.LegRun`` with its primal and dual point."""
        return timedomain.leg_arrays(self.b)._replace(point=self.session.named_point())


_programs = OrderedDict()  # this process's leg programs by structure, least recently used first


def program(leg):
    """This process's reusable :class:`LegProgram` of ``leg``'s structure (its segment's case,
    steps and step, not its departure), built on first use, the least recently used dropped
    beyond PROGRAMS."""
    key = hashlib.sha1(pickle.dumps((leg.case, leg.steps, leg.dt))).hexdigest()
    if key in _programs:
        _programs.move_to_end(key)
    else:
        _programs[key] = LegProgram(leg)
        while len(_programs) > PROGRAMS:
            _programs.popitem(last=False)
    return _programs[key]


def distance_tops(leg, label, buffer=None, ahead=None):
    """The most distance [m] the leg may have run at each step boundary: the segment, and
    ``buffer`` behind the tail of the train ahead where it is on the line (``ahead``: its line
    position per clock step, NaN off the line; head to tail: it is train.length long)."""
    top = np.full(leg.steps + 1, leg.case.segment.distance)
    if ahead is not None and buffer is not None:
        x = np.asarray(ahead, float)[leg.start:leg.start + leg.steps + 1]
        room = leg.direction * (x - leg.line_start) - buffer - leg.case.train.length
        at = np.isfinite(room)
        top[at] = np.minimum(top[at], room[at])
        need = np.zeros(leg.steps + 1)
        need[-1] = leg.case.segment.distance - 1e-6  # the stop, where the leg ends
        if np.any(top < need):
            raise SolverError(f"{label}: infeasible, the train ahead is less than {buffer:g} m ahead "
                              f"at step {int(np.argmax(top < need))} of the leg")
    return top


def solve_leg(task):
    """(leg, label, dt, buffer, guess, warm, weights, allowance, credit, ahead) -> (LegRun, solver
    outcome); a top-level function so a process pool can run it (each process keeps its programs).

    ``warm``: False (a first solve, Ipopt's defaults from ``guess``), True (from the run ``guess``)
    or that run's ``point`` (its primal and dual point). From a point, Ipopt starts from its
    multipliers too with a small barrier (``WARM_DUALS``: measured on the 2-train study's rounds,
    523 -> 312 iterations for the receptivity rule); from a run alone it stays near its start
    (``NEAR_START``: measured 2-3x fewer iterations on the regional study's hardest legs, 1130 ->
    333 and 823 -> 441, and lower costs). Where a warm solve fails (one leg of the 20-stop study
    reached 3000 iterations) the leg is solved again the next way down, Ipopt's defaults last,
    before the failure is raised."""
    leg, label, dt, buffer, guess, warm, weights, allowance, credit, ahead = task
    span = slice(leg.start, leg.start + leg.steps)
    held = pumping_pays(leg.case.train, *(None if a is None else np.asarray(a, float)[span]
                                          for a in (weights, allowance, credit)))
    coefficients = cost_coefficients(leg, weights, allowance, credit)
    tops = distance_tops(leg, label, buffer, ahead)
    point = warm if isinstance(warm, session.NamedPoint) else None
    tries = ((WARM_DUALS,) if point else ()) + ((NEAR_START, None) if warm else (None,))
    plain = weights is None and allowance is None and credit is None  # independent driving, following
    solver = LegProgram(leg, coefficients, held, guess) if plain else program(leg)
    for n, options in enumerate(tries, 1):
        start = point if options is WARM_DUALS else None if plain and n == 1 else guess
        outcome = solver.solve(coefficients, held, tops, start, options)
        if outcome.usable:
            return solver.run(), outcome
        if n == len(tries):
            raise SolverError(f"{label}: Ipopt {outcome.status} after {outcome.iterations} iterations")
