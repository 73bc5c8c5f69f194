"""Driver-advisory runs as phases of variable length (Farooqi 2018 Ch. 5, eqs. 5.7-5.12, Fig. 5.1).

The segment is cut into sectors at every gradient, curve and (train-length) speed-limit change,
so that the track is constant inside a sector. Every sector gets the same fixed sequence of
phases, each with one DAS mode (Farooqi 2018 §3.1.2):

    coast, traction at each DAS level (1, 0.75, 0.5), cruise, coast, braking at each level

(full service braking alone by default; gentler braking levels first, the strongest last; no
coast phases for a train whose ``das_handle_levels`` have no 0).

The leading coast lets a sector begin by coasting and then accelerate (or cruise once gravity
has brought the train to speed). The phase lengths L_{s,p} >= 0 are the decision variables
(eq. 5.8, solved once over the whole horizon instead of inside an MPC loop); they sum to the
sector length, and a phase of zero length is skipped. Each phase has its own sub-grid of n equal
steps ds = L_{s,p} / n, so its mode is exact everywhere inside it:

    traction at level l   F_T = l * F_T,max(v), F_B = 0        (smooth envelope, eq. 5.9)
    coast                 F_T = F_B = 0
    full braking          F_T = 0, F_B = F_B,max(v)
    cruise                v constant; F_T - F_B = resistance, inside both envelopes

The dynamics are the energy-form recursion of ``ocp/space.py`` multiplied through by ds, so that a
zero-length phase is not singular (it forces v_{k+1} = v_k and dt_k = 0):

    v_{k+1}^2 - v_k^2 = 2 ds ((F_T - F_B - R_k) / M),     dt_k (v_k + v_{k+1}) = 2 ds

With ``extend=modechoice.define_mode_choice`` the mode of every phase becomes a choice among all DAS modes by binary
variables (``ocp/modechoice.py``); the fixed sequence above is then one of its binary patterns.
"""
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
import pyomo.core as pyo  # not pyomo.environ: see ocp.solver.prepare

from ecostudy.core.grid import Segment, warn_unmodelled
from ecostudy.core.kinematics import point_resistance
from ecostudy.core.physics import Envelope, interval_resistance, smooth_min
from ecostudy.core.types import Train
from ecostudy.core.units import FloatArray, Numeric
from ecostudy.ocp import space
from ecostudy.ocp.solver import Model
from ecostudy.ocp.space import FORCE_SCALE, energy_reference

MIN_PHASE = 1.0  # [m]: shorter phases are dropped from the driver's advice


@dataclass(frozen=True)
class Mode:
    kind: str      # "traction", "coast", "cruise" or "brake"
    level: float   # handle: traction share, 0 coasting, -1 braking; nan for cruise


def all_modes(train: Train, coast: bool | None = None) -> list["Mode"]:
    """Every distinct DAS mode, traction levels highest first, then cruise, coast and each braking
    level of the train's ``das_handle_levels``, gentlest first and the strongest last (full service
    braking alone by default): the choices of one MINLP phase. A gentler braking level lets advice
    brake where the regenerative envelope takes the whole braking force (the RB arc of Farooqi 2018,
    eq. 7.4), which full service braking cannot. Coast is a mode when the levels have 0 (``coast``
    None) or when ``coast`` says so; cruise always is (it is not a handle level)."""
    levels = sorted((lv for lv in train.das_levels if lv > 0), reverse=True)
    brakes = sorted((lv for lv in train.das_levels if lv < 0), reverse=True)
    coasts = coast if coast is not None else 0.0 in train.das_levels
    return ([Mode("traction", lv) for lv in levels] + [Mode("cruise", float("nan"))]
            + [Mode("coast", 0.0)] * coasts + [Mode("brake", lv) for lv in brakes])


def rspc_modes(train: Train) -> list["Mode"]:
    """The modes RSPC switches among (Remark 6.1.1): each DAS traction level of ``train``, cruise,
    coast (always: row 3 coasts between its checks) and each braking level; six with the default
    levels (1, 0.75, 0.5, 0, -1)."""
    return all_modes(train, coast=True)


def sequences(modes: int, horizon: int) -> int:
    """The switching sequences a sample enumerates over ``modes`` modes and a horizon of N steps,
    before pruning: modes^N (the first sample's handle held over its pieces, then a mode a step).
    Each is predicted step by step, a prefix shared by the sequences that extend it, so a sample
    makes m + m^2 + ... + m^N predictions (about 1.2 m^N for six modes); a prefix that leaves X
    drops every sequence that extends it (no bound on the cost prunes one)."""
    return int(modes ** horizon)


def sequence(train: Train) -> list["Mode"]:
    """The phase sequence of every sector (module docstring): a leading coast, then all modes; a
    train whose ``das_handle_levels`` have no 0 has no coast phase at all."""
    return [md for md in all_modes(train) if md.kind == "coast"] + all_modes(train)


@dataclass(frozen=True)
class Sector:
    start: float   # [m]
    end: float     # [m]
    force: float   # gradient + curve force, constant over the sector [N]
    limit: float   # speed limit of the head [m/s]

    @property
    def length(self) -> float:
        return self.end - self.start


def sectors(segment: Segment, train: Train) -> list[Sector]:
    """Sectors between consecutive profile changes (constant gradient, curvature and limit)."""
    warn_unmodelled(segment, "the phases NLP", train)
    edges = np.concatenate([[0.0], segment.breakpoints(), [segment.distance]])
    out: list[Sector] = []
    for a, b in zip(edges[:-1], edges[1:]):
        mid = 0.5 * (a + b)
        force = point_resistance(segment, train, mid)
        out.append(Sector(float(a), float(b), float(force), float(segment.limit(mid))))
    return out


def sector_at(secs: Sequence[Sector], x: float) -> int:
    """Index of the sector that holds position ``x`` [m] (the last one for its end)."""
    return next((s for s, sec in enumerate(secs) if x < sec.end), len(secs) - 1)


def rolls_from_rest(sector: Sector, train: Train) -> bool:
    """Whether the train, coasting from standstill, gathers speed in ``sector``: its descent pulls harder
    than the resistance at rest (Davis A). There the first sector may begin with a coast (a descent's
    optimum: coast from rest, then hold the limit); elsewhere a coast at rest stays at rest."""
    return sector.force + train.davis[0] < 0


@dataclass
class Layout:
    """The phases in travel order: ``phases[q]`` = (sector index, mode); interval i is sub-step
    i % n of phase i // n. The first sector has no leading coast where the train does not roll from
    rest (:func:`rolls_from_rest`): at standstill it would leave only degenerate constraints (v = 0
    on both sides of every step). ``modes`` is a sector's
    sequence (:func:`sequence`)."""

    sectors: list[Sector]
    phases: list[tuple[int, Mode]]
    substeps: int

    @classmethod
    def make(cls, sectors: list[Sector], modes: Sequence[Mode], substeps: int, train: Train | None = None) -> "Layout":
        """The ``modes`` in every sector; the first sector's leading coast only where the ``train``
        (given) rolls from rest there (:func:`rolls_from_rest`)."""
        first = train is not None and rolls_from_rest(sectors[0], train)
        phases = [(s, mode) for s in range(len(sectors)) for p, mode in enumerate(modes)
                  if s > 0 or p > 0 or mode.kind != "coast" or first]
        return cls(sectors, phases, substeps)

    @property
    def intervals(self) -> int:
        return len(self.phases) * self.substeps

    def owner(self, i: int) -> tuple[int, int, Mode]:
        """(phase index q, sector index, mode) of interval i."""
        q = i // self.substeps
        return (q, *self.phases[q])

    def node_limits(self) -> FloatArray:
        """Limit of each node: the lower one of the sectors of the intervals on its two sides."""
        lim = np.array([self.sectors[self.owner(i)[1]].limit for i in range(self.intervals)], float)
        return np.asarray(np.minimum(np.append(lim, lim[-1]), np.insert(lim, 0, lim[0])), float)


def substeps_for(points: int, n_phases: int, least: int = 4) -> int:
    """Sub-steps per phase so that the whole run has about ``points`` intervals."""
    return max(least, int(round(points / n_phases)))


@space.gc_paused
def build(segment: Segment, train: Train, layout: Layout,
          guess: tuple[Sequence[float] | FloatArray, Sequence[float] | FloatArray],
          running_time: float | None = None, window: tuple[float, float] | None = None, objective: str = "energy",
          extend: Callable[[Model, Layout, Train], None] | None = None, movable: bool = False) -> Model:
    """The phases NLP of ``layout`` (or, with ``extend``, e.g. the mode-choice MINLP of ``ocp/modechoice.py``).

    ``guess`` = (phase lengths [m], node speeds [m/s]); times follow from them. A ``movable``
    model holds the standstill at both ends by bounds and fills each sector to a share of its
    length (bounds 1) from a start clock t0 (bounds 0), so ``ocp.restart.set_phases_start`` can
    re-plan from any state: the sectors behind the start get share 0 (their phases length 0).
    """
    secs, n, N = layout.sectors, layout.substeps, layout.intervals
    lengths, v0 = guess
    M = train.mass
    per_kg, km = tuple(float(x / M) for x in train.davis), float(FORCE_SCALE / M)
    m = pyo.ConcreteModel(name="ecostudy_das_phases")
    m.Q, m.S = pyo.RangeSet(0, len(layout.phases) - 1), pyo.RangeSet(0, len(secs) - 1)
    m.I, m.K = pyo.RangeSet(0, N - 1), pyo.RangeSet(0, N)
    m.L = pyo.Var(m.Q, bounds=lambda m, q: (0.0, secs[layout.phases[q][0]].length),
                  initialize=lambda m, q: float(np.clip(lengths[q], 0.0, secs[layout.phases[q][0]].length)))
    if movable:
        m.share = pyo.Var(m.S, bounds=(1.0, 1.0), initialize=1.0)
        m.t0 = pyo.Var(bounds=(0.0, 0.0), initialize=0.0)
    m.sector_length = pyo.Constraint(m.S, rule=lambda m, s: sum(
        m.L[q] for q in m.Q if layout.phases[q][0] == s) / secs[s].length == (m.share[s] if movable else 1.0))
    limits = layout.node_limits()
    m.v = pyo.Var(m.K, bounds=lambda m, k: (0.0, float(limits[k])), initialize=lambda m, k: float(np.clip(v0[k], 0.0, limits[k])))
    for k in (0, N):
        if movable:
            m.v[k].setub(0.0)
        else:
            m.v[k].fix(0.0)
    ds = {i: m.L[i // n] / n for i in range(N)}
    h = {s: sec.length / n for s, sec in enumerate(secs)}  # reference step [m]
    dt0 = [2 * float(lengths[i // n]) / n / max(v0[i] + v0[i + 1], 0.5) for i in range(N)]
    m.dt = pyo.Var(m.I, bounds=(0.0, None), initialize=lambda m, i: dt0[i])
    m.ft = pyo.Var(m.I, bounds=(0.0, train.traction.peak / FORCE_SCALE), initialize=0.0)
    m.fb = pyo.Var(m.I, bounds=(0.0, train.braking.peak / FORCE_SCALE), initialize=0.0)

    def accel(i: int, v_a: Numeric, v_b: Numeric) -> Numeric:
        """Mean acceleration over an interval [m/s^2] (physics.interval_resistance, as ocp.space)."""
        return km * (m.ft[i] - m.fb[i]) - interval_resistance(v_a, v_b, per_kg, secs[layout.owner(i)[1]].force / M)

    m.accel = accel
    m.speed = pyo.Constraint(m.I, rule=lambda m, i: (
        m.v[i + 1] ** 2 - m.v[i] ** 2 - 2 * ds[i] * accel(i, m.v[i], m.v[i + 1])) / (2 * h[layout.owner(i)[1]]) == 0.0)
    m.time = pyo.Constraint(m.I, rule=lambda m, i: (
        m.dt[i] * (m.v[i] + m.v[i + 1]) - 2 * ds[i]) / (2 * h[layout.owner(i)[1]]) == 0.0)
    def mean(envelope: Envelope, i: int) -> Numeric:
        return 0.5 * (envelope.smooth_force(m.v[i]) + envelope.smooth_force(m.v[i + 1])) / FORCE_SCALE

    m.mean_t = {i: mean(train.traction, i) for i in range(N)}
    m.mean_b = {i: mean(train.braking, i) for i in range(N)}
    if extend is not None:  # a variant passed in: the mode-choice MINLP (ocp.modechoice)
        extend(m, layout, train)
    else:
        _fixed_modes(m, layout)
    bounds = (running_time, running_time) if running_time is not None else window
    if bounds is None:
        raise ValueError("the phases NLP needs a running time or an arrival window")
    m.T = pyo.Var(bounds=bounds, initialize=float(np.clip(np.sum(dt0), *bounds)))
    t_ref = m.time_ref = max(running_time or bounds[1], 1.0)
    clock = m.t0 if movable else 0.0
    m.arrival = pyo.Constraint(expr=(sum(m.dt[i] for i in m.I) + clock - m.T) / t_ref == 0.0)
    _objective(m, train, segment, layout, ds, objective)
    if movable:  # what a re-plan restores (ocp.restart.set_phases_start)
        m.base_bounds = {"v": [(0.0, float(limits[k])) for k in m.K]}
    return m


def _fixed_modes(m: Model, layout: Layout) -> None:
    """Each phase's own mode, exact inside it (module docstring).

    Cruise replaces the speed recursion's content by its meaning: v_{k+1} = v_k and the force
    balances the resistance, so the force is defined even for a phase of zero length.
    """
    m.mode = pyo.ConstraintList()
    for i in range(layout.intervals):
        mode = layout.owner(i)[2]
        if mode.kind == "traction":
            m.fb[i].fix(0.0)
            m.mode.add(m.ft[i] == mode.level * m.mean_t[i])
        elif mode.kind == "coast":
            m.ft[i].fix(0.0)
            m.fb[i].fix(0.0)
        elif mode.kind == "brake":  # at its level of the braking envelope (-1: full service braking)
            m.ft[i].fix(0.0)
            m.mode.add(m.fb[i] == -mode.level * m.mean_b[i])
        else:
            m.speed[i].deactivate()
            m.mode.add(m.v[i + 1] == m.v[i])
            m.mode.add(m.accel(i, m.v[i], m.v[i]) == 0.0)
            m.mode.add(m.ft[i] <= m.mean_t[i])
            m.mode.add(m.fb[i] <= m.mean_b[i])


def _objective(m: Model, train: Train, segment: Segment, layout: Layout, ds: dict[int, Any], objective: str) -> None:
    """Traction work (Farooqi 2018 eq. 2.16) or net energy (eq. 7.3) over an O(1) reference, or the
    arrival time (with the work as a tie-break, as ``space.define_objective`` does), or the speed at
    the end (with the arrival time as one)."""
    e_ref = m.energy_ref = energy_reference(train, segment)
    N = layout.intervals
    work = FORCE_SCALE * sum(m.ft[i] * ds[i] for i in range(N))
    m.traction_work = pyo.Expression(expr=work)
    if objective == "energy":
        expr = work / e_ref
    elif objective == "net_energy":
        regen: Numeric = 0.0
        if train.regeneration is not None:
            cap = {i: 0.5 * (train.regeneration.smooth_force(m.v[i])
                             + train.regeneration.smooth_force(m.v[i + 1])) / FORCE_SCALE for i in range(N)}
            width = 0.01 * train.braking.peak / FORCE_SCALE
            regen = FORCE_SCALE * sum(smooth_min(m.fb[i], cap[i], width) * ds[i] for i in range(N))
        expr = (work / train.traction_efficiency - train.regeneration_efficiency * regen) / e_ref
    elif objective == "time":  # the earliest arrival; work breaks ties
        expr = m.T / m.time_ref + space.TIME_REGULARISATION * work / e_ref
    elif objective == "end_speed":  # the slowest arrival at the end [m/s] (SPPC's relaxed step one), and
        expr = m.v[N] + 1e-2 * m.T / m.time_ref  # among those the earliest (a free clock would crawl)
    else:
        raise ValueError(f"DAS runs minimise energy, net_energy, time or end_speed, not {objective!r}")
    m.objective = pyo.Objective(expr=expr, sense=pyo.minimize)


def node_positions(layout: Layout, lengths: Sequence[float] | FloatArray, origin: float = 0.0) -> FloatArray:
    """Positions of every node of the layout for given phase lengths [m]; ``origin``: where a
    re-plan starts (the sectors behind it have phases of length 0, their nodes sit there)."""
    n = layout.substeps
    pos, start = [float(origin)], float(origin)
    for q, (s, _) in enumerate(layout.phases):
        if q == 0 or layout.phases[q - 1][0] != s:
            start = max(layout.sectors[s].start, origin)
        step = lengths[q] / n
        pos.extend(start + step * (j + 1) for j in range(n))
        start += lengths[q]
    return np.array(pos)


def speeds_at(layout: Layout, lengths: Sequence[float] | FloatArray, x: FloatArray, v: FloatArray) -> FloatArray:
    """ATO speeds interpolated at the layout's nodes; zero at both ends."""
    out = np.interp(node_positions(layout, lengths), x, v)
    out = np.minimum(out, layout.node_limits())
    out[0] = out[-1] = 0.0
    return out


def active(layout: Layout, lengths: Sequence[float] | FloatArray, modes: Sequence[Mode],
           points: int) -> tuple[Layout, FloatArray]:
    """Layout of the phases at least ``MIN_PHASE`` long (each sector keeps its longest one), with
    ``modes[q]`` as the mode of phase q, on a sub-grid of about ``points`` intervals in all; and
    the kept lengths, scaled to fill their sectors. Refining on the phases actually driven puts
    the whole grid where the modes are (and no driver is told to change mode for centimetres)."""
    keep: list[int] = []
    for s in range(len(layout.sectors)):
        mine = [q for q, (owner, _) in enumerate(layout.phases) if owner == s]
        long_ = [q for q in mine if lengths[q] >= MIN_PHASE]
        keep.extend(long_ or [max(mine, key=lambda q: lengths[q])])
    out = Layout(layout.sectors, [(layout.phases[q][0], modes[q]) for q in keep],
                 substeps_for(points, len(keep), least=8))
    kept = np.asarray(lengths, float)[keep]
    for s, sec in enumerate(layout.sectors):
        mine = [k for k, (owner, _) in enumerate(out.phases) if owner == s]
        kept[mine] *= sec.length / max(kept[mine].sum(), 1e-9)
    return out, kept


def solution(m: Model, layout: Layout) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """(phase lengths [m], node positions, speeds, interval times, F_T [N], F_B [N])."""
    # the values as stored (``pyo.value`` gives the same numbers, at 3.3 of 58 CPU s of an SPPC run)
    lengths = np.array([m.L[q].value for q in m.Q], float)
    v = np.array([m.v[k].value for k in m.K], float)
    dt = np.array([m.dt[i].value for i in m.I], float)
    ft = np.array([m.ft[i].value for i in m.I], float) * FORCE_SCALE
    fb = np.array([m.fb[i].value for i in m.I], float) * FORCE_SCALE
    return lengths, node_positions(layout, lengths), v, dt, ft, fb
