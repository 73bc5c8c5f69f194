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
