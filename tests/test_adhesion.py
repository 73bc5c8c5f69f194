"""A point-mass train's adhesion limit (the train file's ``adhesion`` field): the traction envelope and
the electric brake capped at mu(v) m_adh g when the train is loaded (with a warning naming where),
every solved run within it, a run over it flagged, bad values refused, and a train without the field
(or whose envelope never reaches the limit) unchanged."""
import warnings
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from ecostudy.analysis.single import solve_run
from ecostudy.analysis.tables import regenerated_force
from ecostudy.cli import app
from ecostudy.core.adhesion import TOLERANCE, Adhesion, curtius_kniffler
from ecostudy.core.errors import EcostudyWarning
from ecostudy.core.physics import GRAVITY
from ecostudy.core.plant import Plant, Truth
from ecostudy.core.types import Timing
from ecostudy.core.units import KMH, TONNE
from ecostudy.io.loaders import load_track, load_train
from ecostudy.ocp.problem import prepare

from .conftest import DATA, TRACKS, TRAINS, load_yaml, write_yaml

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"


def metro_with(tmp_path, adhesion, name="metro.yaml"):
    """The Amsterdam metro (200 kN to 36 km/h, then 2 MW; electric brake 150 kN, 2 MW) with ``adhesion``."""
    doc = {**load_yaml(METRO), "max_speed_kmh": 90, "adhesion": adhesion}
    return write_yaml(tmp_path / name, doc)


def largest_use(train, limit, result):
    """The largest share of ``limit`` the solved run asks for: each interval's traction against mu m g
    at the faster of its two end speeds (mu falls with speed: the stricter end; the NLP bounds the
    force at both), its electric brake at the mean speed, where the run's accounting reads it
    (``tables.regenerated_force``)."""
    t = result.trajectory
    fast, mean = np.maximum(t.v[:-1], t.v[1:]), 0.5 * (t.v[:-1] + t.v[1:])
    electric = regenerated_force(train, t.v, t.fb)
    return float(max(np.max(t.ft / limit.limit(fast)), np.max(electric / limit.limit(mean))))


def test_curtius_and_kniffler_by_hand():
    """mu = 0.161 + 7.5 / (v + 44), v in km/h: 0.3315 at rest, 0.2548 at 36 km/h; 50 t adhesive
    mass transmits 0.3315 * 50 t * g = 162.5 kN at rest (the metro's motors: 200 kN)."""
    assert curtius_kniffler(0.0) == pytest.approx(0.161 + 7.5 / 44)
    assert curtius_kniffler(36 * KMH) == pytest.approx(0.161 + 7.5 / 80)
    assert Adhesion(50 * TONNE).limit(0.0) == pytest.approx(162.5e3, abs=50)
    assert Adhesion(50 * TONNE, "constant", 0.2).limit(np.array([0.0, 30.0])) == pytest.approx([0.2 * 50e3 * GRAVITY] * 2)


def test_a_too_strong_envelope_is_capped_warned_and_kept_by_the_solved_run(tmp_path):
    """50 t on the driven axles hold 162.5 kN at rest and 113 kN at 64 km/h, where the metro's 2 MW
    meet the grip: the envelope is capped below 64 km/h and the electric brake (150 kN, 2 MW) from
    8 to 64 km/h, each with one warning; the energy optimum in 80 s then asks at most 1 + 0.5 % of
    mu(v) m g (the table's chords and rounded kinks), passes the re-simulation with the check, and is
    ok. The same run without the field asks more than 1.2 times the grip (200 kN at 36 km/h where
    50 t hold 125 kN)."""
    path = metro_with(tmp_path, {"adhesive_mass_t": 50})
    with pytest.warns(EcostudyWarning) as caught:
        train = load_train(path)
    lines = [str(w.message) for w in caught]
    assert f"{path}: adhesion: traction envelope above adhesion (Curtius & Kniffler, 50 t adhesive) below 64 km/h: " \
           "capped there" in lines
    assert f"{path}: adhesion: regenerative braking above adhesion (Curtius & Kniffler, 50 t adhesive) from 8 to " \
           "64 km/h: capped there" in lines
    limit = train.adhesion
    speeds = np.linspace(0.0, 25.0, 2001)
    cap = np.minimum(load_train(METRO).traction.force(speeds), limit.limit(speeds))
    assert np.max(train.traction.force(speeds) / cap) < 1.005  # the curve every formulation and the plant see
    track = load_track(AMS)
    run = solve_run(track, train, "Rokin", "Centraal", Timing(running_time=80.0), points=150)
    assert run.ok, run.status
    use = largest_use(train, limit, run)
    assert 0.99 < use < 1.005  # the limit binds, and holds
    assert run.facts.verification.adhesion_use_max == pytest.approx(use, abs=0.01)
    assert run.summary["verification"]["tolerances"]["adhesion_use_max"] == 1 + TOLERANCE
    free = solve_run(track, load_train(METRO), "Rokin", "Centraal", Timing(running_time=80.0), points=150)
    assert largest_use(train, limit, free) > 1.2
    assert "adhesion_use_max" not in free.summary["verification"]  # a train without the field: as before


@pytest.mark.flagged_on_purpose
def test_a_run_over_the_limit_is_flagged(tmp_path):
    """A train whose adhesion limit is known but whose envelopes were not capped (built in code):
    its optimum pulls 200 kN at rest where 50 t hold 162.5 kN; the re-simulation's check finds the
    run asking about 1.2 of the grip and the run is flagged, naming it."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)
        capped = load_train(metro_with(tmp_path, {"adhesive_mass_t": 50}))
    metro = load_train(METRO)
    strong = replace(capped, traction=metro.traction, regeneration=metro.regeneration)
    run = solve_run(load_track(AMS), strong, "Rokin", "Centraal", Timing(running_time=80.0), points=150)
    ver = run.facts.verification
    assert ver.adhesion_use_max > 1.2 and not ver.passed
    assert run.status.kind == "flagged" and f"adhesion use {ver.adhesion_use_max:.3f} of mu(v) m_adh g" in run.status.reason


def test_an_envelope_within_the_limit_is_left_as_it_is(tmp_path):
    """All 131.4 t on driven axles hold 427 kN at rest and 280 kN at 90 km/h, above the metro's
    envelopes everywhere: no warning, the very same envelopes. A constant mu of 0.05 on 100 t holds
    49 kN, below the envelope's 80 kN at 90 km/h: capped at every speed, flat."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", EcostudyWarning)
        train = load_train(metro_with(tmp_path, {"adhesive_mass_t": 131.403}))
    metro = load_train(METRO)
    assert train.traction == metro.traction and train.regeneration == metro.regeneration
    assert train.adhesion == Adhesion(131.403 * TONNE) and metro.adhesion is None
    with pytest.warns(EcostudyWarning) as caught:
        flat = load_train(metro_with(tmp_path, {"adhesive_mass_t": 100, "law": "constant", "mu": 0.05}))
    assert [str(w.message).split(": ", 2)[2] for w in caught] == [
        f"{what} above adhesion (mu 0.05, 100 t adhesive) at every speed up to 90 km/h: capped there"
        for what in ("traction envelope", "regenerative braking")]
    assert flat.traction.force(np.array([0.0, 10.0, 24.0])) == pytest.approx([0.05 * 100e3 * GRAVITY] * 3, rel=2e-3)


@pytest.mark.parametrize("adhesion, fragment", [
    ({"adhesive_mass_t": -5}, "adhesion.adhesive_mass_t: Input should be greater than 0"),
    ({"adhesive_mass_t": 500}, "adhesion.adhesive_mass_t: 500 t exceeds mass_t (131.403 t)"),
    ({"adhesive_mass_t": 50, "law": "wet"}, "adhesion.law: Input should be 'curtius_kniffler' or 'constant'"),
    ({"adhesive_mass_t": 50, "law": "constant"}, "adhesion: law 'constant' needs mu"),
    ({"adhesive_mass_t": 50, "mu": 0.3}, "adhesion: mu goes with law 'constant'"),
    ({"adhesive_mass_t": 50, "law": "constant", "mu": 1.5}, "adhesion.mu: Input should be less than or equal to 1"),
    ({"adhesive_mass_tonnes": 50}, "adhesion.adhesive_mass_tonnes: unknown field"),
])
def test_bad_adhesion_values_are_one_line(tmp_path, adhesion, fragment):
    path = metro_with(tmp_path, adhesion)
    result = CliRunner().invoke(app, ["solve", "--track", str(AMS), "--train", str(path), "--time", "80",
                                      "--points", "50", "--out", str(tmp_path / "o"), "--no-plot"])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) <= 2 and "Traceback" not in result.output, result.output  # a missing and an unknown field: two
    assert any(f"{path}: {fragment}" in line for line in lines), result.output
    assert not (tmp_path / "o").exists()


def test_a_true_train_stronger_than_its_model_still_transmits_at_most_the_limit(tmp_path):
    """Closed loop drives a plant whose true traction may exceed the model's (``Truth.traction``): 1.5
    times the capped envelope would pull 244 kN at rest, where 50 t hold 162.5 kN; the plant applies
    the limit. Without the field the stronger train pulls its 1.5 times (the model's choice)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)
        train = load_train(metro_with(tmp_path, {"adhesive_mass_t": 50}))
    segment = prepare(load_track(AMS), train, "Rokin", "Centraal", 50, {}).segment
    for v in (0.0, 5.0, 15.0):
        ft, _ = Plant(segment, train, Truth(traction=1.5)).forces(v, 1.0, 0.0)
        assert ft == pytest.approx(train.adhesion.limit(v), rel=1e-9)
    metro = load_train(METRO)
    assert Plant(segment, metro, Truth(traction=1.5)).forces(0.0, 1.0, 0.0)[0] == pytest.approx(300e3)


def test_a_study_warns_once_naming_the_train_file(tmp_path):
    """A study file's train is read twice (the base case and the study's cases): its warnings are
    one line each, naming the train file, not the study."""
    train = metro_with(tmp_path, {"adhesive_mass_t": 50})
    study = write_yaml(tmp_path / "s.yaml", {"name": "s", "track": str(AMS), "train": str(train), "from": "Rokin",
                                             "to": "Centraal", "running_time_s": 80, "points": 50})
    result = CliRunner().invoke(app, ["solve", str(study), "--out", str(tmp_path / "o"), "--no-plot"])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if "above adhesion" in line]
    assert [line.split(": adhesion: ")[0] for line in lines] == [f"warning: {train}"] * 2, result.output
    assert sum("traction envelope" in line for line in lines) == 1


def test_a_scenario_gives_a_published_train_its_adhesion(tmp_path):
    """TTOBench's train files have no adhesion field; a study's scenario adds one through
    ``train_overrides``: the subway train's 310 kN against 80 t (261 kN at rest) is capped, warned
    naming the scenario (the base train, without the field, warns of nothing), and both runs are ok."""
    study = write_yaml(tmp_path / "s.yaml", {
        "name": "s", "track": str(DATA / "ttobench_track.json"), "train": str(DATA / "ttobench_subway_train.json"),
        "supplement_percent": 10, "points": 100, "output": str(tmp_path / "o"),
        "scenarios": [{"name": "grip80", "train_overrides": {"adhesion": {"adhesive_mass_t": 80}}}]})
    result = CliRunner().invoke(app, ["run", str(study), "--workers", "1", "--no-progress"])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if "above adhesion" in line]
    assert lines == [f"warning: {study}: scenarios[0] (grip80): adhesion: traction envelope above adhesion (Curtius & "
                     "Kniffler, 80 t adhesive) below 61 km/h: capped there",
                     f"warning: {study}: scenarios[0] (grip80): adhesion: regenerative braking above adhesion (Curtius "
                     "& Kniffler, 80 t adhesive) at every speed up to 80 km/h: capped there"], result.output
    table = load_yaml(tmp_path / "o" / "summary.json")  # JSON is YAML
    assert table["cases"]["ok"] == 2, table
