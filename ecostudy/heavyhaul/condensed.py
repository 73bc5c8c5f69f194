"""Zhang & Zhuan's QP condensed as the paper writes it (the states eliminated: x(k) = G_k U + d_k), for
long trains without fencing: the same program as :class:`~ecostudy.heavyhaul.qp.ConicHorizon`.

Kept sparse, the 204-car train's dynamics rows carry the dense zero-order-hold matrix (a wave
crosses the train within Ts) and Clarabel's factorisation takes 20-25 s. Condensed, the QP has the
n Nc inputs only: a dense Hessian (built once), the input bounds, the locomotives' rate rows, Np
mean-speed rows, and the in-train force rows (8), which are dense in U and rarely bind: they enter
lazily, only the (sample, coupler) pairs whose predicted force exceeds the limit, and the QP is
solved again until no predicted force does (the rows found stay for the next samples). ``effort_penalty: magnitude`` and ``brake_penalty_on: all`` add variables
and rows after the moves (:mod:`~ecostudy.heavyhaul.magnitude`).

Two solvers of that one program, passed in as ``solver``:

- :class:`DaqpSolver` (default): DAQP's dual active-set method, one workspace for the whole run.
  H, its factor and the constraint rows are set up when the controller is built (every input at
  its upper bound as the first working set: no wagon braking, no traction beyond the envelope);
  a sample changes the linear term and the bounds only and starts from the previous sample's
  working set, so a sample costs the working-set changes since the last one. A new force row
  means a new workspace, started from the previous working set.
- :class:`ClarabelSolver`: Clarabel's interior-point method with its supernodal ``faer``
  factorisation (3x quicker than ``qdldl`` on the dense block), from scratch every sample.
"""
import time

import clarabel
import daqp
import numpy as np
from scipy import sparse

from ecostudy.core.errors import SolverError
from ecostudy.core.units import KN
from ecostudy.heavyhaul.magnitude import Magnitudes
from ecostudy.heavyhaul.qp import QpOutcome, clarabel_settings
from ecostudy.heavyhaul.rhc import objective_terms, objective_values, sample_inputs

ROUNDS = 6  # re-solves with newly binding force rows, per sample
INFINITE = 1e30  # DAQP's bound for "none"
ACTIVE, LOWER = 1, 2  # DAQP's working-set flags (``sense``)


class ClarabelSolver:
    """min 1/2 u'Hu + g'u subject to lo <= u <= hi and c_lo <= C u <= c_hi, from scratch."""

    def __init__(self, hessian, rows):
        self.P = sparse.csc_matrix(np.triu(hessian))
        self.settings = clarabel_settings(direct_solve_method="faer")

    def solve(self, g, lo, hi, rows, c_lo, c_hi):
        upper, lower = np.isfinite(c_hi), np.isfinite(c_lo)
        eye = sparse.identity(len(g), format="csr")
        A = sparse.vstack([eye, -eye, sparse.csr_matrix(rows[upper]), sparse.csr_matrix(-rows[lower])]).tocsc()
        b = np.concatenate([hi, -lo, c_hi[upper], -c_lo[lower]])
        solution = clarabel.DefaultSolver(self.P, g, A, b, [clarabel.NonnegativeConeT(A.shape[0])],
                                          self.settings).solve()
        status = str(solution.status)
        return np.asarray(solution.x), status, int(solution.iterations)


class DaqpSolver:
    """The same program by DAQP (dual active set), warm-started from the previous working set."""

    def __init__(self, hessian, rows):
        self.hessian = hessian
        n = len(hessian)
        start = np.zeros(n + len(rows), dtype=np.int32)
        start[:n] = ACTIVE  # every input at its upper bound
        self._setup(np.zeros(n), np.full(n, -1.0), np.zeros(n), rows, np.full(len(rows), -INFINITE),
                    np.full(len(rows), INFINITE), start)
        self.working = start

    def _setup(self, g, lo, hi, rows, c_lo, c_hi, sense):
        self.model, self.rows = daqp.Model(), len(rows)
        flag, _ = self.model.setup(self.hessian, g, rows, *self._bounds(lo, hi, c_lo, c_hi), sense)
        if flag < 0:
            raise SolverError(f"heavy-haul QP (daqp): setup failed (exit flag {flag})")

    @staticmethod
    def _bounds(lo, hi, c_lo, c_hi):
        return (np.concatenate([hi, np.minimum(c_hi, INFINITE)]),
                np.concatenate([lo, np.maximum(c_lo, -INFINITE)]))

    def solve(self, g, lo, hi, rows, c_lo, c_hi):
        if len(rows) != self.rows:  # a new force row: a new workspace from the last working set
            sense = np.zeros(len(g) + len(rows), dtype=np.int32)
            sense[:len(self.working)] = self.working
            self._setup(g, lo, hi, rows, c_lo, c_hi, sense)
        else:
            upper, lower = self._bounds(lo, hi, c_lo, c_hi)
            self.model.update(f=g, bupper=upper, blower=lower)
        x, _, flag, info = self.model.solve()
        lam = np.asarray(info["lam"])
        self.working = np.where(lam > 0, ACTIVE, np.where(lam < 0, ACTIVE | LOWER, 0)).astype(np.int32)
        status = "Solved" if flag >= 1 else f"daqp exit flag {flag}"
        return np.asarray(x), status, int(info["iterations"])


class CondensedHorizon:
    """The receding-horizon QP over the inputs only; same interface as ``RecedingHorizon``."""

    def __init__(self, model, kinds, np_=8, nc=4, weights=(10.0, 60.0, 10.0, 40.0), rate_kN=200.0,
                 force_limit_kN=2000.0, represented=None, scales=None, solver=DaqpSolver, effort="squared",
                 brake_on="wagons"):
        self.model, self.kinds, self.np_, self.nc = model, list(kinds), np_, nc
        n = self.n = len(self.kinds)
        ns, nu = 2 * n - 1, nc * n
        self.locos = [i for i, kind in enumerate(self.kinds) if kind == "locomotive"]
        self.rate, self.force_limit = rate_kN, force_limit_kN
        self.terms = terms = objective_terms(model, self.kinds, weights, represented, scales, effort, brake_on)
        self.wagons = np.array([kind != "locomotive" for kind in self.kinds])
        self.values = None  # eq. 4's terms at the last optimum (objective_values)
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
        self.q = np.concatenate([terms.kv, terms.kf * terms.stiff ** 2 / 1e4])
        self.scale = model.ts / np_
        held = np.bincount([min(k, nc - 1) for k in range(np_)], minlength=nc)  # samples each move is held
        effort = np.concatenate([count * terms.ke * terms.penalty / 1e4 for count in held])
        hessian = 2 * self.scale * (sum(g.T @ (self.q[:, None] * g) for g in self.G) + np.diag(effort))
        self.magnitude = Magnitudes(terms, self.wagons, self.locos, held, self.scale, hessian, effort)
        rate = []
        for k in range(nc):
            for i in self.locos:
                row = np.zeros(nu)
                row[k * n + i] = 1.0
                if k > 0:
                    row[(k - 1) * n + i] = -1.0
                rate.append(row)
        mean = np.concatenate([terms.weight, np.zeros(n - 1)])
        self.fixed_rows = self.magnitude.rows(np.vstack([np.array(rate).reshape(-1, nu), [mean @ g for g in self.G]]))
        self.binding = []  # (sample, coupler) force rows found binding so far, in the order found
        self.rows = self.fixed_rows
        self.solver = solver(self.magnitude.hessian, self.rows)
        self.previous = np.zeros(n)
        self.last = None

    @property
    def size(self):
        """The program solved: the inputs only (no states; with ``effort_penalty: magnitude`` one
        variable more per locomotive move, its |u|, with ``brake_penalty_on: all`` its braking), the input bounds as simple bounds (not counted),
        rows for the locomotives' rate limits (two-sided), the mean speed, the magnitudes' rows and the
        force rows found binding so far (two-sided)."""
        return {"inputs": self.nc * self.n + self.magnitude.extra, "states": 0, "constraints": len(self.rows)}

    def _force_row(self, k, j):
        return self.magnitude.pad(self.terms.stiff[j] * self.G[k][self.n + j])

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
        ahead = np.array([previous[i] if k == 0 else 0.0 for k in range(nc) for i in self.locos])
        fixed_hi = self.magnitude.upper(np.concatenate([self.rate + ahead, vr[1:] - d[:, :n] @ self.terms.weight]))
        fixed_lo = self.magnitude.lower(np.concatenate([ahead - self.rate, np.full(np_, -np.inf)]))
        g, (lo, hi) = self.magnitude.linear(g, high_kN), self.magnitude.bounds(np.tile(low_kN, nc), np.tile(high_kN, nc))
        iterations = 0
        for _ in range(ROUNDS):
            rest = np.array([self.terms.stiff[j] * d[k][n + j] for k, j in self.binding]).reshape(-1)
            c_lo = np.concatenate([fixed_lo, -self.force_limit - rest])
            c_hi = np.concatenate([fixed_hi, self.force_limit - rest])
            u, status, its = self.solver.solve(g, lo, hi, self.rows, c_lo, c_hi)
            iterations += its
            if status not in ("Solved", "AlmostSolved"):
                break
            u = u[:nc * n]  # the moves (a magnitude's variables after them)
            forces = self.terms.stiff * np.array([self.G[k][n:] @ u + d[k][n:] for k in range(np_)])
            over = sorted({(k, j) for k, j in zip(*np.nonzero(np.abs(forces) > self.force_limit * (1 + 1e-6)))}
                          - set(self.binding))
            if not over:
                break
            self.binding += over
            self.rows = np.vstack([self.rows] + [self._force_row(k, j) for k, j in over])
        self.last = QpOutcome(status, time.perf_counter() - t0, iterations)
        if not self.last.usable:
            raise SolverError(f"heavy-haul QP (condensed): {status} after {iterations} iterations")
        self.previous = u[:n].copy()
        self.values = objective_values(self.terms, self.wagons, np.array([self.G[k] @ u + d[k] for k in range(np_)]),
                                       u.reshape(nc, n), vr, self.model.ts)
        return self.previous.copy()
