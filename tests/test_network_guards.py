"""Local-optimum guards of the network legs: a warm leg in the sample is solved cold too and
replaced where it is dearer; a cold leg is solved from the trapezoidal start too and the cheaper
run kept; a run that stands before its stop is solved again or fails its
verification."""
import numpy as np
import pytest

from ecostudy.io.loaders import load_track, load_train
from ecostudy.network import fleet, legs, scoring
from ecostudy.network.strategies import guard_counts, not_optimal
from ecostudy.ocp import session, timedomain
from pyomo.environ import value as pyo_value

from .test_network import SUPPLY, TRACKS, TRAINS


def solved_leg(dt):
    """(fleet, leg, its cold run) of Noord -> Station in 56 s on steps of ``dt``."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0], ["T1"], dt, SUPPLY, points=300)
    leg = f.legs[0][0]
    cold, _ = legs.solve_leg((leg, "cold", f.dt, None, fleet._guess(f, leg), False, None, None, None, None))
    return f, leg, cold


@pytest.fixture(scope="module")
def one_leg():
    return solved_leg(1.0)


def early_start(leg, run, early):
    """The run ``early`` steps faster, then standing at the stop: a start that arrives early."""
    n = leg.steps
    t = np.arange(n + 1.0)
    s = np.interp(np.minimum(t * n / (n - early), n), t, run.s)
    v = np.clip(np.gradient(s, leg.dt), 0.0, None)
    v[0] = 0.0
    v[-early - 1:] = 0.0
    return s, v


def dearer_start(f, leg, cold):
    """The first early start (5-30 steps early) that a warm solve follows into a local optimum
    more than 5 % dearer than the cold one, and that warm run. Which starts do depends on the leg's
    NLP to rounding and on MUMPS's ordering (with PORD about one in three of them); none at all
    fails the test."""
    for early in range(5, 31):
        guess = early_start(leg, cold, early)
        warm, _ = legs.solve_leg((leg, "T1 leg 1", f.dt, None, guess, True, None, None, None, None))
        if warm.notes is None and warm.p.sum() > 1.05 * cold.p.sum():
            return guess, warm
    pytest.fail("no early start led the warm solve to a dearer local optimum")


def test_a_warm_leg_dearer_than_its_cold_solve_is_replaced(one_leg):
    f, leg, cold = one_leg
    assert [legs.warmth(0, k) for k in range(4)] == [legs.CHECKED, True, True, legs.CHECKED]
    assert [legs.warmth(1, k) for k in range(3)] == [True, True, legs.CHECKED]
    # outside the sample the warm solve stays where its start led it: dearer, yet verified
    guess, warm = dearer_start(f, leg, cold)
    assert scoring.verify_leg(leg, warm)["passed"]
    # in the sample the cold solve replaces it, and says so
    run, outcome = legs.solve_leg((leg, "T1 leg 1", f.dt, None, guess, legs.CHECKED, None, None, None, None))
    assert outcome.usable and run.notes["replaced_by_cold"] and run.notes["warm_vs_cold_pct"] > 5.0
    assert run.p.sum() == pytest.approx(cold.p.sum(), rel=1e-6)
    counts = guard_counts([[run, warm]])
    assert counts["legs_checked_cold_count"] == 1 and counts["legs_replaced_by_cold_count"] == 1
    assert counts["warm_vs_cold_worst_pct"] == pytest.approx(run.notes["warm_vs_cold_pct"])


def test_a_checked_warm_leg_stopped_at_its_cap_gives_way_to_its_cold_solve(one_leg, monkeypatch):
    f, leg, cold = one_leg
    guess = early_start(leg, cold, 10)
    task = (leg, "T1 leg 1", f.dt, None, guess, legs.CHECKED, None, None, None, None)
    free, _ = legs.solve_leg(task)
    assert "warm_capped_at" not in free.notes  # the shipped cap leaves this leg's warm solve alone
    monkeypatch.setattr(legs, "WARM_MAX_ITER", 3)  # a cap the warm solve cannot finish within
    run, outcome = legs.solve_leg(task)
    assert run.notes["warm_capped_at"] == 3 and run.notes["replaced_by_cold"]
    assert outcome.optimal and scoring.verify_leg(leg, run)["passed"]
    assert run.p.sum() == pytest.approx(cold.p.sum(), rel=1e-6)  # the cold solve's optimum
    counts = guard_counts([[run]])
    assert counts["legs_checked_cold_count"] == 1 and counts["legs_warm_capped_count"] == 1 and counts["legs_replaced_by_cold_count"] == 1


def pumping_start(f, leg):
    """A feasible run of the leg that is far from its optimum: its optimum under a traction weight of
    0.3 (traction and regeneration pumped, about 3x the plain cost), every force given."""
    weights = np.full(f.steps, 0.3)
    run, outcome = legs.solve_leg((leg, "pumping", f.dt, None, fleet._guess(f, leg), False, weights, None, None, None))
    assert outcome.optimal
    return run.s, run.v, run.ft, run.fb, run.fr


def test_a_warm_leg_stopped_at_its_cap_is_solved_again_never_kept_unproven(one_leg, monkeypatch):
    f, leg, cold = one_leg
    task = (leg, "T1 leg 2", f.dt, None, pumping_start(f, leg), True, None, None, None, None)
    free, _ = legs.solve_leg(task)
    monkeypatch.setattr(legs, "WARM_MAX_ITER", 0)  # the warm solve stops at its (feasible) start
    nlp = legs.LegNLP(task)
    capped = nlp.solve({**legs.NEAR_START, **legs.KKT, "max_iter": 0}, nlp.start(False))
    assert capped.usable and capped.status == "max_iterations"  # usable, not proven optimal: not to be kept here
    run, outcome = legs.solve_leg(task)  # solved again with Ipopt's defaults, to the optimum
    assert outcome.optimal and run.notes is None
    assert run.p.sum() == pytest.approx(free.p.sum(), rel=1e-6)
    assert run.p.sum() == pytest.approx(cold.p.sum(), rel=1e-4)


def test_a_leg_kept_at_a_point_ipopt_did_not_prove_optimal_flags_its_strategy(one_leg, monkeypatch):
    f, leg, cold = one_leg
    task = (leg, "T1 leg 1", f.dt, None, pumping_start(f, leg), True, None, None, None, None)
    monkeypatch.setattr(legs, "WARM_MAX_ITER", 0)
    monkeypatch.setattr(legs, "KKT", {**legs.KKT, "max_iter": 0})  # the second try stops at once, unusable
    run, outcome = legs.solve_leg(task)  # the capped warm point is kept: usable, not optimal
    assert outcome.status == "max_iterations" and run.notes == {"solver_status": "max_iterations"}
    assert guard_counts([[run]])["legs_not_optimal_count"] == 1
    assert not_optimal(f, [[run]], {}) == ["T1 leg 1: Ipopt ended max_iterations, not optimal"]
    assert not_optimal(f, [[cold]], {"solver_status": "acceptable"}) == [
        "the joint NLP: Ipopt ended acceptable, not optimal"]
    assert not_optimal(f, [[cold]], {"solver_status": "optimal"}) == []
    many = not_optimal(f, [[run] * 5], {})  # a long line of legs: the first three and how many more
    assert many[:3] == [f"T1 leg {k}: Ipopt ended max_iterations, not optimal" for k in (1, 2, 3)]
    assert many[3:] == ["and 2 more legs or NLPs not proven optimal (legs_not_optimal_count)"]


def test_a_cold_leg_keeps_the_cheaper_of_its_two_starts():
    # on 0.5 s steps: on 1 s steps no start 5-49 steps early, none standing 3-23 steps at the start
    # or halfway, led a cold solve of this leg to a dearer optimum (nor on Station -> Centrum)
    f, leg, cold = solved_leg(0.5)
    # from the space run's guess both starts reach the same optimum: the guess's run stays
    assert cold.notes["independent_vs_trapezoid_pct"] <= 100 * legs.TIE and "replaced_by_trapezoid" not in cold.notes
    # from a start that arrives early, a cold solve may stop in a dearer local optimum: the first
    # such start (10-60 steps early; 28 steps early is one) is replaced by the trapezoidal start's run, and says so
    for early in range(10, 61):
        task = (leg, "T1 leg 1", f.dt, None, early_start(leg, cold, early), False, None, None, None, None)
        run, outcome = legs.solve_leg(task)
        if run.notes.get("replaced_by_trapezoid"):
            break
    else:
        pytest.fail("no early start led the cold solve to a dearer local optimum")
    assert outcome.usable and scoring.verify_leg(leg, run)["passed"]
    assert run.p.sum() == pytest.approx(cold.p.sum(), rel=1e-6)
    # the two solves on their own: the guess's run dearer by the noted share
    nlp = legs.LegNLP(task)
    own, trapezoid = legs._solve(nlp)[2], legs._solve(nlp, cold=True)[2]
    assert own > trapezoid * (1 + legs.TIE)
    assert run.notes["independent_vs_trapezoid_pct"] == pytest.approx(100 * (own - trapezoid) / abs(trapezoid))
    assert guard_counts([[run, cold]])["legs_replaced_by_trapezoid_count"] == 1


def test_a_run_that_stands_before_its_stop_fails_verification(one_leg):
    f, leg, cold = one_leg
    assert legs.standing_s(cold, leg) == 0.0  # standing at the stop itself is not standing before it
    half = np.searchsorted(cold.s, leg.case.segment.distance / 2)
    s = np.concatenate([cold.s[:half], np.full(4, cold.s[half - 1]), cold.s[half:-4]])
    v = np.concatenate([cold.v[:half - 1], np.zeros(5), cold.v[half:-4]])
    stands = cold._replace(s=s, v=v)
    assert legs.standing_s(stands, leg) == pytest.approx(4 * leg.dt)
    out = scoring.verify_leg(leg, stands)
    assert out["stood_before_stop_s"] == pytest.approx(4 * leg.dt) and not out["passed"]
    assert scoring.verify_leg(leg, cold)["stood_before_stop_s"] == 0.0


def test_every_strategy_a_study_file_may_name_is_registered():
    from ecostudy.io.schemas import STRATEGIES as IN_FILES
    from ecostudy.network.strategies import STRATEGIES
    assert ["independent", *STRATEGIES.names()] == list(IN_FILES)
    with pytest.raises(KeyError, match="unknown network strategy 'nope'; known: receptivity, triggering"):
        STRATEGIES.get("nope")


def test_a_supervisor_rule_is_looked_up_by_name_and_an_unknown_one_is_refused(one_leg):
    """Every supervisor rule of ``rules.RULES`` is a strategy; a rule name it does not hold is refused
    naming the known ones (it never falls through to another rule's weights)."""
    from ecostudy.network import rules
    from ecostudy.network.strategies import STRATEGIES
    f, _, _ = one_leg
    assert set(rules.RULES.names()) == {"receptivity", "triggering", "voltage", "dissension"} <= set(STRATEGIES.names())
    runs = rules.independent(f)
    weights, allowance = rules.rule_terms(f, "receptivity", runs, 0)
    assert (weights == 1.0).all() and (allowance == 0.0).all()
    with pytest.raises(KeyError, match="unknown supervisor rule 'mild'; known: receptivity, triggering, voltage"):
        rules.rule_terms(f, "mild", runs, 0)


def test_the_guide_s_new_strategy_runs_with_one_registration_line(one_leg):
    """docs/results.md, "Registered kinds": its example, run as written, adds a strategy that the
    study machinery solves and scores like the others."""
    import re
    from pathlib import Path

    from ecostudy.network import rules
    from ecostudy.network.strategies import STRATEGIES, _strategy
    page = (Path(__file__).resolve().parent.parent / "docs" / "results.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", page, re.S) if "STRATEGIES.register" in b)
    f, _, _ = one_leg
    try:
        exec(block, {})
        result = _strategy(f, "lazy", rules.independent(f))
        assert result["totals"]["status"] == "ok" and result["totals"]["all_verified"]
    finally:
        STRATEGIES._specs.pop("lazy", None)


def test_a_cold_leg_with_the_one_handle_rows_is_solved_relaxed_first_and_ends_at_their_own_bound(one_leg):
    f, leg, cold = one_leg
    steps = f.steps
    weights, allowance = np.full(steps, 0.34), np.full(steps, 500.0)  # rule 7.7's discount with others' power to take
    task = (leg, "T1 leg 1", f.dt, None, None, False, weights, allowance, None, None)
    m, b = legs.leg_model(task)
    assert len(b.one_handle) > 0  # traction discounted: traction while braking would pay
    nlp = legs.LegNLP(task)
    outcome = legs._relaxed_first(nlp, nlp.start(cold=False))
    assert outcome.usable
    b = nlp.block
    product = [pyo_value(b.ft[j]) * pyo_value(b.fb[j]) for j in b.one_handle]
    assert max(product) <= timedomain.ONE_HANDLE * (1 + 1e-6) + 1e-9  # the tight bound is the one solved last
    assert all(row.upper == timedomain.ONE_HANDLE for row in b.one_handle.values())
    rows = nlp.session.nlp.get_constraint_indices(list(b.one_handle.values()))
    assert set(nlp.session.nlp.constraints_ub()[rows]) == {timedomain.ONE_HANDLE}  # and so does the NLP
    # without a discount the leg has no such rows and is solved in one go
    plain = (leg, "T1 leg 1", f.dt, None, None, False, None, None, None, None)
    m0, b0 = legs.leg_model(plain)
    assert not timedomain.relax_one_handle(b0, 1.0)


def test_the_supervisor_rounds_check_warm_legs_against_cold_in_their_first_round_only(monkeypatch):
    from ecostudy.network import rules
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 30.0], ["T1", "T2"], 1.0, SUPPLY,
                   points=300)
    start = rules.independent(f)
    warmth, solve = [], fleet.solve_leg

    def noted(task):  # the real solve, with what each task asked for noted
        warmth.append((task[1], task[5]))
        return solve(task)

    monkeypatch.setattr(fleet, "solve_leg", noted)
    runs, history, _, _ = rules.supervised(f, "triggering", start, rounds=2)
    first = warmth[:2]  # both trains' one leg in the first round, T1's in the sample
    assert first == [("train T1, leg 1", legs.CHECKED), ("train T2, leg 1", True)]
    assert len(history) == 3 and len(warmth) > 2 and all(flag is True for _, flag in warmth[2:])
    assert "warm_vs_cold_pct" in runs[0][0].notes  # the first round's check, reported on the final run
    assert guard_counts(runs)["legs_checked_cold_count"] == 1
    # solve_train's own switch: the sampled leg solved warm only, no cold check noted
    run = fleet.solve_train(f, 0, guesses=start[0], check=False)[0][0]
    assert run.notes is None


def test_a_leg_s_nlp_written_once_solves_as_one_written_for_each_solve(one_leg):
    """The cold check and the relaxed first solve reuse the task's NL file: from the trapezoidal
    start, relaxed first, the same run bit for bit as a model built from that start and written
    for each of its solves (the same NLP from the same start)."""
    f, leg, cold = one_leg
    steps = f.steps
    weights, allowance = np.full(steps, 0.34), np.full(steps, 500.0)
    warm = (leg, "T1 leg 1", f.dt, None, cold[:5], True, weights, allowance, None, None)
    nlp = legs.LegNLP(warm)
    legs._solve(nlp)  # the warm solve first, as the check makes it
    again = legs._solve(nlp, cold=True)
    # written afresh: a model built from the trapezoidal start, its relaxed and tight solves each
    # in a model written with its own bound and start
    m, b = legs.leg_model(warm[:4] + (None, False) + warm[6:])
    assert timedomain.relax_one_handle(b, legs.RELAXED_ONE_HANDLE)
    first = session.solve(m, legs.KKT)
    timedomain.relax_one_handle(b)
    second = session.solve(m, {**legs.NEAR_START, **legs.KKT})
    assert first.usable and second.usable
    fresh = timedomain.leg_arrays(b)
    assert again[1].iterations == first.iterations + second.iterations
    for mine, theirs in zip(again[0][:6], fresh[:6]):
        np.testing.assert_array_equal(mine, theirs)


def test_running_times_over_an_all_out_run_ipopt_did_not_prove_optimal_flag_every_strategy(monkeypatch):
    """A leg's running time is a supplement over its segment's all-out run; solved with a tolerance
    Ipopt cannot reach (tol 1e-20 on every space NLP, Ipopt stopping at the first point within its
    acceptable tolerance) that run ends ``acceptable``, and every strategy on that timetable says so."""
    from ecostudy.ocp.solver import IPOPT
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    monkeypatch.setitem(IPOPT["space"], "tol", 1e-20)
    monkeypatch.setitem(IPOPT["space"], "acceptable_iter", 1)
    f = fleet.plan(track, train, ["Noord", "Station"], None, 10.0, [0.0], ["T1"], 1.0, SUPPLY, points=100,
                   supplement=0.1)
    assert f.all_out_solver == {("Noord", "Station"): "acceptable"}
    assert not_optimal(f, [], {}) == ["the all-out run from Noord to Station: Ipopt ended acceptable, not optimal"]
