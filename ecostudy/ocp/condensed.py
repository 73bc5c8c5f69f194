"""Farooqi 2018's SBPC FHOCP condensed to its block handles (single shooting), as fmincon solved it.

The program of ``ocp.blocked`` (eqs. 4.9, 4.18, 4.19, 4.31) with the states eliminated: from the
measured state at sample k the free block handles u+_b, u-_b (b >= floor(k / L)) are the only
decision variables; the positions and speeds on the samples k+1 .. k_f are the simulation of the same
trapezoidal step

    s_i+1 = s_i + T_s (v_i + v_i+1) / 2
    (v_i+1 - v_i) M / T_s = F_T,mean u+_b - share(v_i + v_i+1) (F_B,mean u-_b + R_D(v_i, v_i+1) + G_i)

(implicit in v_i+1, solved by Newton), with their sensitivities to the handles carried forward
(implicit differentiation of each step). The speed bounds of the predicted nodes, v >= 0 and the
terminal set are constraints of the handles. A block of L samples is then one variable where the
simultaneous program of ``ocp.blocked`` keeps (s, v) on every sample whatever L is: the time of a
solve falls with the number of blocks (Farooqi 2018 Table 4.1's trend), at the price of dense
derivatives (one row per predicted node, one column per block), which is why L = 1 is slow here.

The envelopes are the trains' ``smooth_force`` (the simultaneous program's), their slopes central
differences. Solved by SLSQP (scipy), warm from the previous sample's handles (the shifted tail).
"""
import math
from typing import Any, NamedTuple, Optional, TypeAlias

import numpy as np
from scipy.optimize import minimize

from ecostudy.core.physics import Envelope, interval_resistance, moving_share
from ecostudy.core.types import State
from ecostudy.core.units import FloatArray
from ecostudy.ocp.blocked import handle_guess, profile_along
from ecostudy.ocp.problem import Case
from ecostudy.ocp.timedomain import FORCE_SCALE

DIFF = 1e-6  # [m/s] difference step of the envelopes, the share and the resistance
CORNER_SHARE = 0.0005  # ``Envelope.smooth_function``'s default rounding of the power corner (a test holds them equal)
FEASIBLE = 1e-5  # [m, m/s] the violation of a constraint a usable solve may leave


class Outcome(NamedTuple):
    """One solve: ``usable`` when SLSQP stopped at a point within the constraints (``FEASIBLE``)."""

    usable: bool
    iterations: int
    status: str


# simulate's answer: positions and speeds on samples k .. k_f, their derivatives by the free
# handles, the traction work [kJ] and its gradient
Simulated: TypeAlias = tuple[FloatArray, FloatArray, FloatArray, FloatArray, float, FloatArray]


class _Envelope:
    """An envelope's ``smooth_force`` [kN] and its slope (central difference) at a float speed.

    The simulation asks for the same speed twice in a row (a step's end speed is the next step's
    start), so the last answer is kept; a table's three evaluations (v, v +- ``DIFF``) run in one
    loop with ``physics.smooth_table``'s operations in its order, so the numbers are the same to
    the bit (an SBPC run's simulation: 22.8 of 33.4 CPU s under cProfile, docs/closed_loop.md)."""

    def __init__(self, envelope: Envelope) -> None:
        self.force = envelope.smooth_function()
        self.table = (*envelope.smooth_coefficients, envelope.width) if envelope.kind == "table" else None
        # power / smooth_max(v, v_c, CORNER_SHARE v_c), as ``Envelope.smooth_function`` writes it
        power, corner = envelope.max_power, envelope.max_power / envelope.max_force
        self.hyperbola = (power, corner, CORNER_SHARE * corner) if self.table is None and math.isfinite(power) else None
        self.last: tuple[float, tuple[float, float]] = (math.nan, (math.nan, math.nan))

    def __call__(self, v: float) -> tuple[float, float]:
        """(force, slope) at speed ``v``."""
        if v == self.last[0]:
            return self.last[1]
        if self.hyperbola is not None:
            power, corner, width = self.hyperbola
            vu, vd = v + DIFF, v - DIFF
            at = power / (0.5 * (v + corner + ((v - corner) ** 2 + width * width) ** 0.5))
            up = power / (0.5 * (vu + corner + ((vu - corner) ** 2 + width * width) ** 0.5))
            down = power / (0.5 * (vd + corner + ((vd - corner) ** 2 + width * width) ** 0.5))
        elif self.table is None:
            f = self.force
            at, up, down = f(v), f(v + DIFF), f(v - DIFF)
        else:
            c0, c1, terms, width = self.table
            vu, vd = v + DIFF, v - DIFF
            at, up, down = c0 + c1 * v, c0 + c1 * vu, c0 + c1 * vd
            for a, knot in terms:
                at = at + a * ((v - knot) ** 2 + width * width) ** 0.5
                up = up + a * ((vu - knot) ** 2 + width * width) ** 0.5
                down = down + a * ((vd - knot) ** 2 + width * width) ** 0.5
        out = at / FORCE_SCALE, (up - down) / (2 * DIFF * FORCE_SCALE)
        self.last = (v, out)
        return out


class Condensed:
    """The FHOCP on samples 0 .. k_f with blocks of ``block`` samples, from ``guess`` = (s, v) on them."""

    def __init__(self, case: Case, ts: float, kf: int, block: int, guess: tuple[FloatArray, FloatArray],
                 margin: float = 0.1, max_iter: int = 100) -> None:
        train, self.case, self.ts, self.kf, self.block, self.margin = case.train, case, ts, kf, block, margin
        self.nb = (kf - 1) // block + 1
        self.mass = train.mass / FORCE_SCALE
        self.davis = tuple(c / FORCE_SCALE for c in train.davis)
        self.traction, self.braking = _Envelope(train.traction), _Envelope(train.braking)
        s0, v0 = (np.asarray(x, float) for x in guess)
        u = handle_guess(case, s0, v0, ts, block)
        self.u = np.concatenate([np.maximum(u, 0.0), np.maximum(-u, 0.0)])
        self.profile = profile_along(case, s0, v0, ts, margin)
        self.max_iter, self.k, self.state = max_iter, 0, (0.0, 0.0)
        self.gamma, self.s, self.v = 0.0, s0, v0
        self._memo: Optional[tuple[tuple[Any, ...], Outcome, FloatArray, float, FloatArray, FloatArray]] = None
        self.work_ref = max(train.traction.peak * case.segment.distance * 0.1 / 1e3, 1.0)  # kJ, as ocp.blocked

    # --- the model -------------------------------------------------------------------------------
    def _step(self, v0: float, up: float, um: float,
              grade: float) -> tuple[float, tuple[float, float, float], tuple[float, float, float, float]]:
        """v_i+1 and its derivatives by v_i, u+, u- (Newton on the implicit trapezoid from an explicit
        step), and the step's traction work [kJ] with its derivatives by v_i, v_i+1, u+."""
        ts, mass, davis = self.ts, self.mass, self.davis
        ft0, dft0 = self.traction(v0)
        fb0, dfb0 = self.braking(v0)

        def residual(v1: float) -> tuple[float, float, float, float, float, float, float, float]:
            ft1, dft1 = self.traction(v1)
            fb1, dfb1 = self.braking(v1)
            ftm, fbm, total = 0.5 * (ft0 + ft1), 0.5 * (fb0 + fb1), v0 + v1
            held = moving_share(total)
            dheld = (moving_share(total + DIFF) - moving_share(total - DIFF)) / (2 * DIFF)
            resist = interval_resistance(v0, v1, davis, grade)
            r1 = (interval_resistance(v0, v1 + DIFF, davis, grade) - resist) / DIFF  # quadratic in v1: off by C DIFF / 2
            load = fbm * um + resist
            g = (v1 - v0) * mass / ts - (ftm * up - held * load)
            g1 = mass / ts - (0.5 * dft1 * up - dheld * load - held * (0.5 * dfb1 * um + r1))
            return g, g1, ftm, fbm, held, dheld, load, dft1

        v1 = max(v0 + ts / mass * (ft0 * up - moving_share(2 * v0) * (fb0 * um + interval_resistance(v0, v0, davis, grade))), 0.0)
        for _ in range(30):
            g, g1, ftm, fbm, held, dheld, load, dft1 = residual(v1)
            if abs(g) < 1e-12 * mass / ts:
                break
            v1 -= g / g1
        r0 = (interval_resistance(v0 + DIFF, v1, davis, grade) - interval_resistance(v0, v1, davis, grade)) / DIFF
        g0 = -mass / ts - (0.5 * dft0 * up - dheld * load - held * (0.5 * dfb0 * um + r0))
        dv0, dup, dum = -g0 / g1, ftm / g1, -held * fbm / g1
        vbar = 0.5 * (v0 + v1)
        work = ts * ftm * up * vbar
        return v1, (dv0, dup, dum), (work, ts * up * (0.5 * dft0 * vbar + 0.5 * ftm), ts * up * (0.5 * dft1 * vbar + 0.5 * ftm),
                                     ts * ftm * vbar)

    def simulate(self, z: FloatArray) -> Simulated:
        """Positions, speeds on samples k .. k_f, their derivatives by z (the free handles) and the
        traction work [kJ] with its gradient."""
        k, L, ts = self.k, self.block, self.ts
        first = k // L
        nfree = self.nb - first
        n = self.kf - k
        grade = self.profile[0]
        s, v = np.empty(n + 1), np.empty(n + 1)
        ds, dv = np.zeros((n + 1, 2 * nfree)), np.zeros((n + 1, 2 * nfree))
        s[0], v[0] = self.state
        work, dwork = 0.0, np.zeros(2 * nfree)
        for j in range(n):
            b = (k + j) // L - first
            up, um = float(z[b]), float(z[nfree + b])
            v1, (a0, aup, aum), (w, w0, w1, wup) = self._step(float(v[j]), up, um, float(grade[k + j]))
            v[j + 1] = v1
            dv[j + 1] = a0 * dv[j]
            dv[j + 1, b] += aup
            dv[j + 1, nfree + b] += aum
            s[j + 1] = s[j] + 0.5 * ts * (v[j] + v1)
            ds[j + 1] = ds[j] + 0.5 * ts * (dv[j] + dv[j + 1])
            work += w
            dwork += w0 * dv[j] + w1 * dv[j + 1]
            dwork[b] += wup
        return s, v, ds, dv, work, dwork

    # --- the program ----------------------------------------------------------------------------
    def start(self, k: int, state: State) -> None:
        """Solve from sample ``k`` at ``state`` next (the blocks already run are dropped)."""
        self.k, self._memo = k, None
        self.state = (float(np.clip(state.position, 0.0, self.case.segment.distance + 200.0)), max(float(state.speed), 0.0))

    def solve(self, alpha: float, omega: float, gamma_max: float | None) -> Outcome:
        """min (alpha J + omega gamma) / J_ref within Delta(x_kf, X_f) <= gamma <= ``gamma_max``
        (None: any; 0: the nominal terminal set); keeps the handles, predicted states and gamma.

        The nominal program is tried only where the smallest gamma (4.18, warm: a few iterations)
        is within ``FEASIBLE``: SLSQP spends up to ``max_iter`` iterations before it gives up on an
        unreachable terminal set. That solve is kept for a 4.18 asked next from the same state."""
        key = (self.k, self.state, alpha, omega, gamma_max)
        if self._memo is not None and self._memo[0] == key:
            _, outcome, self.u, self.gamma, self.s, self.v = self._memo
            self.u = self.u.copy()
            return outcome._replace(iterations=0)
        if gamma_max == 0.0:
            check = self.solve(0.0, 1.0, None)
            self._memo = (self.k, self.state, 0.0, 1.0, None), check, self.u.copy(), self.gamma, self.s, self.v
            if not check.usable or self.gamma > FEASIBLE:
                return Outcome(False, check.iterations, f"the terminal set is out of reach (gamma {self.gamma:.3g})")
            outcome = self._program(alpha, omega, gamma_max)
            return outcome._replace(iterations=outcome.iterations + check.iterations)
        return self._program(alpha, omega, gamma_max)

    def _program(self, alpha: float, omega: float, gamma_max: float | None) -> Outcome:
        first, distance = self.k // self.block, self.case.segment.distance
        nfree = self.nb - first
        bound = self.profile[1][self.k + 1:]
        cache: dict[bytes, Simulated] = {}

        def run(x: FloatArray) -> Simulated:
            key = x.tobytes()
            if key not in cache:
                cache.clear()
                cache[key] = self.simulate(x[:-1])
            return cache[key]

        def objective(x: FloatArray) -> float:
            return float(alpha * run(x)[4] + omega * x[-1]) / self.work_ref

        def objective_grad(x: FloatArray) -> FloatArray:
            return np.append(alpha * run(x)[5], omega) / self.work_ref

        def path(x: FloatArray) -> FloatArray:  # bound - v >= 0 and v >= 0 on the predicted nodes
            v = run(x)[1][1:]
            return np.concatenate([bound - v, v])

        def path_jac(x: FloatArray) -> FloatArray:
            dv = run(x)[3][1:]
            return np.hstack([np.vstack([-dv, dv]), np.zeros((2 * len(dv), 1))])

        def terminal(x: FloatArray) -> FloatArray:  # gamma - Delta >= 0, Delta = max(|s_kf - x_f|, 1 s * v_kf)
            s, v = run(x)[0][-1], run(x)[1][-1]
            return np.array([x[-1] - (s - distance), x[-1] + (s - distance), x[-1] - v])

        def terminal_jac(x: FloatArray) -> FloatArray:
            ds, dv = run(x)[2][-1], run(x)[3][-1]
            return np.vstack([np.append(-ds, 1.0), np.append(ds, 1.0), np.append(-dv, 1.0)])

        x0 = np.concatenate([self.u[first:self.nb], self.u[self.nb + first:], [min(self.gamma, gamma_max or math.inf)]])
        top = 1e4 if gamma_max is None else gamma_max
        bounds = [(0.0, 1.0)] * (2 * nfree) + [(0.0, top)]
        if gamma_max == 0.0:  # the nominal terminal set X_f itself: s_kf = x_f, v_kf = 0
            end = {"type": "eq", "fun": lambda x: terminal(x)[1:], "jac": lambda x: terminal_jac(x)[1:]}
        else:
            end = {"type": "ineq", "fun": terminal, "jac": terminal_jac}
        constraints = [{"type": "ineq", "fun": path, "jac": path_jac}, end]
        res = minimize(objective, x0, jac=objective_grad, bounds=bounds, constraints=constraints, method="SLSQP",
                       options={"maxiter": self.max_iter, "ftol": 1e-10})
        x = np.clip(res.x, [b[0] for b in bounds], [b[1] for b in bounds])
        ends = terminal(x)
        ends = -np.abs(ends[1:]) if gamma_max == 0.0 else ends  # equalities, or gamma - Delta >= 0
        worst = min(float(np.min(path(x))), float(np.min(ends)))
        # status 8 (no descent along the search direction) at a point within the constraints is the
        # optimum to the accuracy of the simulation's derivatives (measured: 1e-7 to 4e-6 m off the
        # terminal set); 9 (iteration limit) there is a plan that keeps every constraint
        usable = res.status in (0, 8, 9) and worst >= -FEASIBLE
        if usable:
            self.u[first:self.nb], self.u[self.nb + first:] = x[:nfree], x[nfree:2 * nfree]
            self.gamma = float(x[-1])
            s, v = run(x)[:2]
            self.s = np.concatenate([np.full(self.k, s[0]), s])
            self.v = np.concatenate([np.full(self.k, v[0]), v])
        return Outcome(usable, int(res.nit), res.message)

    def follow(self) -> None:
        """Move the grade and the speed bounds to the positions the last solve predicts."""
        self.profile = profile_along(self.case, self.s, self.v, self.ts, self.margin)

    def handle(self, k: int) -> float:
        """The handle the solved program applies at sample ``k``."""
        b = min(k // self.block, self.nb - 1)
        return float(self.u[b] - self.u[self.nb + b])

    def handles(self, k: int) -> FloatArray:
        """The handles of samples k .. k_f - 1."""
        u = self.u[:self.nb] - self.u[self.nb:]
        handles: FloatArray = u[np.minimum(np.arange(k, self.kf) // self.block, self.nb - 1)]
        return handles
