"""Eq. 11's effort term as Zhang & Zhuan print it, K_e (sum_loco |u| + K_b sum_wagon |u|), in the
condensed QP (``effort_penalty: magnitude``; eq. 4 squares the efforts, eq. 11, the fenced objective
Table IV's f = 10 runs use, does not). A wagon only brakes (u <= 0), so its |u| is -u, a linear term; a
locomotive pulls and brakes, so each locomotive move gets a variable t >= |u| (two rows, t >= u and
t >= -u) whose cost is the magnitude's. With the term squared (eq. 4) nothing here adds anything, but for
``brake_penalty_on: all``: each locomotive move gets a variable b >= -u, b >= 0 (one row; its bounds),
costing (K_b - 1) b^2 on top of eq. 4's u^2, so at the optimum b = max(-u, 0) and a braking locomotive
costs K_b u^2 as a braking wagon does (``terms.brake``; DAQP needs its curvature, so none for K_b = 1,
where the term is nil)."""
import numpy as np

from ecostudy.core.errors import SolverError


class Magnitudes:
    """The variables, rows and linear costs a magnitude (or a locomotive's braking, ``terms.brake``) adds
    to the condensed QP over the moves u(0..Nc-1) (``terms`` from
    :func:`~ecostudy.heavyhaul.rhc.objective_terms`; ``scale`` Ts / Np, move m held over ``count[m]``
    samples of the horizon; ``hessian`` over the moves, ``effort`` its diagonal's share from eq. 4's
    squared term, which a locomotive move's |u| variable takes on as its own). The variables follow
    the moves: the |u| ones, then the braking ones."""

    def __init__(self, terms, wagons, locos, count, scale, hessian, effort):
        n, nc = len(wagons), len(count)
        weight = np.asarray(terms.magnitude, float)
        self.moves = nc * n
        self.cost = np.concatenate([np.where(wagons, -scale * c * weight, 0.0) for c in count])  # on u: a wagon's -u
        self.wagon_cols = [m * n + i for m in range(nc) for i in range(n) if wagons[i] and weight[i] > 0]
        pairs = [(m, i) for m in range(nc) for i in locos if weight[i] > 0]
        self.cols = [m * n + i for m, i in pairs]
        self.t_cost = np.array([scale * count[m] * weight[i] for m, i in pairs])
        brakes = [(m, i) for m in range(nc) for i in locos if terms.brake[i] > 0]
        self.brake_cols = [m * n + i for m, i in brakes]
        self.extra = len(pairs) + len(brakes)
        curvature = np.concatenate([2 * scale * np.asarray(effort)[self.cols],
                                    [2 * scale * count[m] * terms.ke * terms.brake[i] / 1e4 for m, i in brakes]])
        self.hessian = np.block([[hessian, np.zeros((self.moves, self.extra))],
                                 [np.zeros((self.extra, self.moves)), np.diag(curvature)]]) if self.extra else hessian
        pick = np.zeros((len(pairs), self.moves))
        pick[np.arange(len(pairs)), self.cols] = 1.0
        eye, none = np.eye(len(pairs)), np.zeros((len(pairs), len(brakes)))
        brake_pick = np.zeros((len(brakes), self.moves))
        brake_pick[np.arange(len(brakes)), self.brake_cols] = -1.0
        self.abs_rows = np.vstack([np.hstack([pick, -eye, none]), np.hstack([-pick, -eye, none]),  # +-u - t <= 0
                                   np.hstack([brake_pick, none.T, -np.eye(len(brakes))])])  # -u - b <= 0

    def pad(self, row):
        """A row over the moves, with zeros for the magnitudes' variables."""
        return np.concatenate([row, np.zeros(self.extra)])

    def rows(self, rows):
        """The fixed rows over the moves, padded, and the magnitudes' rows after them."""
        return np.vstack([np.hstack([rows, np.zeros((len(rows), self.extra))]), self.abs_rows]) if self.extra else rows

    def upper(self, c_hi):
        return np.concatenate([c_hi, np.zeros(len(self.abs_rows))])

    def lower(self, c_lo):
        return np.concatenate([c_lo, np.full(len(self.abs_rows), -np.inf)])

    def linear(self, g, high_kN):
        """The linear term over the moves and the magnitudes' variables."""
        if self.wagon_cols and np.any(np.tile(high_kN, self.moves // len(high_kN))[self.wagon_cols] > 0):
            raise SolverError("heavy-haul QP: a wagon may pull, so its |u| is not -u (effort_penalty: magnitude)")
        return np.concatenate([g + self.cost, self.t_cost, np.zeros(len(self.brake_cols))])

    def bounds(self, lo, hi):
        """Bounds over the moves and the added variables (0 <= t <= the larger of |lo| and |hi|;
        0 <= b <= the larger of -lo and 0)."""
        top = np.maximum(np.abs(lo), np.abs(hi))[self.cols]
        braking = np.maximum(-np.asarray(lo), 0.0)[self.brake_cols]
        return np.concatenate([lo, np.zeros(self.extra)]), np.concatenate([hi, top, braking])
