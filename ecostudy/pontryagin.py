"""Pontryagin regime check: does a profile obey the switching conditions of thesis 000 eq. 2.17?

The costate of the speed dynamics is estimated from the multipliers mu_k of the discretised
speed recursion (model.speed). Stationarity of the Lagrangian in the traction force of
interval k reads  ds_k / E_ref - mu_k (kN / M) + (bound and envelope multipliers) = 0,  so

    psi_k = mu_k (kN / M) E_ref / (ds_k kN)

is the discrete lambda / v of eq. 2.17 (traction energy objective): maximum acceleration where
psi > 1 (MA), partial traction only where psi = 1 (CR), coasting where 0 < psi < 1 (CO),
partial braking where psi = 0 (CR2), maximum braking where psi < 0 (MB).

The multipliers are Ipopt's (Pyomo's dual suffix equals Ipopt's y: grad f + J^T y - z_L + z_U = 0).
Checking a profile that is not an NLP optimum needs multipliers estimated at that point; that
estimate is not built yet (see the closing note of issue 3).
"""
import numpy as np

from . import model as formulation
from . import regimes

RULES = {  # regime -> test on psi (tolerance t)
    "MA": lambda p, t: p >= 1 - t,
    "CR": lambda p, t: abs(p - 1) <= t,
    "CO": lambda p, t: -t <= p <= 1 + t,
    "CR2": lambda p, t: abs(p) <= t,
    "MB": lambda p, t: p <= t,
}


def psi_from_multipliers(mu, nodes, train, energy_ref):
    """psi_k = lambda / v per interval from the speed-recursion multipliers (Ipopt's y, = Pyomo's dual)."""
    ds = np.diff(nodes)
    return np.asarray(mu) * (formulation.KN / train.mass) * energy_ref / (ds * formulation.KN)


def ipopt_psi(m, nodes, train):
    """psi from the multipliers Ipopt returned for a solved model (traction-energy objective)."""
    return psi_from_multipliers([m.dual[m.speed[k]] for k in m.I], nodes, train, m.energy_ref)


def check(nodes, labels, psi, tolerance=0.02):
    """Agreement of each interval's regime with psi, the regime runs, and the disagreements."""
    agree = np.array([RULES[label](p, tolerance) for label, p in zip(labels, psi)])
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


def estimated_psi(m, nodes, train, tolerance=1e-2):
    """psi at the point loaded in ``m`` (any profile): multipliers from a sign-constrained fit.

    The first-order conditions grad f + J^T y - z_L + z_U = 0 are fitted in the least-squares
    sense over the equality constraints, the active inequalities (y >= 0 at an active upper
    bound, <= 0 at a lower one) and the active variable bounds (z >= 0); the signs pin the
    costate, which the state rows alone leave free. The fit is a convex QP, solved by Ipopt.
    Returns (psi, relative stationarity residual, residual per speed node).
    """
    import pyomo.environ as pyo
    from scipy.sparse import hstack, identity

    from .solver import Session, solve
    nlp = Session(m).nlp
    grad = nlp.evaluate_grad_objective()
    jac = nlp.evaluate_jacobian().tocsr()
    c, lb, ub = nlp.evaluate_constraints(), nlp.constraints_lb(), nlp.constraints_ub()
    scale = np.maximum(1.0, np.abs(c))
    equal = lb == ub
    at_ub = ~equal & (np.abs(c - ub) <= tolerance * scale)
    at_lb = ~equal & (np.abs(c - lb) <= tolerance * scale)
    rows = np.nonzero(equal | at_ub | at_lb)[0]
    x, xl, xu = nlp.get_primals(), nlp.primals_lb(), nlp.primals_ub()
    near = tolerance * np.maximum(1.0, np.abs(x))
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
    return (psi_from_multipliers(multipliers[speed_rows], nodes, train, m.energy_ref),
            float(np.linalg.norm(residual) / norm), np.abs(residual[v_cols]) / norm)


def check_profile(track, train, inputs, profile, running_time=None, tolerance=1e-2):
    """Regime check of a result's profile as the energy-optimal run for ``running_time``.

    ``running_time`` None: the profile's own time, fixed. Given: arrive by then (a window), so a
    profile that arrives earlier than it needs to is tested as what it is offered as.
    """
    from .run import build, prepare
    from .units import KMH, KN
    case = prepare(track, train, inputs["from"], inputs["to"], inputs["points"])
    x = profile["position_m"].to_numpy()
    if len(x) != len(case.nodes) or not np.allclose(x, case.nodes, atol=1e-3):
        raise ValueError("the profile's positions differ from the grid rebuilt from inputs.json")
    v = profile["speed_kmh"].to_numpy() * KMH
    dt = np.diff(profile["time_s"].to_numpy())
    ft = profile["traction_force_kN"].to_numpy()[:-1] * KN
    fb = profile["braking_force_kN"].to_numpy()[:-1] * KN
    own = float(dt.sum())
    timing = {"running_time": own} if running_time is None else {"window": (0.0, float(running_time))}
    m = build(case, (v, dt, ft, fb), "energy", {}, **timing)
    psi, residual, _ = estimated_psi(m, case.nodes, train, tolerance)
    labels = regimes.classify(train, v, ft, fb)
    out = check(case.nodes, labels, psi, tolerance=0.02)
    out.update(method="multipliers fitted at the profile (sign-constrained least squares)",
               stationarity_residual=residual, profile_running_time_s=own,
               checked_as="energy-optimal run for " + (f"{own:.2f} s (its own time)" if running_time is None
                                                       else f"arrival by {running_time:.2f} s"))
    return out, psi


def check_result(result_dir, running_time=None):
    """:func:`check_profile` of an `ecostudy solve` output folder (inputs.json and profile.csv)."""
    import json
    from pathlib import Path

    import pandas as pd

    from .errors import InputError, problem
    from .inputs import load_track, load_train
    result_dir = Path(result_dir)
    try:
        inputs = json.loads((result_dir / "inputs.json").read_text())
        profile = pd.read_csv(result_dir / "profile.csv")
    except (OSError, ValueError) as exc:
        raise InputError(problem(result_dir, "", f"not a result folder of `ecostudy solve` ({exc})"))
    return check_profile(load_track(inputs["track"]), load_train(inputs["train"]), inputs, profile, running_time)[0]
