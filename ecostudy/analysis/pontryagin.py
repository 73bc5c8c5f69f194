"""Pontryagin regime check: does a profile obey the switching conditions of Farooqi 2018 eq. 2.17
(eq. 7.4 when regenerated energy is credited)?

The costate of the speed dynamics is estimated from the multipliers mu_k of the discretised
speed recursion (model.speed). Stationarity of the Lagrangian in the traction force of
interval k reads  ds_k / (eta_T E_ref) - mu_k (kN / M) + (bound and envelope multipliers) = 0,
so

    psi_k = mu_k (kN / M) eta_T E_ref / (ds_k kN)

is the discrete lambda / v of eq. 2.17 (lambda / K of eq. 7.4), normalised so that partial
traction sits at psi = 1 (eta_T = 1 for the traction-energy objective).

Traction energy (eq. 2.17): MA where psi > 1, CR where psi = 1, CO where 0 < psi < 1, CR2
(partial braking) where psi = 0, MB where psi < 0.

Net energy (eq. 7.4, objective W_T / eta_T - eta_R W_R): one newton of electric braking earns
eta_R per unit of work, eta = eta_T eta_R in psi units, so CO needs eta < psi < 1 and RB, braking
the electric brake takes whole, needs psi = eta. The thesis' electric brake takes any braking;
ecostudy's has its own envelope with friction on top, which adds two cases: electric braking
at its own limit without friction needs 0 <= psi <= eta, and friction (CR2, or MB beyond the
electric limit) needs psi = 0 (psi <= 0 at MB). Maximum braking taken whole by the electric
brake is eq. 7.4's MB: psi <= eta.

The multipliers are Ipopt's (Pyomo's dual suffix equals Ipopt's y: grad f + J^T y - z_L + z_U = 0),
or fitted at any profile by :func:`estimated_psi`.
"""

import numpy as np
import pyomo.core as pyo  # not pyomo.environ: see ocp.solver.prepare
from scipy.sparse import hstack, identity

from ecostudy.analysis import regimes
from ecostudy.core.units import KWH
from ecostudy.io.results import on_grid
from ecostudy.ocp import space
from ecostudy.ocp.problem import build, prepare
from ecostudy.ocp.session import Session, solve

INF = np.inf


def psi_bounds(labels, eta=0.0, capped=None, friction=None):
    """[lower, upper] of psi that each interval's regime requires (eqs. 2.17 and 7.4).

    eta       eta_T eta_R, the worth of regenerated work in psi units (0: none credited)
    capped    per interval: the electric brake is at its own limit
    friction  per interval: friction brakes carry part of the braking force
    """
    n = len(labels)
    capped = np.zeros(n, bool) if capped is None else np.asarray(capped)
    friction = np.ones(n, bool) if friction is None else np.asarray(friction)
    table = {"MA": (1.0, INF), "CR": (1.0, 1.0), "CO": (eta, 1.0), "CR2": (0.0, 0.0)}
    lo, hi = np.empty(n), np.empty(n)
    for i, label in enumerate(labels):
        if label == "RB":
            lo[i], hi[i] = (0.0 if capped[i] else eta), eta
        elif label == "MB":
            lo[i], hi[i] = -INF, (0.0 if friction[i] else eta)
        else:
            lo[i], hi[i] = table[label]
    return lo, hi


def psi_from_multipliers(mu, nodes, train, energy_ref, traction_efficiency=1.0):
    """psi_k = lambda / v per interval from the speed-recursion multipliers (Ipopt's y, = Pyomo's dual)."""
    ds = np.diff(nodes)
    return (np.asarray(mu) * (space.FORCE_SCALE / train.mass) * energy_ref * traction_efficiency
            / (ds * space.FORCE_SCALE))


def ipopt_psi(m, nodes, train, objective="energy"):
    """psi from the multipliers Ipopt returned for a solved model (energy or net-energy objective)."""
    eta_t = train.traction_efficiency if objective == "net_energy" else 1.0
    return psi_from_multipliers([m.dual[m.speed[k]] for k in m.I], nodes, train, m.energy_ref, eta_t)


def regime_bounds(train, v, ft, fb, labels, objective="energy"):
    """:func:`psi_bounds` for a profile: eta and the electric brake's state read off the forces."""
    if objective != "net_energy" or train.regeneration is None:
        return psi_bounds(labels)
    limit = regimes.regenerative_limit(train, v)
    electric = np.minimum(fb, limit)
    scale = np.maximum(train.braking.peak, 1.0)
    return psi_bounds(labels, train.traction_efficiency * train.regeneration_efficiency,
                      capped=electric >= limit - 0.01 * scale, friction=fb - electric > 0.01 * scale)


def check(nodes, labels, psi, tolerance=0.02, bounds=None):
    """Agreement of each interval's regime with psi, the regime runs, and the disagreements.

    ``bounds``: (lower, upper) psi per interval, default :func:`psi_bounds` of the labels (eq. 2.17).
    """
    lo, hi = psi_bounds(labels) if bounds is None else bounds
    agree = (psi >= lo - tolerance) & (psi <= hi + tolerance)
    ds = np.diff(nodes)
    bad = []
    for label, start, end in regimes.runs(np.where(agree, "ok", labels), nodes):
        if label != "ok":
            sel = (nodes[:-1] >= start) & (nodes[:-1] < end)
            bad.append({"regime": label, "start_m": start, "end_m": end,
                        "psi_min": float(psi[sel].min()), "psi_max": float(psi[sel].max())})
    return {"agreement_pct": float(100 * ds[agree].sum() / ds.sum()),
            "intervals_agreeing_pct": float(100 * agree.mean()),
            "sequence": [{"regime": r, "start_m": a, "end_m": b} for r, a, b in regimes.runs(labels, nodes)],
            "disagreements": bad, "tolerance": tolerance}


def costate_check(train, nodes, v, ft, fb, labels, psi, objective):
    """:func:`check` of ``psi`` against the regimes ``labels`` of a run of ``objective`` (the bounds
    its forces give, :func:`regime_bounds`), as its solve, ``ecostudy check`` and the saved run
    judged again check it."""
    return check(nodes, labels, psi, tolerance=0.02, bounds=regime_bounds(train, v, ft, fb, labels, objective))


TIMING_TOLERANCE = 1e-5  # [-]: an arrival or passing time this near its bound binds (profile.csv's 6 digits)


def estimated_psi(m, nodes, train, tolerance=1e-2):
    """psi at the point loaded in ``m`` (any profile): multipliers from a sign-constrained fit.

    The first-order conditions grad f + J^T y - z_L + z_U = 0 are fitted in the least-squares
    sense over the equality constraints, the active inequalities (y >= 0 at an active upper
    bound, <= 0 at a lower one) and the active variable bounds (z >= 0); the signs pin the
    costate, which the state rows alone leave free. The fit is a convex QP, solved by Ipopt.
    A row or bound counts as active within ``tolerance`` of it (relative, at least 1), the arrival
    time's bound and the timing windows' rows within :data:`TIMING_TOLERANCE` only: a run that
    arrives 0.6 s before the time it is checked for has time to spare, and is not the optimum.
    Returns (psi, relative stationarity residual, residual per speed node, dE/dT [J/s]: the fitted
    multiplier of the arrival row, as ``space.marginal_energy`` reads Ipopt's).
    """

    nlp = Session(m).nlp
    grad = nlp.evaluate_grad_objective()
    jac = nlp.evaluate_jacobian().tocsr()
    c, lb, ub = nlp.evaluate_constraints(), nlp.constraints_lb(), nlp.constraints_ub()
    scale = np.full(len(c), tolerance) * np.maximum(1.0, np.abs(c))
    if hasattr(m, "windows") and len(m.windows):
        timing = nlp.get_constraint_indices(list(m.windows.values()))
        scale[timing] *= TIMING_TOLERANCE / tolerance
    equal = lb == ub
    at_ub = ~equal & (np.abs(c - ub) <= scale)
    at_lb = ~equal & (np.abs(c - lb) <= scale)
    rows = np.nonzero(equal | at_ub | at_lb)[0]
    x, xl, xu = nlp.get_primals(), nlp.primals_lb(), nlp.primals_ub()
    near = tolerance * np.maximum(1.0, np.abs(x))
    if hasattr(m, "T"):
        near[nlp.get_primal_indices([m.T])] *= TIMING_TOLERANCE / tolerance
    fixed = xl == xu
    lower = np.nonzero(~fixed & (np.abs(x - xl) <= near))[0]
    upper = np.nonzero(~fixed & (np.abs(x - xu) <= near))[0]
    free = np.nonzero(fixed)[0]
    eye = identity(len(x), format="csc")
    a = hstack([jac[rows].T, -eye[:, lower], eye[:, upper], eye[:, free]]).tocsr()
    lo = np.concatenate([np.where(equal[rows] | at_lb[rows], None, 0.0), [0.0] * (len(lower) + len(upper)),
                         [None] * len(free)])
    hi = np.concatenate([np.where(equal[rows] | at_ub[rows], None, 0.0), [None] * (len(lower) + len(upper) + len(free))])
    norm = max(float(np.linalg.norm(grad)), 1e-12)
    qp = pyo.ConcreteModel()
    qp.y = pyo.Var(range(a.shape[1]), bounds=lambda q, i: (lo[i], hi[i]), initialize=0.0)
    qp.fit = pyo.Objective(expr=sum(
        ((grad[j] + sum(a.data[p] * qp.y[a.indices[p]] for p in range(a.indptr[j], a.indptr[j + 1]))) / norm) ** 2
        for j in range(a.shape[0])))
    solve(qp)
    y = np.array([pyo.value(qp.y[i]) for i in range(a.shape[1])])
    residual = a @ y + grad
    multipliers = np.zeros(len(c))
    multipliers[rows] = y[:len(rows)]
    speed_rows = nlp.get_constraint_indices([m.speed[k] for k in m.I])
    v_cols = nlp.get_primal_indices([m.v[k] for k in m.K if not m.v[k].fixed])
    arrival = multipliers[nlp.get_constraint_indices([m.arrival])[0]]
    return (psi_from_multipliers(multipliers[speed_rows], nodes, train, m.energy_ref),
            float(np.linalg.norm(residual) / norm), np.abs(residual[v_cols]) / norm,
            space.marginal_energy_of(arrival, m))


def check_profile(track, train, inputs, trajectory, running_time=None, tolerance=1e-2, objective="energy",
                  where="profile.csv", case=None):
    """Regime check of a result's :class:`~ecostudy.core.types.Trajectory` as the energy-optimal run
    for ``running_time``; ``inputs`` names the stops and the grid size (``inputs.json``).

    ``running_time`` None: the profile's own time, fixed. Given: arrive by then (a window), so a
    profile that arrives earlier than it needs to is tested as what it is offered as.
    ``objective``: ``energy`` (eq. 2.17) or ``net_energy`` (eq. 7.4, regeneration credited).
    ``where`` names the profile in the refusal of positions off the grid; ``case``: the run's prepared
    case (with its timing windows, whose nodes are on its grid), else prepared from ``inputs``.
    """
    case = case if case is not None else prepare(track, train, inputs["from"], inputs["to"], inputs["points"])
    on_grid(trajectory, case.nodes, inputs, where)
    x, v, dt, ft, fb = trajectory
    own = float(dt.sum())
    timing = {"running_time": own} if running_time is None else {"window": (0.0, float(running_time))}
    m = build(case, (v, dt, ft, fb), objective, {}, **timing)
    if hasattr(m, "fr"):  # the electric brake takes what it can of the profile's braking
        for k, f in enumerate(np.minimum(fb, regimes.regenerative_limit(train, v))):
            m.fr[k].set_value(float(f) / space.FORCE_SCALE)
    psi, residual, _, marginal = estimated_psi(m, case.nodes, train, tolerance)
    psi = psi * (train.traction_efficiency if objective == "net_energy" else 1.0)
    labels = regimes.labelled(train, v, ft, fb, objective)
    out = costate_check(train, case.nodes, v, ft, fb, labels, psi, objective)
    kind = ("net-energy-optimal (Farooqi 2018, eq. 7.4)" if objective == "net_energy"
            else "energy-optimal (Farooqi 2018, eq. 2.17)")
    out.update(method="multipliers fitted at the profile (sign-constrained least squares)",
               stationarity_residual=residual, profile_running_time_s=own,
               marginal_energy_kWh_per_s=marginal / KWH if running_time is None else None,
               checked_as=f"{kind} run for " + (f"{own:.2f} s (its own time)" if running_time is None
                                                 else f"arrival by {running_time:.2f} s"))
    return out, psi


