"""Zhang & Zhuan's braking-penalised receding-horizon controller (eqs. 4-9), first version: one convex
QP over Np samples with Nc moves on the design model (full or fence-reduced), built once in Pyomo
and re-solved every Ts with new parameters.

    min sum_k [K_f sum f_in^2 + K_v sum (v - v_r)^2 + K_e (sum_loco u^2 + K_b sum_wagon u^2)] Ts   (eq. 4)
    x(k+1) = A x(k) + B (u(k) - offset)                                                              (eq. 2)
    u_low <= u <= u_high, |u_loco(k) - u_loco(k-1)| <= rate                                          (eq. 6)
    mean v(k) <= v_r(k)                                                                              (eq. 7)
    f_low <= k x_in(k) <= f_high                                                                     (eq. 8)

Forces in kN, speeds in m/s (the paper's units are not stated; this scaling keeps the QP's terms
of order one). ``offset`` is the operating point's speed-independent and quadratic resistance
(eq. 2's input shift), re-evaluated at every sample from the measured state. Moves beyond Nc hold
the last one. The offsets and the reference are given per sample of the horizon (eq. 9's F1, F2:
the caller reads them along the predicted positions, :mod:`ecostudy.heavyhaul.loop`).
"""
from typing import NamedTuple

import numpy as np
import pyomo.environ as pyo

from ecostudy.core.errors import SolverError
from ecostudy.core.units import KN
from ecostudy.heavyhaul.linear import Represented
from ecostudy.ocp.session import Session


class Terms(NamedTuple):
    """The objective's weights and the constant vectors every QP form shares."""

    kf: np.ndarray        # K_f per coupler (times the real couplers it spans)
    kv: np.ndarray        # K_v per car (times the cars whose speed it carries)
    ke: float
    penalty: np.ndarray   # 1 for locomotives, K_b for wagons (eq. 5's R), times the effort's weight
    weight: np.ndarray    # mass shares (eq. 7's mean speed)
    stiff: np.ndarray     # coupler stiffness [kN/m] (f_in = k x_in, eq. 8)
    magnitude: np.ndarray  # per kN of |u| (``effort_penalty: magnitude``, eq. 11 as printed); zeros for eq. 4
    brake: np.ndarray     # on min(u, 0)^2 besides ``penalty`` (``brake_penalty_on: all``: K_b - 1 for the locomotives)


UNIT_KN, UNIT_MPS = 100.0, 1.0  # the QP's units: forces in 100 kN (the /1e4 on squared kN), speeds in m/s


class Scales(NamedTuple):
    """What eq. 4's terms are measured in (``objective_scale: limits``, docs/heavyhaul.md): every
    in-train force in the coupler limit [kN], each (virtual) car's effort in its largest effort
    [kN] (an array), every speed error in the route's highest speed [m/s]. ``None`` in
    :func:`objective_terms`: the paper's units (100 kN, 1 m/s) for every term."""

    force_kN: float
    effort_kN: np.ndarray
    speed_mps: float


EFFORT_PENALTIES = ("squared", "magnitude")  # eq. 4's K_e (u^2 ...), eq. 11's K_e (|u| ...) as printed
# ``magnitude`` keeps eq. 4's squared effort term at this fraction, so that the condensed QP stays strictly
# convex (DAQP's dual active set needs a positive definite Hessian); docs/heavyhaul.md measures what it moves
MAGNITUDE_CURVATURE = 1e-3
# where K_b applies: the wagons' (pneumatic) braking only, eq. 5's R; or every brake, the locomotives' dynamic
# braking too (a departure from eq. 5, docs/heavyhaul.md "A penalty on every brake")
BRAKE_PENALTY_ON = ("wagons", "all")


def objective_terms(model, kinds, weights, represented=None, scales=None, effort="squared", brake_on="wagons"):
    """Eq. 4's weights (K_f, K_v, K_e, K_b) on a model of ``kinds``; ``represented``
    (:class:`~ecostudy.heavyhaul.linear.Represented`) what each (virtual) car and coupler stands for;
    ``scales`` (:class:`Scales`) the units each term is measured in (default: the paper's); ``effort``
    the effort term's form (:data:`EFFORT_PENALTIES`): eq. 4's squares or eq. 11's magnitudes, each
    car's |u| in its unit (a virtual car's |u| is the sum of its braking cars' |share u|, so it is
    weighted as one whatever it stands for); ``brake_on`` (:data:`BRAKE_PENALTY_ON`) where K_b applies:
    with ``all`` a locomotive's effort costs u^2 pulling and K_b u^2 braking (``brake``: K_b - 1 on
    min(u, 0)^2, so K_b >= 1; the squared form only)."""
    if effort not in EFFORT_PENALTIES:
        raise ValueError(f"effort penalty one of {EFFORT_PENALTIES} (got {effort})")
    if brake_on not in BRAKE_PENALTY_ON:
        raise ValueError(f"brake penalty on one of {BRAKE_PENALTY_ON} (got {brake_on})")
    kf, kv, ke, kb = weights
    if brake_on == "all" and (effort != "squared" or kb < 1):
        raise ValueError(f"brake_penalty_on: all needs effort_penalty squared and K_b >= 1 (got {effort}, {kb:g})")
    r = represented or Represented.each(len(kinds))
    penalty = np.array([1.0 if kind == "locomotive" else kb for kind in kinds])
    unit = np.full(len(kinds), UNIT_KN) if scales is None else np.asarray(scales.effort_kN, float)
    if scales is not None:  # (x / scale)^2 = (x / unit)^2 (unit / scale)^2
        kf = kf * (UNIT_KN / scales.force_kN) ** 2
        kv = kv * (UNIT_MPS / scales.speed_mps) ** 2
    squared = penalty * (UNIT_KN / unit) ** 2 * r.effort
    magnitude = ke * penalty / unit if effort == "magnitude" else np.zeros(len(kinds))
    locos = np.array([kind == "locomotive" for kind in kinds])
    brake = np.where(locos, (kb - 1.0) * squared, 0.0) if brake_on == "all" else np.zeros(len(kinds))
    return Terms(kf * r.couplers, kv * r.cars, ke, squared * (MAGNITUDE_CURVATURE if effort == "magnitude" else 1.0),
                 model.mass / model.mass.sum(), model.stiffness / KN, magnitude, brake)


TERMS = ("force", "tracking", "energy", "braking")  # eq. 4's terms as reported: K_f, K_v, K_e locomotives, K_e K_b wagons


def objective_values(terms, wagons, predicted, moves, vr, ts):
    """Eq. 4's terms at a solution (same scaling as the QP): ``predicted`` the states x(1..Np) (rows),
    ``moves`` the Nc moves [kN] (rows), ``vr`` v_r(0..Np), ``wagons`` a mask of the wagon (virtual)
    cars; a dict by :data:`TERMS` (the energy term the locomotives', the braking term the wagons'), and
    ``planned``: the predicted mean speeds v(1..Np) [m/s] (eq. 7's left side), where the loop reads
    the positions of the next horizon from."""
    predicted, moves = np.atleast_2d(predicted), np.atleast_2d(moves)
    np_, nc = len(predicted), len(moves)
    n = len(wagons)
    forces = predicted[:, n:] * terms.stiff
    held = moves[[min(k, nc - 1) for k in range(np_)]]
    brake = terms.brake > 0
    efforts = ((held ** 2 * terms.penalty + np.minimum(held, 0.0) ** 2 * terms.brake) * terms.ke / 1e4
               + np.abs(held) * terms.magnitude)
    braking = wagons[None, :] | (brake[None, :] & (held < 0))
    scale = ts / np_
    return {"force": scale * float(np.sum(terms.kf * forces ** 2)) / 1e4,
            "tracking": scale * float(np.sum(terms.kv * (predicted[:, :n] - np.asarray(vr)[1:, None]) ** 2)),
            "energy": scale * float(np.sum(efforts[~braking])), "braking": scale * float(np.sum(efforts[braking])),
            "planned": predicted[:, :n] @ terms.weight}


def qp_size(n, np_, nc, locomotives):
    """The Pyomo form's decision variables and constraints, as Ipopt receives them (input bounds are
    variable bounds; the rate and force rows two-sided, one row each; the states kept). The paper
    condenses the states away (n Nc variables, (6n - 2) Nc constraints: linear.paper_counts); each
    form reports the rows it solves (``size``)."""
    return {"inputs": nc * n, "states": np_ * (2 * n - 1),
            "constraints": np_ * (2 * n - 1) + nc * len(locomotives) + np_ + np_ * (n - 1)}


def sample_inputs(controller, offsets_kN, low_kN, high_kN, reference):
    """(offsets per sample of the horizon, v_r(0..Np), the previous move clipped into this sample's
    bounds) as every form of the QP reads them: one row of offsets is held over the horizon, and
    v_r beyond the reference's end repeats its last value."""
    offsets = np.broadcast_to(np.atleast_2d(offsets_kN), (controller.np_, controller.n))
    vr = np.array([float(reference[min(k, len(reference) - 1)]) for k in range(controller.np_ + 1)])
    return offsets, vr, np.clip(controller.previous, low_kN, high_kN)


class RecedingHorizon:
    """One QP for ``model`` (heavyhaul.linear.DesignModel) of cars ``kinds``, written once; every
    ``solve`` changes bounds only (the measured state, the input shift, the envelopes, the previous
    input and the reference are variables fixed by their bounds) and warm-starts Ipopt."""

    def __init__(self, model, kinds, np_=8, nc=4, weights=(10.0, 60.0, 10.0, 40.0), rate_kN=200.0,
                 force_limit_kN=2000.0, represented=None, scales=None, effort="squared", brake_on="wagons"):
        if effort != "squared" or brake_on != "wagons":  # the condensed forms add the variables these need
            raise ValueError(f"effort penalty '{effort}' on '{brake_on}': this QP form has Zhang & Zhuan's eq. 4 and 5 as printed only")
        self.model, self.kinds, self.np_, self.nc = model, list(kinds), np_, nc
        terms = objective_terms(model, self.kinds, weights, represented, scales)
        n = len(self.kinds)
        self.n = n
        self.locos = [i for i, kind in enumerate(self.kinds) if kind == "locomotive"]
        A, B = model.A, model.B * KN  # the input in kN
        m = pyo.ConcreteModel()
        m.K, m.U = pyo.RangeSet(0, np_), pyo.RangeSet(0, nc - 1)
        m.S, m.C, m.X = pyo.RangeSet(0, 2 * n - 2), pyo.RangeSet(0, n - 1), pyo.RangeSet(0, n - 2)
        m.offset = pyo.Var(pyo.RangeSet(0, np_ - 1), m.C, initialize=0.0)  # [kN] per sample, fixed by bounds
        m.previous = pyo.Var(m.C, initialize=0.0)   # [kN], likewise
        m.vr = pyo.Var(m.K, initialize=0.0)         # [m/s], likewise
        m.x = pyo.Var(m.K, m.S, initialize=0.0)     # x[0, :] fixed by bounds to the measured state
        m.u = pyo.Var(m.U, m.C, initialize=0.0)     # [kN]

        def move(k):
            return min(k, nc - 1)

        m.dynamics = pyo.Constraint(pyo.RangeSet(0, np_ - 1), m.S, rule=lambda m, k, s: m.x[k + 1, s] == sum(
            A[s, j] * m.x[k, j] for j in range(2 * n - 1) if A[s, j] != 0.0) + sum(
            B[s, i] * (m.u[move(k), i] - m.offset[k, i]) for i in range(n) if B[s, i] != 0.0))
        m.rate = pyo.Constraint(m.U, self.locos, rule=lambda m, k, i: pyo.inequality(
            -rate_kN, m.u[k, i] - (m.previous[i] if k == 0 else m.u[k - 1, i]), rate_kN))
        self.terms, self.wagons = terms, np.array([kind != "locomotive" for kind in self.kinds])
        self.values = None  # eq. 4's terms at the last optimum (objective_values)
        weight, stiff, penalty = terms.weight, terms.stiff, terms.penalty
        m.mean_speed = pyo.Constraint(pyo.RangeSet(1, np_), rule=lambda m, k: sum(
            weight[i] * m.x[k, i] for i in range(n)) - m.vr[k] <= 0.0)
        m.couplers = pyo.Constraint(pyo.RangeSet(1, np_), m.X, rule=lambda m, k, j: pyo.inequality(
            -force_limit_kN, stiff[j] * m.x[k, n + j], force_limit_kN))
        m.objective = pyo.Objective(expr=sum(
            sum(terms.kf[j] * (stiff[j] * m.x[k, n + j]) ** 2 for j in range(n - 1)) / 1e4
            + sum(terms.kv[i] * (m.x[k, i] - m.vr[k]) ** 2 for i in range(n))
            + terms.ke * sum(penalty[i] * m.u[move(k - 1), i] ** 2 for i in range(n)) / 1e4
            for k in range(1, np_ + 1)) * model.ts / np_)
        self.m, self.session = m, Session(m)
        self.previous = np.zeros(n)
        self.last = None  # the last solve's Outcome

    @property
    def size(self):
        return qp_size(self.n, self.np_, self.nc, self.locos)

    def solve(self, state, offsets_kN, low_kN, high_kN, reference):
        """The first move [kN per (virtual) car] from the measured ``state`` (speeds then coupler
        extensions), the input offsets [kN] per sample of the horizon (rows; one row: held), the
        bounds [kN] and the reference speeds v_r(k), k = 0..Np (eq. 9: along the predicted positions)."""
        m, n = self.m, self.n
        offsets_kN, vr, previous = sample_inputs(self, offsets_kN, low_kN, high_kN, reference)
        locos = self.locos
        variables = ([m.x[0, s] for s in m.S] + [m.offset[k, i] for k in range(self.np_) for i in m.C] + [m.previous[i] for i in locos]
                     + [m.vr[k] for k in range(1, self.np_ + 1)] + [m.u[k, i] for k in m.U for i in m.C])
        fixed = (list(map(float, state)) + list(map(float, offsets_kN.ravel())) + [float(previous[i]) for i in locos]
                 + list(map(float, vr[1:])))
        lows = fixed + [float(low_kN[i]) for _ in m.U for i in range(n)]
        highs = fixed + [float(high_kN[i]) for _ in m.U for i in range(n)]
        self.session.set_many_bounds(variables, lows, highs)
        self.last = self.session.solve()
        if not self.last.usable:
            raise SolverError(f"heavy-haul QP: Ipopt {self.last.status} after {self.last.iterations} iterations")
        self.previous = np.array([pyo.value(m.u[0, i]) for i in range(n)])
        states = np.array([[pyo.value(m.x[k, s]) for s in m.S] for k in range(1, self.np_ + 1)])
        moves = np.array([[pyo.value(m.u[k, i]) for i in range(n)] for k in m.U])
        self.values = objective_values(self.terms, self.wagons, states, moves, vr, self.model.ts)
        return self.previous.copy()


def input_offsets(mass, resistance, speeds, fixed):
    """Eq. 2's input shift per (virtual) car [N]: m (c0 + c2 v^2) at the speeds plus the grade and
    curve forces ``fixed`` [N] (the plant's :meth:`~ecostudy.heavyhaul.plant.CascadePlant.fixed_forces`)."""
    c0, _, c2 = np.asarray(resistance).T
    return mass * (c0 + c2 * speeds ** 2) + fixed
