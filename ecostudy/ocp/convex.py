"""The convex controller's program: Yazhemsky 2017's SOCP (eq. 6.10) from any state, on a trimmed grid.

On nodes x_0 = X0 (the measured position) < x_1 < ... < x_n = D (the grid ahead, eqs. 4.2a-e)
the variables are the node speeds v and clocks t, and per interval the inverse speed rho,
the force per speed and unit mass g = Gamma / (M v) [1/s] (Yazhemsky 2017's gamma / m), its positive
part g+, the overspeed slack b and the over-braking slack h:

    minimise  w_t t_n + sum dx_i (w_e g+_i + w_br h_i + w_os b_i)                       (6.10)
    v_0 = V0, t_0 = T0, v_n = V_f, T_min <= t_n <= T_max                        (6.1c-e)
    v_i <= V_max,i (i = 1 .. n-1)                                                 (6.1b)
    t_i+1 = t_i + rho_i dx_i                                                      (6.1f)
    || (2, s_i - rho_i) || <= s_i + rho_i, i.e. rho_i s_i >= 1                   (6.1g)
    -F_B(v) rho <= g M <= F_T(v) rho as lines F <= a_j + b_j v: g M <= a_j rho + b_j  (6.1h, 6.1j)
    g+ >= 0, g+ >= g                                                              (6.1i)
    v_i+1 = v_i + (g_i - a0_i rho_i - a1 - a2 s_i) dx_i                          (6.1k)
    b >= 0, b_i >= v_i - (V_max,i - B_os)                                          (6.5)
    h >= 0, h_i >= g+_i - g_i - B_brk rho_i                                        (6.8)
    t_i >= T_buff,i (a leading train's clock at x_i + X_sep)                      (6.9)

a0 = (A + grade and curve force) / M, a1 = B / M, a2 = C / M (Davis A + B v + C v^2, the signs of
ecostudy: resistances positive). The speed s_i of an interval is ``scheme``-dependent:

- ``"left"``: s_i = v_i, as printed (forward Euler). It needs v >= epsilon (eq. 3.6), and the
  first interval from a stand then takes dx / epsilon;
- ``"midpoint"`` (default): s_i = (v_i + v_i+1) / 2. Still linear, so the program stays a SOCP;
  rho_i dx_i is then the exact time of an interval run at constant acceleration, and a train at a
  stand needs no epsilon.

Envelopes enter as pieces a + b v + c v^2, linear in the variables (v rho = 1, v^2 rho = s): thesis
001's F_max and R(v) exactly, other concave tables as their chords; a power limit P / v (convex
in v) as its tangent at the previous plan's speed in each interval: below it, tight where the
train runs (a sequential convex step). Solved by Clarabel (interior point; against Ipopt: ``docs/closed_loop.md``) on
rows of about one: m/s, s, scaled cones (below), force limits per unit mass g <= (a_j rho + b_j) / M in 1/s (6.10's
gamma / m); in newtons (coefficients to 1e6) its dual residual stalls above 1e-8, plans end ``AlmostSolved``.
"""
import time
from dataclasses import dataclass
from typing import Any, Callable, NamedTuple, Sequence, TypeAlias

import clarabel
import numpy as np
from scipy import sparse

from ecostudy.core.grid import Segment, drop_idle_power, node_limits, warn_unmodelled
from ecostudy.core.kinematics import interval_grade_force
from ecostudy.core.physics import Envelope
from ecostudy.core.types import State, Train
from ecostudy.core.units import FloatArray, Numeric

Pieces: TypeAlias = Callable[[FloatArray], list[tuple[Numeric, Numeric, Numeric]]]  # (a [N], b [N s/m], c [N s^2/m^2])
Term: TypeAlias = tuple[Any, Any]  # (column indices, coefficients), each broadcast to the block's rows
Block: TypeAlias = tuple[list[np.ndarray], list[np.ndarray], np.ndarray]
Lead: TypeAlias = Callable[[FloatArray], Any]  # the earliest clock at positions [s] (eq. 6.9's T_buff)
Problem: TypeAlias = tuple[FloatArray, State, tuple[float, float], float, float, Lead | None]

NAMES = ("v", "t", "rho", "g", "gp", "b", "h")  # variable blocks, in this order
USABLE = ("Solved", "AlmostSolved")  # Clarabel's statuses whose plan is driven
TIGHT = 5e-7  # rho s - 1 above which an interval's relaxation is tightened by another solve
EXACT = 1e-6  # max |rho s - 1| up to which a plan is a driving of the real train
POLISH = 3    # tightening rounds at most while the plan is exact (max |rho s - 1| <= EXACT)
MORE_POLISH = 6  # rounds at most for a plan that is not exact yet


@dataclass(frozen=True)
class ConvexWeights:
    """Objective weights and buffers of eq. 6.10 (defaults: Yazhemsky 2017 Ch.9)."""

    time: float = 1.0          # w_t [1/s]
    energy: float = 1.0        # w_e
    overspeed: float = 0.02    # w_os
    braking: float = 1.0       # w_br
    buffer: float = 1.0        # B_os [m/s]
    brake_level: float = 0.8   # B_brk [m/s^2]


FASTEST = ConvexWeights(time=1.0, energy=0.0, overspeed=0.0, braking=0.0, buffer=0.0, brake_level=1.0)  # all-out


def envelope_pieces(envelope: Envelope, tolerance: float = 0.002) -> Pieces:
    """A function of the intervals' reference speeds [m/s] giving pieces (a [N], b [N s/m],
    c [N s^2/m^2]) with envelope(v) <= min a + b v + c v^2 (scalars, or arrays per interval).
    Each piece enters the program linearly: g M <= a rho + b + c s (as v rho = 1, v^2 rho = s).

    - a table that is a constant force up to a corner, then a concave quadratic within
      ``tolerance`` of its peak (Yazhemsky 2017's F_max and R(v), eqs. 6.1h, 6.1j): those two pieces;
    - another concave table: its chords (their minimum is the table);
    - a table with a convex part, and a power limit P / v (convex in v): the force limit and, per
      interval, the chord or tangent at the reference speed (the previous plan's): exact where the
      train runs and below the envelope elsewhere (a sequential convex step).
    """
    if envelope.kind != "table":
        fixed: list[tuple[Numeric, Numeric, Numeric]] = [(envelope.max_force, 0.0, 0.0)]
        if not np.isfinite(envelope.max_power):
            return lambda speeds: fixed
        power = envelope.max_power
        return lambda speeds: fixed + [(2.0 * power / np.maximum(speeds, 0.5), -power / np.maximum(speeds, 0.5) ** 2, 0.0)]
    v, f = np.asarray(envelope.speeds, float), np.asarray(envelope.forces, float)
    drop = np.nonzero(f < f[0] - tolerance * f.max())[0]
    if v.size < 2 or not drop.size:
        return lambda speeds: [(f[0], 0.0, 0.0)]
    flat = drop[0] - 1
    if v.size - flat >= 3:
        c2, c1, c0 = np.polyfit(v[flat:], f[flat:], 2)
        if c2 <= 0 and np.max(np.abs(np.polyval((c2, c1, c0), v[flat:]) - f[flat:])) <= tolerance * f.max():
            return lambda speeds: [(f[0], 0.0, 0.0), (c0, c1, c2)]
    slope = np.diff(f) / np.diff(v)
    chords = [(a, b, 0.0) for a, b in zip(f[:-1] - slope * v[:-1], slope)]
    if np.all(np.diff(slope) <= 1e-9 * max(abs(slope).max(), 1.0)):  # concave
        return lambda speeds: chords

    def at(speeds: FloatArray) -> list[tuple[Numeric, Numeric, Numeric]]:
        k = np.clip(np.searchsorted(v, speeds) - 1, 0, slope.size - 1)
        return [(f.max(), 0.0, 0.0), (f[k] - slope[k] * v[k], slope[k], 0.0)]
    return at


def trapezoid_grid(segment: Segment, points: int, ramp: float = 0.1, smallest: float = 0.2) -> FloatArray:
    """Yazhemsky 2017 §3.2.2's grid: ``points`` nodes whose spacing grows linearly from ``smallest``
    times the mean over the first ``ramp`` share of the nodes, stays flat, and shrinks again to
    the stop; every profile change is a node (the nearest node moves there)."""
    n = points - 1
    r = max(int(ramp * n), 1)
    profile = np.ones(n)
    profile[:r] = np.linspace(smallest, 1.0, r)
    profile[-r:] = np.minimum(profile[-r:], np.linspace(1.0, smallest, r))
    nodes = np.concatenate([[0.0], np.cumsum(profile)]) * segment.distance / profile.sum()
    for x in segment.breakpoints():
        k = int(np.argmin(np.abs(nodes - x)))
        if 0 < k < n:
            nodes[k] = x
    nodes = np.unique(nodes)
    nodes[-1] = segment.distance
    return nodes


class ConvexPlan(NamedTuple):
    """A solved program on the grid ahead: nodes [m], speeds [m/s], clocks [s], per interval the
    inverse speed rho [s/m] and the force [N]; the relaxation's largest gap max |rho s - 1|,
    Clarabel's status, its solve time [s] and whether the arrival window had to be dropped."""

    nodes: np.ndarray
    v: np.ndarray
    t: np.ndarray
    rho: np.ndarray
    force: np.ndarray
    gap: float
    status: str
    seconds: float
    softened: bool

    @property
    def usable(self) -> bool:
        return self.status in USABLE


class ConvexProgram:
    """SOCP 6.10 for one segment and train; ``solve(state, ...)`` assembles the program on the grid
    from the measured position (eqs. 4.2a-e) and solves it."""

    def __init__(self, segment: Segment, train: Train, nodes: Sequence[float] | FloatArray,
                 weights: ConvexWeights = ConvexWeights(), scheme: str = "midpoint", epsilon: float = 0.1,
                 margin: float = 0.05) -> None:
        if scheme not in ("left", "midpoint"):
            raise ValueError(f"scheme must be 'left' or 'midpoint', not {scheme!r}")
        self.segment, self.nodes = segment, np.asarray(nodes, float)
        warn_unmodelled(segment, "the convex SOCP")
        # a power limit that never binds would only add a badly scaled tangent row (the relaxation
        # then ends inexact, max |rho s - 1| up to 3e-2 on a 1e7 kW train): left out
        self.train, self.idle_power = drop_idle_power(segment, train, "the convex SOCP")
        self.weights, self.scheme, self.epsilon, self.margin = weights, scheme, epsilon, margin
        self.traction = envelope_pieces(self.train.traction)
        self.brake = envelope_pieces(self.train.braking)
        # (nodes, speeds) of the last plan: where the power tangents touch
        self.previous: tuple[FloatArray, FloatArray] | None = None
        self.settings = clarabel.DefaultSettings()
        self.settings.verbose = False
        self.settings.iterative_refinement_enable = False  # halves the solve; the gap stays below 1e-7 (tests)
        self.refined = clarabel.DefaultSettings()  # for a solve that ended inaccurate
        self.refined.verbose = False

    def limit(self, max_iter: int | None = None, seconds: float | None = None) -> None:
        """Cap every Clarabel solve of the next ``solve`` at ``max_iter`` iterations and ``seconds``
        (None: Clarabel's defaults, 200 iterations and no time limit). A solve that hits either
        ends unusable, as an on-board solver's would."""
        for settings in (self.settings, self.refined):
            settings.max_iter = 200 if max_iter is None else int(max_iter)
            settings.time_limit = float("inf") if seconds is None else float(seconds)

    def grid_from(self, position: float, reach: float = 0.0) -> FloatArray:
        """Nodes of the grid ahead of ``position`` (eq. 4.2d). With ``reach`` > 0 the first
        interval is [position, position + reach], the distance the train runs under the control
        held until the next sample, and the grid continues from the next node beyond it."""
        last = self.nodes[-1]
        end = min(position + max(reach, 0.0), last)
        ahead = self.nodes[self.nodes > end + 1e-3]
        if not ahead.size:  # within the last millimetre: one interval to the stop
            return np.array([position, max(last, position + 1e-3)])
        return np.concatenate([[position, end] if end > position + 1e-3 else [position], ahead])

    def solve(self, state: State, arrival: tuple[float, float] = (0.0, np.inf), end_speed: float = 0.0,
              mass_scale: float = 1.0, lead: Lead | None = None, hold: float = 0.0) -> ConvexPlan:
        """Plan from ``state`` (State, SI). ``arrival``: (T_min, T_max) on the state's clock;
        ``lead``: a callable giving the earliest clock at positions (eq. 6.9's T_buff);
        ``hold`` [s]: the sample time, so the first interval is what the first control drives.
        Without a plan in the window, the window is dropped (``softened``)."""
        t0 = time.perf_counter()
        x = self.grid_from(state.position, max(state.speed, 0.5) * hold if hold else 0.0)
        plan = self._solve(x, state, arrival, end_speed, mass_scale, lead)
        # at the edge of the window Clarabel may end with reduced accuracy and a plan faster than the
        # physics (rho s < 1 by 3e-5, measured on Fig. 9.7's last metre; 1e-6 to 4.5e-6 there with a
        # sample of computation delay): no plan in the window either, when it is not exact (1e-6)
        edge = plan.status == "AlmostSolved" and plan.gap > EXACT
        if (not plan.usable or edge) and np.isfinite(arrival[1]):
            dropped = self._solve(x, state, (arrival[0], np.inf), end_speed, mass_scale, lead)._replace(softened=True)
            if dropped.usable or not plan.usable:
                plan = dropped
        return plan._replace(seconds=time.perf_counter() - t0)

    def _solve(self, x: FloatArray, state: State, arrival: tuple[float, float], end_speed: float, mass_scale: float,
               lead: Lead | None) -> ConvexPlan:
        problem: Problem = (x, state, arrival, end_speed, mass_scale, lead)
        v, t, rho, g, status = self._conic(problem)
        s = self._speed(v)
        if status != "Solved" and (status != "AlmostSolved" or np.max(np.abs(rho * s - 1.0)) > TIGHT):
            # reduced accuracy or no progress: again with iterative refinement (off for speed)
            again = self._conic(problem, refined=True)
            if again[4] == "Solved":
                v, t, rho, g, status = again
                s = self._speed(v)
        # an optimum on a face of the relaxation (braking at the reserve or the full brake): the
        # interior point sits inside it, rho s - 1 up to 2e-5. Solve again with those intervals' rho
        # below the tangent of 1/s at their speed (a sequential convex step; only rho = 1/s meets
        # it); the slack may move to other intervals of the face, so up to POLISH rounds, and up to
        # MORE_POLISH while the plan is not exact (one solve of Fig. 9.7 with a sample of delay on a
        # force-limited train was 3.3e-6 after three)
        tight, speeds = np.zeros(len(rho), bool), np.zeros(len(rho))
        for round_ in range(MORE_POLISH if status in USABLE else 0):
            loose = (rho * s - 1.0 > TIGHT) & ~tight
            if not loose.any() or (round_ >= POLISH and np.max(rho * s - 1.0) <= EXACT):
                break
            tight, speeds[loose] = tight | loose, s[loose]
            again = self._conic(problem, tight=(tight, speeds[tight]))
            if again[4] not in USABLE:
                break
            v, t, rho, g, status = again
            s = self._speed(v)
        gap = float(np.max(np.abs(rho * s - 1.0))) if rho.size else 0.0
        force = g * self.train.mass * mass_scale / np.maximum(rho, 1e-12)
        if status in USABLE:
            self.previous = (0.5 * (x[:-1] + x[1:]), s)
        return ConvexPlan(x, v, t, rho, force, gap, status, 0.0, False)

    def _conic(self, problem: Problem, tight: tuple[np.ndarray, FloatArray] | None = None,
               refined: bool = False) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, str]:
        """(v, t, rho, g, Clarabel's status) of one solve of the program ``problem`` (assemble's arguments)."""
        A, b, q, cones, index = self.assemble(*problem, tight)
        P = sparse.csc_matrix((A.shape[1], A.shape[1]))
        solution = clarabel.DefaultSolver(P, q, A, b, cones, self.refined if refined else self.settings).solve()
        z = np.asarray(solution.x, float)
        return z[index["v"]], z[index["t"]], z[index["rho"]], z[index["g"]], str(solution.status)

    def _speed(self, v: FloatArray) -> FloatArray:
        return v[:-1] if self.scheme == "left" else 0.5 * (v[:-1] + v[1:])

    def assemble(self, x: FloatArray, state: State, arrival: tuple[float, float], end_speed: float, mass_scale: float,
                 lead: Lead | None, tight: tuple[np.ndarray, FloatArray] | None = None
                 ) -> tuple[Any, FloatArray, FloatArray, list[Any], dict[str, np.ndarray]]:
        """Clarabel's (A, b, q, cones) of the program on nodes ``x``: A z + s = b, s in cones.
        ``tight``: (mask of intervals, their speeds s0): rho <= 2 / s0 - s / s0^2 + TIGHT / s0 there."""
        n = len(x) - 1
        sizes = {"v": n + 1, "t": n + 1, "rho": n, "g": n, "gp": n, "b": n, "h": n}
        index, start = {}, 0
        for name in NAMES:
            index[name] = np.arange(start, start + sizes[name])
            start += sizes[name]
        rows = _Rows(start)
        iv, it, ir, ig, igp, ib, ih = (index[name] for name in NAMES)
        dx = np.diff(x)
        mass = self.train.mass * mass_scale
        A0, B1, C2 = (c / mass for c in self.train.davis)
        a0 = A0 + interval_grade_force(self.segment, self.train, x) / self.train.mass
        w = self.weights
        i = np.arange(n)
        left, right = iv[:-1], iv[1:]
        half = 0.5 if self.scheme == "midpoint" else 0.0
        s_cols = [(left, 1.0 - half)] + ([(right, half)] if half else [])  # the interval's speed s
        # equalities (zero cone): start, end, clock and speed recursions
        v0 = max(state.speed, 0.0) if self.scheme == "midpoint" else max(state.speed, self.epsilon)
        rows.eq([(iv[[0, n]], 1.0)], [v0, end_speed])
        rows.eq([(it[0], 1.0)], state.time)
        rows.eq([(it[1:], 1.0), (it[:-1], -1.0), (ir, -dx)], np.zeros(n))
        # v_i+1 - v_i - dx (g - a0 rho - a1 - a2 s) = 0, s = (1 - half) v_i + half v_i+1
        rows.eq([(right, 1.0 + dx * C2 * half), (left, -1.0 + dx * C2 * (1 - half)),
                 (ig, -dx), (ir, dx * a0)], -dx * B1)
        # inequalities (non-negative cone): A z <= b
        inner = iv[1:n]
        limits = node_limits(self.segment, x)[1:] - self.margin  # node 0 is the measured state
        rows.le([(inner, 1.0)], limits[:-1])
        if self.scheme == "left":
            rows.le([(inner, -1.0)], -self.epsilon * np.ones(n - 1))
        mid = 0.5 * (x[:-1] + x[1:])
        reference = (np.interp(mid, *self.previous) if self.previous is not None
                     else np.minimum(limits, np.concatenate([[limits[0]], limits[:-1]])))
        for sign, pieces in ((1.0, self.traction), (-1.0, self.brake)):
            for a, slope, c in pieces(reference):      # +-g <= (a rho + slope + c s) / M: per unit mass
                rows.le([(ig, sign), (ir, -np.asarray(a, float) / mass)]
                        + [(col, -np.asarray(c, float) / mass * share) for col, share in s_cols], slope / mass * np.ones(n))
        rows.le([(igp, -1.0)], np.zeros(n))
        rows.le([(ig, 1.0), (igp, -1.0)], np.zeros(n))
        limit_here = np.concatenate([[float(self.segment.limit(state.position)) - self.margin], limits[:-1]])
        rows.le([(ib, -1.0)], np.zeros(n))
        rows.le([(left, 1.0), (ib, -1.0)], limit_here - w.buffer)
        rows.le([(ih, -1.0)], np.zeros(n))
        rows.le([(igp, 1.0), (ig, -1.0), (ir, -w.brake_level), (ih, -1.0)], np.zeros(n))
        lo, hi = arrival
        rows.le([(it[n], -1.0)], -lo)
        if np.isfinite(hi):
            rows.le([(it[n], 1.0)], hi)
        if lead is not None:
            earliest = np.asarray(lead(x[1:]), float)
            ok = np.isfinite(earliest)
            if ok.any():
                rows.le([(it[1:][ok], -1.0)], -earliest[ok])
        if tight is not None:
            mask, s0 = tight
            rows.le([(ir[mask], 1.0)] + [(col[mask], share / s0 ** 2) for col, share in s_cols], (2.0 + TIGHT) / s0)
        # second-order cones (s / c + c rho, 2, s / c - c rho), each component b - A z: rho s >= 1. The
        # scale c (the reference speed) makes both terms about 1: unscaled (s ~ 20 m/s, rho ~ 0.05 s/m)
        # Clarabel's cone residual of 1e-8 was a gap rho s - 1 of -1e-6 to -1e-5
        c = np.maximum(reference, 0.1)
        if self.previous is None:  # the first plan: no faster than full traction from the state
            c = np.minimum(c, np.sqrt(v0 ** 2 + 2.0 * self.train.traction.peak / mass * (mid - x[0])) + 0.1)
        s_terms = [(col, -share / c) for col, share in s_cols]
        rows.soc([s_terms + [(ir, -c)], [], s_terms + [(ir, c)]], [np.zeros(n), 2 * np.ones(n), np.zeros(n)])
        q = np.zeros(start)
        q[it[n]] = w.time
        q[igp], q[ih], q[ib] = dx * w.energy, dx * w.braking, dx * w.overspeed
        A, b, cones = rows.matrices()
        return A, b, q, cones, index


class _Rows:
    """Constraint rows grouped by cone, in Clarabel's form A z + s = b. A block is one row per
    element of ``rhs``; its terms are (column indices, coefficients), each broadcast to it."""

    def __init__(self, columns: int) -> None:
        self.columns = columns
        self.groups: dict[str, list[Any]] = {"eq": [], "le": [], "soc": []}

    @staticmethod
    def _block(terms: Sequence[Term], rhs: Any) -> Block:
        right = np.atleast_1d(np.asarray(rhs, float))
        return ([np.broadcast_to(np.asarray(c), right.shape) for c, _ in terms],
                [np.broadcast_to(np.asarray(v, float), right.shape) for _, v in terms], right)

    def eq(self, terms: Sequence[Term], rhs: Any) -> None:
        """sum of terms = rhs."""
        self.groups["eq"].append(self._block(terms, rhs))

    def le(self, terms: Sequence[Term], rhs: Any) -> None:
        """sum of terms <= rhs."""
        self.groups["le"].append(self._block(terms, rhs))

    def soc(self, parts: Sequence[Sequence[Term]], rhs: Sequence[Any]) -> None:
        """Three-dimensional cones, one per element: ``parts`` are the terms of the cone's three
        components (each rhs minus terms), the first at least the norm of the other two."""
        self.groups["soc"].append([self._block(terms, r) for terms, r in zip(parts, rhs)])

    def matrices(self) -> tuple[Any, FloatArray, list[Any]]:
        data, rows, cols, b, cones, r = [], [], [], [], [], 0

        def put(block: Block, row_of: np.ndarray) -> None:
            cs, vs, rhs = block
            for c, v in zip(cs, vs):
                rows.append(row_of)
                cols.append(c)
                data.append(v)
            b.append((row_of, rhs))

        for kind, cone in (("eq", clarabel.ZeroConeT), ("le", clarabel.NonnegativeConeT)):
            count = 0
            for block in self.groups[kind]:
                m = block[2].size
                put(block, np.arange(r, r + m))
                r, count = r + m, count + m
            if count:
                cones.append(cone(count))
        for parts in self.groups["soc"]:
            m = parts[0][2].size
            for p, block in enumerate(parts):
                put(block, r + 3 * np.arange(m) + p)
            r += 3 * m
            cones.extend(clarabel.SecondOrderConeT(3) for _ in range(m))
        rhs = np.zeros(r)
        for row_of, values in b:
            rhs[row_of] = values
        A = sparse.csc_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(r, self.columns))
        return A, rhs, cones
