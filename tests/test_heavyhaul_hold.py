"""The heavy-haul hill start and the end of a run: the hold applies the brake that holds the grade
(not every wagon's full brake), a train held for the whole run says so and ends when it would stay
held, and a train still crawling on its final approach runs on until it stands."""
import numpy as np
import pandas as pd
import pytest

from ecostudy.heavyhaul.loop import STANDING, finished, mean_speed
from ecostudy.heavyhaul.plant import friction
from ecostudy.studies.heavyhaul import case_plant, expand

from .conftest import ROOT, load_yaml, write_yaml
from .test_heavyhaul_status import climb_study, invoke


def climb_plant(tmp_path, air_brake=True):
    """(plant, reference) of one locomotive and 40 wagons on 15 per mille from the start (3 km)."""
    path = climb_study(tmp_path, 0, start_permille=15, air_brake=air_brake, reference={"supplement_percent": 10, "points": 150})
    _, plant, reference = case_plant(expand(path)[3][0])
    return plant, reference


def test_the_hold_applies_the_brake_that_holds_the_grade(tmp_path):
    """One locomotive and 40 wagons (2766 t) standing on 15 per mille with the air brake on: the hold
    sets every wagon the same share of its brake, the share whose force at the plant's friction
    (rounded over 1 cm/s) balances the 407 kN the grade pulls back at the standing threshold's creep
    (0.02 m/s: 1.118 x 407 kN = 455 kN), far below the wagons' whole 7200 kN. Held on it for 60 s (the command
    kept) the train creeps back no faster than that; on 0.9 of it, faster."""
    plant, _ = climb_plant(tmp_path)
    state = plant.initial(head=100.0)
    pull = float(plant.resistance(state.positions, np.zeros(plant.n)).sum())
    assert 400e3 < pull < 420e3
    step = plant.hold(state, 20.0, STANDING)
    brakes = step.state.brakes
    whole = -plant.envelopes(np.zeros(plant.n))[0][~plant.loco].sum()
    assert -brakes.sum() == pytest.approx(pull / friction(STANDING), rel=1e-9)  # 1.118 x the pull
    assert -brakes.sum() < 0.5 * whole and (brakes[plant.loco] == 0).all()
    share = brakes[~plant.loco] / plant.envelopes(np.zeros(plant.n))[0][~plant.loco]
    assert np.ptp(share) < 1e-12  # every wagon the same share
    for scale, holds in ((1.0, True), (0.9, False)):
        held = step.state._replace(brakes=scale * brakes, commanded=scale * brakes)
        after = plant.step(held, scale * brakes, 60.0).state
        assert (mean_speed(plant, after) >= -STANDING) == holds, mean_speed(plant, after)
        assert mean_speed(plant, after) < 0.0  # the plant's friction is 0 at rest: it creeps


def test_a_train_crawling_on_its_final_approach_runs_on(tmp_path):
    """On the reference's final approach, short of the stop, a train at 0.1 m/s (under the 1 km/h a
    plan stops the train) has not finished its run; standing (0.01 m/s) or rolling back it has."""
    plant, reference = climb_plant(tmp_path, air_brake=False)
    where = 0.5 * (reference.final_approach + reference.distance[-1])
    for speed, done in ((0.1, False), (0.25, False), (0.01, True), (-0.1, True)):
        assert finished(plant, reference, plant.initial(head=where, speed=speed)) == done, speed


def test_a_train_held_at_the_start_for_the_whole_run_says_so(tmp_path):
    """The ore train on Vasteras - Kolback (10.8 per mille from the start, 1451 kN of grade) with Np =
    Nc = 1: the controller asks its locomotives for 1208 kN and no more, so the train stands held on
    its brakes; from the fifth sample on it is asked the same again from the same standing train, so
    the run ends there (not at the 1000-sample cap), flagged with the held time and why."""
    doc = load_yaml(ROOT / "studies" / "heavyhaul_vasteras_kolback.yaml")
    for name in ("consist", "track"):
        doc[name] = str((ROOT / "studies" / doc[name]).resolve())
    doc.update(brake_penalty=[60], horizons=[{"np": 1, "nc": 1}])
    write_yaml(tmp_path / "vk.yaml", doc)
    result = invoke(tmp_path / "vk.yaml", tmp_path / "out")
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert result.exit_code == 1 and run["status"] == "flagged" and not run["arrived"]
    assert run["ended"] == "held on its brakes" and run["held_at_end"] and run["samples"] < 10
    assert run["held_s"] == run["ended_s"] == 20 * run["samples"]  # held from the first sample
    assert np.isnan(run["arrival_s"]) and np.isnan(run["arrival_late_pct"])  # it never stood on the final approach
    assert run["traction_asked_at_end_kN"] < run["resistance_at_end_kN"]  # 1208 against 1451 kN measured
    assert run["reason"].startswith(f"held on its brakes at the start for {run['held_s']:.0f} s until the run ended "
                                    "(the same plan twice running from the same standing train")
    assert "never asked more traction" in run["reason"] and "sample cap (" not in run["reason"]
