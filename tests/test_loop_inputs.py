"""Closed-loop and batch study inputs that are refused before computing, and what the tables of
a closed-loop study count: small studies (K 100, one draw, open-loop replays) on the 1 km track."""
import warnings

import pandas as pd
import pytest

from ecostudy.core.errors import EcostudyWarning
from ecostudy.studies.cases import expand
from ecostudy.studies.closedloop import expand as expand_loop

from .conftest import TRACKS, TRAINS, write_yaml
from .test_bad_input_studies import refused, run


def loop_study(tmp_path, file="study.yaml", **changes):
    """A closed-loop study on the 1 km track: one open-loop replay, K 100, one draw."""
    doc = {"name": "small", "track": str(TRACKS / "yazhemsky2017_advanced_1km.yaml"),
           "train": str(TRAINS / "yazhemsky2017_commuter.yaml"), "window_s": [0, 200], "points": 100,
           "controllers": [{"name": "replay", "kind": "open_loop"}], "draws": 1, **changes}
    return write_yaml(tmp_path / file, doc)


@pytest.mark.parametrize("name", ["../../../escape", "a/b", "a\\b", "..", ".hidden", "tab\there"])
def test_a_controller_name_that_is_no_file_name_part_is_refused(tmp_path, name):
    """A controller's name is part of steps/<name>_draw<i>.csv: '../../../escape' wrote outside --out."""
    (tmp_path / "in").mkdir()
    study = loop_study(tmp_path / "in", controllers=[{"name": "fine", "kind": "open_loop"},
                                                     {"name": name, "kind": "open_loop"}])
    refused(run("simulate", study, "--workers", 1, "--no-plot", "--out", tmp_path / "in" / "out"),
            "controllers[1].name:", "file name")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["in", "study.yaml"]


def test_aggregate_counts_the_runs_computed_and_the_missing_apart(tmp_path):
    """One draw of both replays, then two draws of one (``--only b``): a's second run is missing, not
    a run (aggregate.csv said a: runs 2, arrived 1, as if one of two runs had not arrived)."""
    controllers = [{"name": "a", "kind": "open_loop"}, {"name": "b", "kind": "open_loop", "settings": {"time": 10}}]
    out = tmp_path / "o"
    first = run("simulate", loop_study(tmp_path, "one.yaml", controllers=controllers), "--workers", 1, "--no-plot",
                "--out", out)
    assert first.exit_code in (0, 1) and "missing" not in first.output.splitlines()[0], first.output
    second = run("simulate", loop_study(tmp_path, "two.yaml", controllers=controllers, draws=2), "--only", "b",
                 "--workers", 1, "--no-plot", "--out", out)
    assert second.exit_code == 1, second.output
    aggregate = pd.read_csv(out / "aggregate.csv").set_index("controller")
    assert list(aggregate.columns[:4]) == ["runs", "missing", "ok", "arrived"], aggregate.columns
    assert aggregate.loc["a", ["runs", "missing"]].tolist() == [1, 1], aggregate
    assert aggregate.loc["b", ["runs", "missing"]].tolist() == [2, 0], aggregate
    assert aggregate.loc["a", "arrived"] <= 1 and aggregate.loc["b", "arrived"] <= 2, aggregate
    header = next(line for line in second.output.splitlines() if "controller" in line).split()
    assert header[:5] == ["controller", "runs", "missing", "ok", "arrived"], header


def batch_study(tmp_path, **changes):
    """A batch study (``ecostudy run``) of the metro run at K 100, supplement 10 %."""
    doc = {"name": "batch", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
           "train": str(TRAINS / "amsterdam_metro.yaml"), "supplement_percent": 10, "points": 100,
           "output": str(tmp_path / "out"), **changes}
    return write_yaml(tmp_path / "batch.yaml", doc)


def test_a_scenario_with_two_timings_is_refused_as_the_study_is(tmp_path):
    """Scenario 'a' ran at 5 % over the all-out time, its 80 s dropped without a word."""
    study = batch_study(tmp_path, scenarios=[{"name": "ok", "running_time_s": 80},
                                             {"name": "a", "running_time_s": 80, "supplement_percent": 5}])
    refused(run("run", study, "--workers", 1), "scenarios[1].supplement_percent: running_time_s given too")
    assert not (tmp_path / "out").exists()
    both = batch_study(tmp_path, running_time_s=80)  # the study's own: the same words
    refused(run("run", both, "--workers", 1), ": supplement_percent: running_time_s given too")


@pytest.mark.parametrize("settings, fragment", [
    ({"brake_level_mps2": 1e300}, "controllers[0].settings: brake_level_mps2: 1e+300 m/s^2 is above 5, beyond any train"),
    ({"brake_level_mps2": 5.5}, "brake_level_mps2: 5.5 m/s^2 is above 5"),
    ({"time": 0, "energy": 0}, "controllers[0].settings: time, energy: both 0"),
])
def test_convex_settings_no_train_can_use_are_refused_before_computing(tmp_path, settings, fragment):
    """A braking level of 1e300 m/s^2 computed 146 s before 7000 solves gave no plan; both weights 0
    ran 17.5 m beyond the stop."""
    study = loop_study(tmp_path, controllers=[{"name": "convex", "kind": "convex", "settings": settings}],
                       sample_time_s=1.0)
    refused(run("simulate", study, "--workers", 1, "--no-plot", "--out", tmp_path / "out"), fragment)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("sweep", [{}, None, {"points": None}])
def test_an_empty_sweep_is_refused_as_an_empty_list_is(tmp_path, sweep):
    """``sweep: {}`` and ``sweep:`` ran the base case alone, exit 0."""
    refused(run("run", batch_study(tmp_path, sweep=sweep), "--workers", 1), "sweep: empty")
    assert not (tmp_path / "out").exists()


def test_a_scenario_das_beside_objective_time_advises_its_all_out_run(tmp_path):
    """A scenario's ``das: phases`` beside its ``objective: time`` was dropped without a word; it now
    advises the all-out run, as ``solve --objective time --das phases`` does, and is not warned of."""
    study = batch_study(tmp_path, supplement_percent=None, running_time_s=80,
                        scenarios=[{"name": "fast", "objective": "time", "das": "phases"}])
    with pytest.warns(EcostudyWarning) as seen:
        cases = expand(study)[2]
    said = [str(w.message) for w in seen]
    assert not any(".das:" in line or "read but not used" in line for line in said), said
    assert {c["scenario"]: c.get("das") for c in cases} == {"base": None, "fast": "phases"}, cases


def test_solves_refused_for_the_time_budget_are_counted_apart_from_slow_ones(tmp_path):
    """With time_budget_s 1e-6 every solve was refused, yet over_budget_count (solves slower than the
    sample) read 0 and no column counted them. The reason names the budget they went over."""
    study = loop_study(tmp_path, sample_time_s=1.0,
                       controllers=[{"name": "c", "kind": "convex", "time_budget_s": 1e-6}])
    result = run("simulate", study, "--workers", 1, "--no-plot", "--out", tmp_path / "out")
    assert result.exit_code == 1, result.output
    row = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert row["over_time_budget_count"] == row["failures_count"] > 0 and row["over_budget_count"] == 0, row
    assert f"{row['failures_count']} solves went over time_budget_s in " in row["reason"], row["reason"]
    aggregate = pd.read_csv(tmp_path / "out" / "aggregate.csv").iloc[0]
    assert aggregate["over_time_budget_count_sum"] == row["over_time_budget_count"], aggregate


def test_a_brake_level_the_trains_brakes_never_reach_is_warned_of(tmp_path):
    """The commuter train brakes at most 1.0 m/s^2 (its braking envelope's peak over its mass): a
    convex controller's B_brk of 1.5 (or 1.0) never sees braking beyond it, so its braking weight
    has no effect; it was read without a word. 0.8 is below and is not warned of; neither is a
    level with the braking weight 0 (nothing to penalise)."""
    def study(level, braking=1.0):
        return loop_study(tmp_path, controllers=[{"name": "c", "kind": "convex", "settings": {
            "brake_level_mps2": level, "braking": braking}}], output=str(tmp_path / "o"))
    for level in (1.5, 1.0):
        with pytest.warns(EcostudyWarning, match=rf"study.yaml: controllers\[0\].settings.brake_level_mps2: {level:g} "
                          r"m/s\^2 is at or above the strongest braking of the train '.*', 1 m/s\^2"):
            expand_loop(study(level))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        expand_loop(study(0.8))
        expand_loop(study(1.5, braking=0.0))
