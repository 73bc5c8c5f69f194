"""The Python API refuses what no run answers in one line naming the argument, before solving, and
its warnings name arguments, not options: a path where a loaded train belongs (and the reverse),
timing windows that are not Windows of finite numbers between the stops (Pyomo's errors), a front
or a re-planner asked to minimise time (an energy front labelled time-optimal), a solve folder's
objective or advice method misspelt (a ValueError after the solve), an export step given as a
number (a TypeError), mixed weights ``ecostudy solve --weights`` refuses (an energy weight of 0, a
time weight of 0 with no window: computed before)."""
import warnings

import pytest

from ecostudy import api
from ecostudy.core.errors import EcostudyWarning, InputError

from .conftest import TRACKS, TRAINS

ROKIN, METRO = TRACKS / "amsterdam_rokin_centraal.yaml", TRAINS / "amsterdam_metro.yaml"
TRACK, TRAIN = api.load_track(ROKIN), api.load_train(METRO)
W = api.Window


@pytest.mark.parametrize("call, words", [
    (lambda: api.solve(TRACK, str(METRO), running_time=80), "arguments: train: a Train (api.load_train(path)"),
    (lambda: api.solve(TRAIN, TRACK, running_time=80), "arguments: track: a Track"),
    (lambda: api.solve(TRACK, TRAIN, running_time=80, windows=[W(-10.0, 30.0, 45.0)]), "arguments: windows[0]: finite"),
    (lambda: api.solve(TRACK, TRAIN, running_time=80, windows=[W(2000.0)]), "windows[0].distance: 2000 m is not"),
    (lambda: api.solve(TRACK, TRAIN, running_time=80, windows=W(500.0, 30.0, 45.0)), "arguments: windows: a list"),
    (lambda: api.solve(TRACK, TRAIN, running_time=80, windows=[{"distance": 5}]), "windows[0]: a Window(distance"),
    (lambda: api.solve(TRACK, TRAIN, running_time=80, windows=[W(500.0, 50.0, 40.0)]), "earliest after latest"),
    (lambda: api.solve(TRACK, TRAIN, window=(70, 90), objective="mixed", weights=(1, 0)),
     "arguments: weights: an energy weight of 0 leaves the running time alone"),
    (lambda: api.solve(TRACK, TRAIN, objective="mixed", weights=(0, 1)), "arguments: weights: a time weight of 0"),
    (lambda: api.solve(TRACK, TRAIN, objective="mixed", weights=(0, 0)), "arguments: weights: must be two weights"),
    (lambda: api.solve(TRACK, TRAIN, objective="mixed", weights=5), "arguments: weights: expected (time, energy)"),
    (lambda: api.solve(TRACK, TRAIN, running_time=80, weights=(1, 1)), "arguments: weights: weigh time against"),
    (lambda: api.pareto(TRACK, TRAIN, count=3, objective="time"), "arguments: objective: expected one of energy, net_energy"),
    (lambda: api.replanner(TRACK, TRAIN, running_time=80, objective="time"), "'time' plans the earliest arrival"),
    (lambda: api.solve_folder(track=ROKIN, train=TRAIN, time=80), "arguments: train: a path to a train file, not Train"),
    (lambda: api.solve_folder(track=ROKIN, train=METRO, time=80, objective="energi"), "arguments: objective: expected"),
    (lambda: api.solve_folder(track=ROKIN, train=METRO, time=80, das="nope"), "arguments: das: expected one of round"),
    (lambda: api.export_folder(TRACKS, every=1.0), "arguments: every: expected a step such as '1s'"),
    (lambda: api.calibrate_folder(["no.csv"], bootstrap=-5), "arguments: bootstrap: must be at least 0"),
    (lambda: api.calibrate_folder(["no.csv"], savings=-1), "arguments: savings: must be at least 0"),
    (lambda: api.calibrate_folder("no_such_log.csv"), "no_such_log.csv: file not found"),
])
def test_an_argument_no_run_answers_is_one_line_naming_it(call, words):
    with pytest.raises(InputError) as refused:
        call()
    assert words in str(refused.value), str(refused.value)


def test_a_warning_names_the_argument_not_the_option(tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        api.solve_folder(track=ROKIN, train=METRO, time=80, das="round", das_time_limit=5, points=100,
                         out=tmp_path / "o", plot=False)
    said = [str(w.message) for w in caught if issubclass(w.category, EcostudyWarning)]
    assert any(s.startswith("arguments: das_time_limit: bounds the minlp search only") for s in said), said


def test_the_mixed_weights_given_are_the_ones_solved(tmp_path):
    """api.solve's weights reach the run: a heavier time weight is a shorter run, the CLI's for the same weights."""
    runs = [api.solve(TRACK, TRAIN, objective="mixed", weights=(w, 1.0), points=60) for w in (1.0, 4.0)]
    assert runs[1].facts.running_time_s < runs[0].facts.running_time_s - 1.0, [r.facts.running_time_s for r in runs]
    folder = api.solve_folder(track=ROKIN, train=METRO, objective="mixed", weights="4,1", points=60,
                              out=tmp_path / "m", plot=False)
    assert folder.run().running_time_s == pytest.approx(runs[1].facts.running_time_s, rel=1e-6)
