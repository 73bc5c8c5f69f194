"""Supervisor rules (Farooqi 2018 Ch. 7-8): triggering 7.7, voltage 7.11, dissension 8.14-8.17, the
receptivity credit, and following a train ahead (Yazhemsky 2017 eq. 6.9). See :mod:`.strategies`."""
import copy
from typing import NamedTuple

import numpy as np

from ecostudy.core.errors import SolverError
from ecostudy.core.registry import Registry
from ecostudy.network import circuit
from ecostudy.network.fleet import departure_order, line_positions, solve_train, step_arrays
from ecostudy.network.scoring import buffer_missed, evaluate


GAMMA = (0.71, 0.9)  # Farooqi 2018 Fig. 7.3: time weights without / with a braking neighbour


def _braking_steps(fleet, runs_by_train, share=0.1):
    """Per train, the clock steps in which it regenerates more than ``share`` of its peak power."""
    out = []
    for i, runs in enumerate(runs_by_train):
        flag = np.zeros(fleet.steps, bool)
        for leg, run in zip(fleet.legs[i], runs):
            peak = max(float(np.max(-run.p)), 1.0)
            flag[leg.start:leg.start + leg.steps] = -run.p > share * peak
        out.append(flag)
    return out


def _others(flags, i):
    return np.any([f for j, f in enumerate(flags) if j != i], axis=0) if len(flags) > 1 else np.zeros_like(flags[0])


def independent(fleet, mapper=map):
    """Every train for itself; a train whose legs are those of one already solved (the same
    segments and running times, another departure) drives as that one did."""
    runs, solved = [], {}
    for i, legs in enumerate(fleet.legs):
        key = tuple((id(leg.case), leg.steps) for leg in legs)
        if key not in solved:
            solved[key] = solve_train(fleet, i, mapper=mapper)[0]
        runs.append(copy.deepcopy(solved[key]))
    return runs


DISSENSION = {"gamma0": 0.5, "rate": 0.05, "influence": 0.15}  # [-], [1/s], [1/s]


def dissension_weights(fleet, flags):
    """Traction weights gamma_i(t) / gamma0 of the dissension strategy (Farooqi 2018 eqs. 8.14-8.17).

    Each train's q_i = [gamma_i, 1 - gamma_i] follows q' = (Q^T + A_i^T) q with the two-state
    generator Q = [[-r, r], [r, -r]] (rest value gamma0 = 0.5) and the interaction rate
    a_12 = lambda_1 / (M - 1) * (number of other trains braking), lambda_2 = 0 (eq. 8.15-8.17):
    while others brake, gamma_i falls (to 0.29 with one of two neighbours braking, the thesis'
    0.5 -> 0.3), and it is reset to gamma0 at every departure. Integrated exactly per clock step.
    """
    g0, r, lam = DISSENSION["gamma0"], DISSENSION["rate"], DISSENSION["influence"]
    count = np.sum(flags, axis=0)
    out = []
    for i, legs in enumerate(fleet.legs):
        braking_others = count - flags[i]
        a12 = lam * braking_others / max(len(fleet.legs) - 1, 1)
        gamma = np.full(fleet.steps, g0)
        departures = {leg.start for leg in legs}
        g = g0
        for t in range(fleet.steps):
            if t in departures:
                g = g0
            total = 2 * r + a12[t]  # gamma' = -(r + a12) gamma + r (1 - gamma)
            target = r / total
            g = target + (g - target) * np.exp(-total * fleet.dt)
            gamma[t] = g
        out.append(gamma / g0)
    return out


def offered(fleet, runs_by_train):
    """Regenerated power each train offers per clock step [kW] (what its electric brake feeds)."""
    out = np.zeros((len(runs_by_train), fleet.steps))
    for i, runs in enumerate(runs_by_train):
        for leg, run in zip(fleet.legs[i], runs):
            out[i, leg.start:leg.start + leg.steps] = np.maximum(-run.p, 0.0) / 1e3
    return out


def _probe(fleet, runs_by_train, i, power_w):
    """The clock steps where train ``i`` runs beside another and ``power_w`` [W per step, NaN: no
    probe] is set, and the circuit solved there with train i at that power, the others as they run."""
    x, p = step_arrays(fleet, runs_by_train)
    shared = np.isfinite(x[:, i]) & (np.isfinite(x).sum(axis=1) > 1) & np.isfinite(power_w)
    p = p[shared]
    p[:, i] = power_w[shared]
    return shared, circuit.solve_steps(fleet.supply, x[shared], p)


def deliverable(fleet, runs_by_train, i, offer_kw):
    """Per clock step, the part [kW] of ``offer_kw`` that train ``i`` could take over the line:
    the regeneration used with train i drawing the offer, less that with train i at rest, the
    others as they run (the circuit of ``circuit.solve_steps``: line losses, V_max, the diode)."""
    offer = np.where(offer_kw > 0, offer_kw * 1e3, np.nan)
    at, drawing = _probe(fleet, runs_by_train, i, offer)
    _, idle = _probe(fleet, runs_by_train, i, np.where(offer_kw > 0, 0.0, np.nan))
    out = np.zeros(fleet.steps)
    out[at] = np.maximum(drawing["regen_used_W"] - idle["regen_used_W"], 0.0) / 1e3
    return out


RECEPTIVITY_PROBE = 5e6  # [W] a regeneration no train offers: what the line takes of it is its limit


def receptivity(fleet, runs_by_train, i):
    """Per clock step, the regenerated power [kW] the line could take from train ``i`` while the
    others run as in ``runs_by_train`` (train i offering ``RECEPTIVITY_PROBE``; ``circuit.solve_steps``)."""
    at, flows = _probe(fleet, runs_by_train, i, np.full(fleet.steps, -RECEPTIVITY_PROBE))
    out = np.zeros(fleet.steps)
    out[at] = flows["fed_W"][:, i] / 1e3
    return out


def sensed(fleet, runs_by_train):
    """Pantograph voltages [V] per train and clock step as rule 7.11's supervisor sees them
    (``circuit.sensed_voltages``: eq. 7.8 with a receptive source); NaN where a train is not running."""
    x, p = step_arrays(fleet, runs_by_train)
    return circuit.sensed_voltages(fleet.supply, x, p).T


def _offered_by_others(fleet, runs_by_train, i):
    power = offered(fleet, runs_by_train)
    return power.sum(axis=0) - power[i]


def _no_rule(fleet, runs_by_train, i):
    """supervisor rounds, regeneration credited up to what the line takes"""
    return np.ones(fleet.steps), np.zeros(fleet.steps)


def _triggering(fleet, runs_by_train, i):
    """rule 7.7: traction discounted while another train brakes"""
    flags = _braking_steps(fleet, runs_by_train)
    return np.where(_others(flags, i), (1 - GAMMA[1]) / (1 - GAMMA[0]), 1.0), _offered_by_others(fleet, runs_by_train, i)


def _voltage(fleet, runs_by_train, i):
    """rule 7.11: traction free while the train ahead's voltage is above one's own"""
    order = departure_order(fleet)
    rank = order.index(i)
    if rank == 0:
        return np.ones(fleet.steps), np.zeros(fleet.steps)
    ahead, power = order[rank - 1], offered(fleet, runs_by_train)
    volts = sensed(fleet, runs_by_train)
    higher = (volts[ahead] > volts[i] + 1.0) & (power[ahead] > 0)  # NaN (not running) compares False
    return np.where(higher, 0.0, 1.0), deliverable(fleet, runs_by_train, i, np.where(higher, power[ahead], 0.0))


def _dissension(fleet, runs_by_train, i):
    """eqs. 8.14-8.17: weights that fall with the number of braking neighbours"""
    return dissension_weights(fleet, _braking_steps(fleet, runs_by_train))[i], _offered_by_others(fleet, runs_by_train, i)


# the supervisor rules by name, each ``terms(fleet, runs_by_train, i)``: every one is a network
# strategy of supervisor rounds (``strategies.STRATEGIES``); the study file's names: ``io.schemas.Strategy``
RULES: Registry = Registry("supervisor rule")
RULES.register("receptivity", _no_rule)
RULES.register("triggering", _triggering)
RULES.register("voltage", _voltage)
RULES.register("dissension", _dissension)


def rule_terms(fleet, rule, runs_by_train, i):
    """(traction weight, allowance [kW]) per clock step of train ``i`` under ``rule`` (a name of
    :data:`RULES`; another is refused naming them), from the runs as they are now: 7.7 discounts by
    (1 - gamma2) / (1 - gamma1) while another train brakes, dissension by gamma_i / gamma0
    (:func:`dissension_weights`), both up to the power the others offer; 7.11 (between consecutive
    trains, as the thesis' text applies it) weighs 0 while the voltage of the train ahead is above
    one's own (:func:`sensed`), up to what the line can deliver of that train's offer
    (:func:`deliverable`); ``receptivity``, no rule: the rounds' receptivity credit alone."""
    return RULES.get(rule)(fleet, runs_by_train, i)


class Rounds(NamedTuple):
    """What :func:`supervised` returns."""
    runs: list            # the best round's runs, per train
    history: list         # the substation kWh of the start and of each round
    stopped: str | None   # why a round stopped, None when every round completed
    held: dict            # {train name: why it kept an earlier run from some round on}


def supervised(fleet, rule, start, rounds=3, mapper=map):
    """Rules (b), (c) and (d): supervisor rounds; in each, the trains in departure order are
    re-optimised one by one against the others' latest runs (Gauss-Seidel: a train never plans
    against a run that has already been replaced).

    With a ``fleet.buffer``, each train stays that far behind the tail of the one ahead, as that
    one now runs (Yazhemsky 2017 eq. 6.9, as in :func:`following`).
    Each train minimises w traction (discounted up to an allowance, :func:`rule_terms`; a zero
    weight on unlimited traction only moves consumption to the substation) minus its regeneration
    credited up to what the line could take from it then (:func:`receptivity`; crediting all of it,
    as independent driving does, let a discounted train accelerate and brake harder and lose the
    extra braking: measured +1 % substation energy for rule 7.11 on the 2-train study). Returns
    :class:`Rounds`: the runs, the rounds' substation kWh, None or why a round stopped, and the trains
    held at an earlier run with why; the runs are those of the best
    round, the start included where it keeps the buffer (the independent runs ignore it: on two metro
    trains 30 s apart with buffer_m 150, tests/test_network_buffer.py, the start was the cheapest
    and 35 m too near). Where a train cannot keep its buffer behind the new run ahead, that new run is
    not taken (the train ahead keeps its run of the round before) and the train is planned behind
    it, the train ahead keeping that run in the later rounds (the 3-train metro study's rule 7.7:
    its T2's first new run leaves T3 no run 60 m behind it); a round whose runs then miss the buffer
    somewhere is not kept. A round after the first that still cannot be
    completed ends the rounds.

    The warm-against-cold check of ``legs.solve_leg`` is made in the first round only: there each
    leg starts from a run of another problem (independent driving); a later round starts it from
    its own previous optimum under costs that moved less. On the 3-train metro study's rule 7.7 the
    later rounds' cold solves of the checked legs were 36 % of the rule's solve time (1672 of 5068
    Ipopt iterations) and replaced no warm run (those were up to 23 % cheaper); every strategy's
    substation energy stayed the same (docs/speed.md).
    """
    runs = list(start)
    _, _, totals = evaluate(fleet, runs)
    history = [totals["substation_kWh"]]
    # the start (independent runs) is a candidate only where it keeps the buffer: the rounds keep it
    best = (history[0], list(runs)) if buffer_missed(fleet, runs) is None else (np.inf, runs)
    order = departure_order(fleet)
    memo = {}  # legs whose terms did not change since their last solve are not solved again
    checked = {}  # the first round's cold checks (:func:`_checks`)
    held = {}  # trains whose new run left the train behind no run: they keep their run from then on
    for number in range(1, rounds + 1):
        before = list(runs)  # the runs of the round before (the start before the first)
        try:
            for rank, i in enumerate(order):
                if i in held:
                    continue
                try:
                    runs[i] = _replan(fleet, rule, runs, order, rank, memo, mapper, number == 1)
                except SolverError:
                    j = order[rank - 1] if rank and fleet.buffer else None
                    if j is None or runs[j] is before[j]:
                        raise
                    runs[j] = before[j]  # the new run ahead leaves this train no run behind it: not taken
                    held[j] = (f"from round {number} on: its new run left {fleet.names[i]} no run buffer_m "
                               f"{fleet.buffer:g} m behind it")
                    runs[i] = _replan(fleet, rule, runs, order, rank, memo, mapper, number == 1)
        except SolverError as exc:
            if number == 1:
                raise
            return Rounds(_with_checks(best[1], checked), history, f"round {number} stopped: {exc}", _named(fleet, held))
        if number == 1:
            checked = _checks(runs)
        _, _, totals = evaluate(fleet, runs)
        history.append(totals["substation_kWh"])
        if history[-1] < best[0] and buffer_missed(fleet, runs) is None:
            best = (history[-1], list(runs))
    return Rounds(_with_checks(best[1], checked), history, None, _named(fleet, held))


def _named(fleet, held):
    """{train name: why} of the trains ``held`` by index, in departure order."""
    return {fleet.names[j]: why for j, why in sorted(held.items())}


def _replan(fleet, rule, runs, order, rank, memo, mapper, check):
    """The new run of train ``order[rank]`` under ``rule`` against the others' ``runs``, behind the
    run of the train ahead (:func:`supervised`)."""
    i = order[rank]
    weights, allowance = rule_terms(fleet, rule, runs, i)
    ahead = line_positions(fleet, order[rank - 1], runs[order[rank - 1]]) if rank and fleet.buffer else None
    return solve_train(fleet, i, weights, guesses=runs[i], allowance=allowance, credit=receptivity(fleet, runs, i),
                       ahead=ahead, mapper=mapper, memo=memo, check=check)[0]


CHECK_NOTES = ("warm_vs_cold_pct", "replaced_by_cold", "warm_capped_at")  # what ``legs.solve_leg``'s cold check notes


def _checked(run):
    """Whether a leg's run carries the notes of a cold check."""
    return bool(run.notes) and CHECK_NOTES[0] in run.notes


def _checks(runs):
    """{(train, leg): the cold check's notes} of the legs checked in ``runs`` (the first round)."""
    return {(i, k): {key: run.notes[key] for key in CHECK_NOTES if key in run.notes}
            for i, train in enumerate(runs) for k, run in enumerate(train) if _checked(run)}


def _with_checks(runs, checked):
    """``runs`` with the first round's cold-check notes on the legs of a later round, which were not
    checked themselves (what ``guard_counts`` reports of a strategy's final runs)."""
    out = [list(train) for train in runs]
    for (i, k), notes in checked.items():
        run = out[i][k]
        if not _checked(run):
            out[i][k] = run._replace(notes={**notes, **(run.notes or {})})
    return out


def following(fleet, start, mapper=map):
    """(f): trains in departure order, each kept ``fleet.buffer`` behind the one ahead."""
    order = departure_order(fleet)
    runs = list(start)
    for rank, i in enumerate(order):
        if rank == 0:
            continue
        ahead = line_positions(fleet, order[rank - 1], runs[order[rank - 1]])
        runs[i] = solve_train(fleet, i, guesses=runs[i], ahead=ahead, mapper=mapper)[0]
    return runs
