"""Driving regimes of a profile, read off the control (Farooqi 2018 eqs. 2.15, 2.17, 7.2, 7.4).

Each interval is classified by where its forces sit against the envelopes that bind them in
the NLP (a table the lower of its values at the interval's two ends, a power limit at its mean speed):

MA   maximum acceleration: traction on its envelope
CR   partial traction (cruising, or holding a limit uphill)
CO   coasting: no traction, no braking
CR2  partial braking (holding a limit downhill)
MB   maximum braking: braking on its envelope
RB   regenerative braking (only when regeneration is credited): braking below the envelope and
     all of it taken by the electric brake, no friction (eq. 7.4)

A switch that falls inside an interval shows as one interval of partial force between two
other regimes, or, where maximum traction meets cruising, as one interval of coasting; such
single transitional intervals are merged into the run before them.

A share within :data:`TIE` of a threshold is a tie: the interval keeps the side of that threshold
the interval before it is on (hysteresis), so a cruise that needs just the threshold's share is one
run whatever its last digits, in the solve's unrounded forces as in profile.csv's six digits.
"""
import numpy as np

from ecostudy.ocp import phases, space

REGIMES = ("MA", "CR", "CO", "RB", "CR2", "MB")
TIE = 1e-3  # share of the envelope [-] within which a share sits on its threshold (see the module's doc)


def _lower_end(envelope, v0, v1):
    """The envelope of the interval as the NLP binds it [N] (``ocp.space.interval_envelope``: a table
    at the interval's lower end, a power limit at its mean speed)."""
    return np.maximum(space.interval_envelope(envelope, v0, v1), 1e-9)


def regenerative_limit(train, v):
    """Electric-brake limit per interval [N] (zero without an electric brake)."""
    if train.regeneration is None:
        return np.zeros(len(v) - 1)
    return _lower_end(train.regeneration, v[:-1], v[1:])


def above(share, threshold):
    """Per interval, whether ``share`` is above ``threshold``: a share within :data:`TIE` of it takes
    the answer of the interval before (the first interval: its plain comparison)."""
    side = np.where(share > threshold + TIE, 1, np.where(share < threshold - TIE, -1, 0))
    if len(side):
        side[0] = side[0] or (1 if share[0] > threshold else -1)
    last = np.maximum.accumulate(np.where(side != 0, np.arange(len(side)), 0))
    return side[last] > 0


def classify(train, v, ft, fb, tolerance=0.01, regeneration=False):
    """Regime label per interval from speeds at the nodes and forces per interval [N].

    ``regeneration``: the run credits regenerated energy, so braking that the electric brake
    takes whole (friction share below ``tolerance``) is RB unless it is maximum braking.
    """
    v0, v1 = v[:-1], v[1:]
    t_max, b_max = _lower_end(train.traction, v0, v1), _lower_end(train.braking, v0, v1)
    t_share, b_share = (ft - fb).clip(0) / t_max, (fb - ft).clip(0) / b_max
    labels = np.full(len(ft), "CO", dtype=object)
    labels[above(t_share, tolerance)] = "CR"
    labels[above(t_share, 1 - tolerance)] = "MA"
    labels[above(b_share, tolerance)] = "CR2"
    if regeneration:
        friction = (fb - np.minimum(fb, regenerative_limit(train, v))) / b_max
        labels[above(b_share, tolerance) & ~above(friction, tolerance)] = "RB"
    labels[above(b_share, 1 - tolerance)] = "MB"
    return labels


def runs(labels, nodes):
    """[(regime, start_m, end_m)] with transitional single intervals merged into the run before."""
    out = []
    for i, label in enumerate(labels):
        if out and out[-1][0] == label:
            out[-1][2] = i + 1
        else:
            out.append([label, i, i + 1])
    merged = []
    for j, (label, i0, i1) in enumerate(out):
        single = i1 - i0 == 1 and 0 < j < len(out) - 1
        transitional = single and (
            (label in ("CR", "CR2", "RB") and merged[-1][0] != out[j + 1][0])
            or (label == "CO" and {merged[-1][0], out[j + 1][0]} == {"MA", "CR"}))
        if merged and (transitional or merged[-1][0] == label):
            merged[-1][2] = i1
        else:
            merged.append([label, i0, i1])
    return [(label, float(nodes[i0]), float(nodes[i1])) for label, i0, i1 in merged]


def labelled(train, v, ft, fb, objective):
    """:func:`classify` as a run of ``objective`` is labelled: RB where a net-energy run's train
    regenerates (eq. 7.4), else eq. 2.17's regimes. Its solve, ``ecostudy check`` and the saved run
    judged again label it so."""
    return classify(train, v, ft, fb, regeneration=objective == "net_energy" and train.regeneration is not None)


def block(labels, nodes):
    """``summary.json``'s ``regimes``: the sequence, the distance shares, the runs."""
    regime_runs = runs(labels, nodes)
    return {"sequence": sequence_text(regime_runs), "distance_shares": distance_shares(labels, nodes),
            "runs": [{"regime": r, "start_m": a, "end_m": b} for r, a, b in regime_runs]}


def sequence_text(run_list):
    """'MA-CR-CO-MB' from :func:`runs`."""
    return "-".join(label for label, _, _ in run_list)


def distance_shares(labels, nodes):
    """Share of the distance spent in each regime [-]."""
    ds = np.diff(nodes)
    total = ds.sum()
    return {r: float(ds[labels == r].sum() / total) for r in REGIMES}


def guess_from_result(result, layout):
    """Phase lengths and node speeds of an ``ocp.phases`` layout from an ATO ``result`` (its regimes,
    sector by sector): the start of the DAS phases NLP and of SPPC.

    MA intervals go to full traction, CR/CR2 to cruise, MB to braking, coasting to the leading
    coast before the sector's first traction and to the trailing coast after it (to cruise in a
    layout without coast phases); partial braking that lets the train gather speed before the
    sector's first traction (a zero-energy run down a grade, one of many) to the leading coast.
    """
    x, v, ft, fb = result.nodes, result.trajectory.v, result.trajectory.ft, result.trajectory.fb
    labels = classify(result.train, v, ft, fb)
    mid = 0.5 * (x[:-1] + x[1:])
    lengths = np.zeros(len(layout.phases))
    for s, sec in enumerate(layout.sectors):
        mine = [q for q, (owner, _) in enumerate(layout.phases) if owner == s]
        kinds = [layout.phases[q][1] for q in mine]
        slot = {"MA": next(q for q, md in zip(mine, kinds) if md.kind == "traction"),
                "CR": next(q for q, md in zip(mine, kinds) if md.kind == "cruise"),
                "MB": mine[-1]}
        slot["CR2"] = slot["CR"]
        coasts = [q for q, md in zip(mine, kinds) if md.kind == "coast"]
        driven = False
        for i in np.nonzero((mid >= sec.start) & (mid < sec.end))[0]:
            label = labels[i]
            if label == "CR2" and not driven and len(coasts) > 1 and v[i + 1] > (1 + 1e-3) * v[i]:
                label = "CO"  # braking that does not hold the speed down a grade, before any traction: a coast
            q = slot.get(label, slot["CR"] if not coasts  # no coast mode (das_handle_levels without 0)
                         else coasts[-1] if driven or len(coasts) == 1 else coasts[0])
            driven = driven or labels[i] in ("MA", "CR")
            lengths[q] += x[i + 1] - x[i]
        lengths[mine] *= sec.length / max(lengths[mine].sum(), 1e-9)
    return lengths, phases.speeds_at(layout, lengths, x, v)


def all_out_check(train, nodes, limits, v, ft, fb, tolerance=0.01):
    """The regimes of a minimum-time run (all-out): every interval at full traction (MA), at full
    braking (MB), at the net acceleration or deceleration bound of the train, or with a node at its
    speed limit ``limits`` [m/s] (holding it, or the one interval that reaches or leaves it); each
    within ``tolerance`` (relative). Agreement as :func:`ecostudy.analysis.pontryagin.check` says it,
    without a costate (the all-out run's arrival multiplier is unbounded: no energy costate to fit)."""
    labels = classify(train, v, ft, fb, tolerance)
    ds = np.diff(nodes)
    accel = (v[1:] ** 2 - v[:-1] ** 2) / (2 * ds)
    at_limit = v >= (1 - tolerance) * limits
    agree = (np.isin(labels, ("MA", "MB")) | at_limit[:-1] | at_limit[1:]
             | (accel >= (1 - tolerance) * train.max_acceleration) | (-accel >= (1 - tolerance) * train.max_deceleration))
    bad = [{"regime": label, "start_m": start, "end_m": end} for label, start, end in
           runs(np.where(agree, "ok", labels), nodes) if label != "ok"]
    return {"agreement_pct": float(100 * ds[agree].sum() / ds.sum()), "intervals_agreeing_pct": float(100 * agree.mean()),
            "sequence": [{"regime": r, "start_m": a, "end_m": b} for r, a, b in runs(labels, nodes)],
            "disagreements": bad, "tolerance": tolerance}
