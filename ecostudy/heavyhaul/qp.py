"""Zhang & Zhuan's QP (eqs. 4-8) in matrix form for Clarabel, the same program as
:class:`~ecostudy.heavyhaul.rhc.RecedingHorizon` (Pyomo + Ipopt) without the modelling layer.

Variables z = [u(0..Nc-1) per (virtual) car [kN], x(1..Np) [m/s, m]]: the states are kept (sparse,
banded rows) rather than condensed away as the paper does. Clarabel minimises 1/2 z'Pz + q'z
subject to A z + s = b, s in the zero cone (the dynamics of eq. 2) or the non-negative cone (the
input bounds and rate limit of eq. 6, the mean speed of eq. 7 and the in-train forces of eq. 8).
P and A are built once; a sample changes b (the measured state, the input shifts, the bounds, the
previous input, v_r) and q (v_r). Same scaling as the Pyomo model (kN, m/s, the /1e4 on squared kN).
"""
import time
from typing import NamedTuple

import clarabel
import numpy as np
from scipy import sparse

from ecostudy.core.errors import SolverError
from ecostudy.core.units import KN
from ecostudy.heavyhaul.rhc import objective_terms, objective_values, sample_inputs


def clarabel_settings(**chosen):
    """Clarabel's settings for the heavy-haul QPs: quiet; presolve off (every row stays a row, so a
    sample's update of b applies row for row); no iterative refinement (50 -> 37 ms at f = 10, the
    same moves to 1e-4 kN); ``chosen`` on top (e.g. direct_solve_method)."""
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.presolve_enable = False
    settings.iterative_refinement_enable = False
    for name, value in chosen.items():
        setattr(settings, name, value)
    return settings


class QpOutcome(NamedTuple):
    status: str
    seconds: float
    iterations: int

    @property
    def usable(self):
        return self.status in ("Solved", "AlmostSolved")


class ConicHorizon:
    """The receding-horizon QP solved by Clarabel; same interface as ``RecedingHorizon``.

    The dynamics are eq. 2's zero-order hold, exact; A = expm(A_c Ts) is dense (a wave crosses the
    2.5 km ore train in about 16 s, under Ts), 1.8 million non-zeros for 204 cars at Np = 8, which
    is what a step of f = 1 costs (docs/heavyhaul.md: trapezoidal substeps keep the rows banded but
    mispredict the undamped coupler modes by as much as the forces themselves)."""

    def __init__(self, model, kinds, np_=8, nc=4, weights=(10.0, 60.0, 10.0, 40.0), rate_kN=200.0,
                 force_limit_kN=2000.0, represented=None, scales=None, effort="squared", brake_on="wagons"):
        if effort != "squared" or brake_on != "wagons":  # the condensed forms add the variables these need
            raise ValueError(f"effort penalty '{effort}' on '{brake_on}': this QP form has Zhang & Zhuan's eq. 4 and 5 as printed only")
        self.model, self.kinds, self.np_, self.nc = model, list(kinds), np_, nc
        n = self.n = len(self.kinds)
        self.locos = [i for i, kind in enumerate(self.kinds) if kind == "locomotive"]
        self.rate, self.force_limit = rate_kN, force_limit_kN
        self.terms = terms = objective_terms(model, self.kinds, weights, represented, scales)
        self.wagons = np.array([kind != "locomotive" for kind in self.kinds])
        self.values = None  # eq. 4's terms at the last optimum (objective_values)
        ns = 2 * n - 1
        self.nu, self.ns = nc * n, ns
        nz = self.nu + np_ * ns
        self.u = lambda k, i: k * n + i                       # index of u[k, i]
        self.x = lambda k, s: self.nu + (k - 1) * ns + s      # index of x[k, s], k >= 1
        scale = model.ts / np_
        diag = np.zeros(nz)
        for k in range(1, np_ + 1):
            diag[[self.x(k, n + j) for j in range(n - 1)]] += 2 * scale * terms.kf * terms.stiff ** 2 / 1e4
            diag[[self.x(k, i) for i in range(n)]] += 2 * scale * terms.kv
            move = min(k - 1, nc - 1)
            diag[[self.u(move, i) for i in range(n)]] += 2 * scale * terms.ke * terms.penalty / 1e4
        self.P = sparse.diags(diag).tocsc()
        self.scale, self.kv = scale, terms.kv
        rows = []  # (row entries as {column: value}) per block, in cone order

        def add(entries):
            rows.append(entries)

        A, B = model.A, model.B * KN  # x(k+1) - A x(k) - B u(move) = A x0 [k = 0] - B offset(k)
        self.A_model, self.B_kN = A, B
        for k in range(np_):
            for s in range(ns):
                e = {self.x(k + 1, s): 1.0}
                if k > 0:
                    for j in np.nonzero(A[s])[0]:
                        e[self.x(k, j)] = e.get(self.x(k, j), 0.0) - A[s, j]
                for i in np.nonzero(B[s])[0]:
                    e[self.u(min(k, nc - 1), i)] = -B[s, i]
                add(e)
        self.equalities = len(rows)
        for k in range(nc):  # u <= high, -u <= -low
            for i in range(n):
                add({self.u(k, i): 1.0})
            for i in range(n):
                add({self.u(k, i): -1.0})
        for k in range(nc):  # |u(k) - u(k-1)| <= rate for the locomotives (u(-1): the previous input)
            for sign in (1.0, -1.0):
                for i in self.locos:
                    e = {self.u(k, i): sign}
                    if k > 0:
                        e[self.u(k - 1, i)] = -sign
                    add(e)
        for k in range(1, np_ + 1):  # mean speed <= v_r(k)
            add({self.x(k, i): terms.weight[i] for i in range(n)})
        for k in range(1, np_ + 1):  # |k x_in| <= limit
            for sign in (1.0, -1.0):
                for j in range(n - 1):
                    add({self.x(k, n + j): sign * terms.stiff[j]})
        data, ri, ci = [], [], []
        for r, e in enumerate(rows):
            for c, v in e.items():
                ri.append(r), ci.append(c), data.append(v)
        self.A = sparse.csc_matrix((data, (ri, ci)), shape=(len(rows), nz))
        self.cones = [clarabel.ZeroConeT(self.equalities), clarabel.NonnegativeConeT(len(rows) - self.equalities)]
        self.settings = clarabel_settings()
        self.solver = None
        self.previous = np.zeros(n)
        self.last = None

    @property
    def size(self):
        """The program Clarabel solves: inputs and states, every row of A (dynamics, input bounds and
        rate limits one-sided, mean speed, force limits one-sided)."""
        return {"inputs": self.nu, "states": self.np_ * self.ns, "constraints": self.A.shape[0]}

    def solve(self, state, offsets_kN, low_kN, high_kN, reference):
        """As :meth:`RecedingHorizon.solve`: the first move [kN per (virtual) car]."""
        t0 = time.perf_counter()
        n, np_, nc = self.n, self.np_, self.nc
        offsets_kN, vr, previous = sample_inputs(self, offsets_kN, low_kN, high_kN, reference)
        b = [(self.A_model @ np.asarray(state, float) if k == 0 else np.zeros(self.ns)) - self.B_kN @ offsets_kN[k]
             for k in range(np_)]
        for _ in range(nc):
            b += [np.asarray(high_kN, float), -np.asarray(low_kN, float)]
        for k in range(nc):
            for sign in (1.0, -1.0):
                b.append(np.full(len(self.locos), self.rate) + (sign * previous[self.locos] if k == 0 else 0.0))
        b.append(vr[1:])
        b += [np.full(n - 1, self.force_limit)] * (2 * np_)
        q = np.zeros(self.A.shape[1])
        for k in range(1, np_ + 1):
            q[self.x(k, 0):self.x(k, 0) + n] = -2 * self.scale * self.kv * vr[k]
        if self.solver is None:  # set up once (structure, symbolic factorisation); then only q and b change
            self.solver = clarabel.DefaultSolver(self.P, q, self.A, np.concatenate(b), self.cones, self.settings)
        else:
            self.solver.update(q=q, b=np.concatenate(b))
        solution = self.solver.solve()
        self.last = QpOutcome(str(solution.status), time.perf_counter() - t0, int(solution.iterations))
        if not self.last.usable:
            raise SolverError(f"heavy-haul QP: Clarabel {self.last.status} after {self.last.iterations} iterations")
        z = np.asarray(solution.x)
        self.previous = z[:n].copy()
        self.values = objective_values(self.terms, self.wagons, z[self.nu:].reshape(np_, self.ns),
                                       z[:self.nu].reshape(nc, n), vr, self.model.ts)
        return self.previous.copy()
