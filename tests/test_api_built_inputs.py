"""A Train or Track built or changed in code (``dataclasses.replace``) is held to the rules of its
file before anything is solved: one InputError naming the object's field (``arguments:
train.traction_efficiency``), read through the file's own schema. An efficiency of 85 (per cent
for a share) solved to a negative net energy and `ok`; a NaN mass raised Pyomo's errors; a track
of length -1 was blamed on the train. Every shipped train and track passes as it is."""
import dataclasses
import math
import warnings

import pytest

from ecostudy import api

from .conftest import TRACKS, TRAINS

TRACK = api.load_track(TRACKS / "amsterdam_rokin_centraal.yaml")
TRAIN = api.load_train(TRAINS / "amsterdam_metro.yaml")
TRAINED = [  # (fields changed, the one line)
    ({"traction_efficiency": 85.0}, "arguments: train.traction_efficiency: Input should be less than or equal to 1"),
    ({"regeneration_efficiency": 5.0},
     "arguments: train.regeneration_efficiency: Input should be less than or equal to 1"),
    ({"mass": math.nan},
     "arguments: train.mass (as the file's rotating_mass_factor = mass / static_mass - 1): Input should be a finite "
     "number"),
    ({"mass": -1.0}, "arguments: train.mass (as the file's rotating_mass_factor = mass / static_mass - 1): Input "
                     "should be greater than or equal to 0"),
    ({"static_mass": 10.0}, "arguments: train.static_mass (as the file's mass_t): Input should be greater than or "
                            "equal to 1"),
    ({"davis": (math.inf, 0.0, 0.0)}, "arguments: train.davis[0]: Input should be a finite number"),
    ({"das_levels": (0.0, 0.5)}, "arguments: train.das_levels: need a braking level (< 0) and a traction level (> 0): "
                                 "advice cannot stop or start otherwise"),
    ({"length": 5000.0}, "arguments: train.length: 5000 m is longer than the track 'Amsterdam metro Rokin - "
                         "Centraal' (1106 m)"),
]


@pytest.mark.parametrize("changed, line", TRAINED, ids=[next(iter(c)) for c, _ in TRAINED])
def test_a_train_changed_in_code_is_refused_by_its_field(changed, line):
    with pytest.raises(api.InputError) as refused:
        api.solve(TRACK, dataclasses.replace(TRAIN, **changed), running_time=80.0, points=100)
    assert refused.value.problems[0] == line  # (a static mass of 10 kg puts the mass over twice it too)


def test_a_track_built_wrong_is_its_own_fault_and_every_entry_refuses_it():
    short = dataclasses.replace(TRACK, length=-1.0)
    fast = dataclasses.replace(TRACK, limits=TRACK.limits * 100)
    for call in (lambda t: api.solve(t, TRAIN, running_time=80.0, points=100),
                 lambda t: api.pareto(t, TRAIN, count=3, points=100),
                 lambda t: api.replanner(t, TRAIN, running_time=80.0, points=100)):
        with pytest.raises(api.InputError, match=r"^arguments: track\.length: Input should be greater than 0$"):
            call(short)
        with pytest.raises(api.InputError) as refused:
            call(fast)
        assert refused.value.problems[0] == ("arguments: track.limits[0] (as the file's speed_kmh): Input should be "
                                             "less than or equal to 1000")


def test_every_shipped_train_and_track_passes_and_a_sound_change_solves():
    from ecostudy.io.incode import built_problems  # here: the rest of the file runs without it

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the shipped files' own warnings (a train without curve resistance)
        trains = [api.load_train(p) for p in sorted(TRAINS.glob("*.yaml")) if "heavyhaul" not in p.name]
        tracks = [api.load_track(p) for p in sorted(TRACKS.glob("*.yaml"))]
    assert len(trains) >= 5 and len(tracks) >= 10
    assert [built_problems(train=t) for t in trains] == [[]] * len(trains)
    assert [built_problems(track=t) for t in tracks] == [[]] * len(tracks)
    run = api.solve(TRACK, dataclasses.replace(TRAIN, traction_efficiency=0.9), running_time=80.0, points=100)
    assert run.ok, run
