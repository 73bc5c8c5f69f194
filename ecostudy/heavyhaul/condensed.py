"""Paper 002's QP condensed as the paper writes it (the states eliminated: x(k) = G_k U + d_k), for
long trains without fencing: the same program as :class:`~ecostudy.heavyhaul.qp.ConicHorizon`.

Kept sparse, the 204-car train's dynamics rows carry the dense zero-order-hold matrix (a wave
crosses the train within Ts) and Clarabel's factorisation takes 20-25 s. Condensed, the QP has the
n Nc inputs only: a dense Hessian (built once), the input bounds and rate rows, Np mean-speed rows,
and the in-train force rows (8), which are dense in U and rarely bind: they enter lazily, only the
(sample, coupler) pairs whose predicted force exceeds the limit, and the QP is solved again until
no predicted force does (the rows found stay for the next samples). Solved by Clarabel with its
supernodal ``faer`` factorisation (3x quicker than ``qdldl`` on the dense block).
"""
import time

import clarabel
import numpy as np
from scipy import sparse

from ecostudy.core.errors import SolverError
from ecostudy.core.units import KN
from ecostudy.heavyhaul.qp import QpOutcome, clarabel_settings
from ecostudy.heavyhaul.rhc import objective_terms, qp_size, sample_inputs

ROUNDS = 6  # re-solves with newly binding force rows, per sample


class CondensedHorizon:
    """The receding-horizon QP over the inputs only; same interface as ``RecedingHorizon``."""

    def __init__(self, model, kinds, np_=8, nc=4, weights=(10.0, 60.0, 10.0, 40.0), rate_kN=200.0,
                 force_limit_kN=2000.0):
        self.model, self.kinds, self.np_, self.nc = model, list(kinds), np_, nc
        n = self.n = len(self.kinds)
        ns, nu = 2 * n - 1, nc * n
        self.locos = [i for i, kind in enumerate(self.kinds) if kind == "locomotive"]
        self.rate, self.force_limit = rate_kN, force_limit_kN
        self.terms = terms = objective_terms(model, self.kinds, weights)
        A, B = model.A, model.B * KN
        self.powers = [np.eye(ns)]
        for _ in range(np_):
            self.powers.append(A @ self.powers[-1])
        self.AB = [p @ B for p in self.powers]  # A^j B
        self.G = np.zeros((np_, ns, nu))  # x(k) = G[k-1] U + d(k)
        for k in range(1, np_ + 1):
            for j in range(k):
                move = min(j, nc - 1)
                self.G[k - 1][:, move * n:(move + 1) * n] += self.AB[k - 1 - j]
        self.q = np.concatenate([np.full(n, terms.kv), terms.kf * terms.stiff ** 2 / 1e4])
        self.scale = model.ts / np_
        effort = np.zeros(nu)
        for k in range(1, np_ + 1):
            move = min(k - 1, nc - 1)
            effort[move * n:(move + 1) * n] += terms.ke * terms.penalty / 1e4
        hessian = sum(g.T @ (self.q[:, None] * g) for g in self.G) + np.diag(effort)
        self.P = sparse.csc_matrix(np.triu(2 * self.scale * hessian))
        eye = sparse.identity(nu, format="csr")
        rate = []
        for k in range(nc):
            for i in self.locos:
                row = np.zeros(nu)
                row[k * n + i] = 1.0
                if k > 0:
                    row[(k - 1) * n + i] = -1.0
                rate.append(row)
        rate = np.array(rate)
        mean = np.concatenate([terms.weight, np.zeros(n - 1)])
        self.mean_rows = np.array([mean @ g for g in self.G])
        self.fixed_rows = sparse.vstack([eye, -eye, sparse.csr_matrix(rate), sparse.csr_matrix(-rate),
                                         sparse.csr_matrix(self.mean_rows)]).tocsc()
        self.binding = set()  # (sample, coupler) force rows found binding so far
        self.settings = clarabel_settings(direct_solve_method="faer")
        self.previous = np.zeros(n)
        self.last = None

    @property
    def size(self):
        """The uncondensed program's size (the same program)."""
        return qp_size(self.n, self.np_, self.nc, self.locos)

    def solve(self, state, offsets_kN, low_kN, high_kN, reference):
        """As :meth:`RecedingHorizon.solve`: the first move [kN per (virtual) car]."""
        t0 = time.perf_counter()
        n, np_, nc = self.n, self.np_, self.nc
        offsets_kN, vr, previous = sample_inputs(self, offsets_kN, low_kN, high_kN, reference)
        shifts = [self.AB[0] @ offsets_kN[j] for j in range(np_)]  # B o(j)
        d = np.array([self.powers[k] @ np.asarray(state, float)
                      - sum(self.powers[k - 1 - j] @ shifts[j] for j in range(k)) for k in range(1, np_ + 1)])
        target = np.zeros_like(d)
        target[:, :n] = vr[1:, None]
        g = 2 * self.scale * sum(self.G[k].T @ (self.q * (d[k] - target[k])) for k in range(np_))
        rate = []
        for k in range(nc):
            rate += [self.rate + (previous[i] if k == 0 else 0.0) for i in self.locos]
        rate_low = [self.rate - (previous[i] if k == 0 else 0.0) for k in range(nc) for i in self.locos]
        b_fixed = np.concatenate([np.tile(high_kN, nc), -np.tile(low_kN, nc), rate, rate_low,
                                  vr[1:] - d[:, :n] @ self.terms.weight])
        iterations = 0
        for _ in range(ROUNDS):
            rows, bounds = [self.fixed_rows], [b_fixed]
            for k, j in sorted(self.binding):
                row = self.terms.stiff[j] * self.G[k][n + j]
                rest = self.terms.stiff[j] * d[k][n + j]
                rows.append(sparse.csr_matrix(np.vstack([row, -row])))
                bounds.append(np.array([self.force_limit - rest, self.force_limit + rest]))
            A = sparse.vstack(rows).tocsc()
            solution = clarabel.DefaultSolver(self.P, g, A, np.concatenate(bounds),
                                              [clarabel.NonnegativeConeT(A.shape[0])], self.settings).solve()
            iterations += int(solution.iterations)
            status = str(solution.status)
            if status not in ("Solved", "AlmostSolved"):
                break
            u = np.asarray(solution.x)
            forces = self.terms.stiff * np.array([self.G[k][n:] @ u + d[k][n:] for k in range(np_)])
            over = {(k, j) for k, j in zip(*np.nonzero(np.abs(forces) > self.force_limit * (1 + 1e-6)))}
            if not over - self.binding:
                break
            self.binding |= over
        self.last = QpOutcome(status, time.perf_counter() - t0, iterations)
        if not self.last.usable:
            raise SolverError(f"heavy-haul QP (condensed): Clarabel {status} after {iterations} iterations")
        self.previous = u[:n].copy()
        return self.previous.copy()
