"""Leg tasks that several strategies pose alike are solved once per process (network/shared.py), and
every strategy's runs are those of solving each of its tasks itself."""
import copy
import threading

import numpy as np
import pytest

from ecostudy.core.types import Supply
from ecostudy.io.loaders import load_track, load_train
from ecostudy.network import fleet, legs, rules
from ecostudy.network.shared import LegRuns, task_key

from .conftest import TRACKS, TRAINS

SUPPLY = Supply(position=1500.0)


@pytest.fixture(scope="module")
def two_trains():
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 30.0], ["T1", "T2"], 1.0, SUPPLY,
                   points=300)
    return f, rules.independent(f)


def _same(a, b):
    return all(np.array_equal(x, y) for ra, rb in zip(a, b) for la, lb in zip(ra, rb) for x, y in zip(la[:6], lb[:6]))


def test_a_leg_task_another_strategy_solved_is_not_solved_again_and_the_runs_are_the_same(two_trains):
    """Rule 7.11 weighs the first train as the receptivity credit alone does, so its first round poses
    that train's leg as the receptivity rounds did: handed over, with every run of the rule the same
    to the last bit as in a process that solved each of the rule's tasks itself."""
    f, ind = two_trains
    f = copy.copy(f)
    f.solved = LegRuns()
    alone = copy.copy(f)
    alone.solved = LegRuns()
    rules.supervised(f, "receptivity", ind)
    before = f.solved.hits
    shared, shared_history, _, _ = rules.supervised(f, "voltage", ind)
    own, own_history, _, _ = rules.supervised(alone, "voltage", ind)
    assert f.solved.hits > before and alone.solved.hits == 0
    assert shared_history == own_history and _same(shared, own)


def _counting(calls):
    def mapper(fn, tasks):
        tasks = list(tasks)
        calls.extend(t[1] for t in tasks)
        return map(fn, tasks)
    return mapper


def test_two_threads_posing_one_task_solve_it_once(two_trains):
    f, ind = two_trains
    leg = f.legs[0][0]
    task = (leg, "train T1, leg 1", f.dt, f.buffer, ind[0][0][:5], True, None, None, None, None)
    key = task_key(task, fleet._own_terms(leg, None, None, None, None))
    shared, calls, outs = LegRuns(), [], []
    threads = [threading.Thread(target=lambda: outs.append(shared.map(_counting(calls), legs.solve_leg, [task], [key])))
               for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert calls == ["train T1, leg 1"] and shared.hits == 1
    assert np.array_equal(outs[0][0][0].v, outs[1][0][0].v) and outs[0][0][0] is not outs[1][0][0]


def test_a_task_whose_solve_raised_is_solved_again_when_posed_again(two_trains):
    f, ind = two_trains
    leg = f.legs[0][0]
    task = (leg, "train T1, leg 1", f.dt, f.buffer, ind[0][0][:5], True, None, None, None, None)
    key = task_key(task, fleet._own_terms(leg, None, None, None, None))
    shared, calls = LegRuns(), []

    def failing(fn, tasks):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        shared.map(failing, legs.solve_leg, [task], [key])
    (run, outcome), = shared.map(_counting(calls), legs.solve_leg, [task], [key])
    assert calls == ["train T1, leg 1"] and outcome.usable and shared.hits == 0
