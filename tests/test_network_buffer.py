"""buffer_m in a network study: a strategy whose trains come closer than the buffer (without
overlapping) is flagged with its closest approach, and the strategies that keep the buffer keep it
(real solves: two metro trains 30 s apart on one segment, dt 1 s, buffer_m 150, which the
independent runs break by some 35 m)."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.types import Supply
from ecostudy.io.loaders import load_track, load_train
from ecostudy.network import fleet, strategies

from .conftest import TRACKS, TRAINS, write_yaml

BUFFER = 150.0
SLACK = 1e-3  # [m] what Ipopt may leave a separation row violated


def _fleet():
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    return fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 30.0], ["T1", "T2"], 1.0,
                      Supply(position=300.0), points=200, buffer=BUFFER)


def test_independent_runs_closer_than_the_buffer_are_flagged_with_the_closest_approach():
    """Each train alone ignores the other: T2's head comes within about 115 m of T1's tail, closer
    than buffer_m 150 m but no overlap; the result is flagged and says which trains, when, where."""
    out = strategies.run_strategies(_fleet(), ["independent"], progress=None)["independent"]
    gap = out["totals"]["separation_min_m"]
    assert 0.0 < gap < BUFFER - 10.0
    status = out["totals"]["status"]
    assert status.startswith("flagged") and "buffer_m 150 m" in status, status
    assert f"{gap:.1f} m" in status and "T2" in status and "T1" in status and " s" in status, status
    assert "overlap" not in status, status


@pytest.fixture(scope="module")
def buffered():
    return strategies.run_strategies(_fleet(), ["independent", "receptivity", "joint", "following"], progress=None)


@pytest.mark.slow
def test_the_rules_keep_the_buffer_and_never_return_the_independent_start_that_breaks_it(buffered):
    """The supervisor keeps its best round, the start included: the start (the independent runs)
    is cheaper here but breaks the buffer, so it is not a candidate."""
    rounds = buffered["receptivity"]["info"]["rounds_substation_kWh"]
    assert rounds[0] < min(rounds[1:])  # the independent start is the cheapest of the history
    totals = buffered["receptivity"]["totals"]
    assert totals["separation_min_m"] >= BUFFER - SLACK and totals["status"] == "ok", totals
    assert totals["substation_kWh"] == pytest.approx(min(rounds[1:]), rel=1e-9)


@pytest.mark.slow
def test_the_joint_optimum_keeps_the_buffer_and_bounds_the_strategies_that_keep_it(buffered):
    joint = buffered["joint"]["totals"]
    assert joint["separation_min_m"] >= BUFFER - SLACK and joint["status"] == "ok", joint
    for name in ("receptivity", "following"):
        assert buffered[name]["totals"]["status"] == "ok", (name, buffered[name]["totals"]["status"])
        assert joint["substation_kWh"] <= buffered[name]["totals"]["substation_kWh"] * (1 + 1e-4), name


@pytest.mark.slow
def test_the_command_exits_1_and_network_json_carries_each_strategys_own_status(tmp_path):
    """Through `ecostudy network`: the independent runs break the buffer, so the command exits 1 and
    says why; network.json's status of each strategy is the study's (ok / flagged), not the joint
    NLP's Ipopt status."""
    study = write_yaml(tmp_path / "s.yaml", {
        "name": "buffer", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "running_times_s": [56.0], "dwell_s": 10, "time_step_s": 1.0,
        "trains": [{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": 30}],
        "substation": {"position_m": 300}, "strategies": ["independent", "joint"], "buffer_m": BUFFER, "points": 200,
        "output": str(tmp_path / "out")})
    r = CliRunner().invoke(app, ["network", str(study), "--workers", "1", "--no-plot"])
    assert r.exit_code == 1 and "buffer_m 150 m" in r.output, r.output
    saved = json.loads((tmp_path / "out" / "network.json").read_text())["strategies"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert saved["independent"]["status"].startswith("flagged") and "buffer_m 150 m" in saved["independent"]["status"]
    assert saved["joint"]["status"] == "ok", saved["joint"]["status"]
    assert summary["status"] != "ok" and summary["cases"]["flagged"] == 1, summary["cases"]


@pytest.mark.slow
def test_a_new_run_ahead_that_leaves_the_train_behind_no_run_is_not_taken():
    """The 3-train study's rule 7.7: T2's first new run leaves T3 no run 60 m behind it (each leg
    of T3 planned behind it alone is infeasible); T2 keeps its run of the start and every round
    completes, keeping the buffer, where the strategy failed in its first round."""
    from ecostudy.core.errors import SolverError
    from ecostudy.network import rules
    from ecostudy.network.scoring import buffer_missed
    from ecostudy.studies.network import expand_network
    from .conftest import STUDIES
    f = expand_network(STUDIES / "network_metro_3trains.yaml").cases[0]["fleet"]
    start = rules.independent(f)
    order = fleet.departure_order(f)
    runs = list(start)
    runs[order[0]] = rules._replan(f, "triggering", runs, order, 0, {}, map, True)
    runs[order[1]] = rules._replan(f, "triggering", runs, order, 1, {}, map, True)
    with pytest.raises(SolverError, match="cannot keep buffer_m 60"):
        rules._replan(f, "triggering", runs, order, 2, {}, map, True)
    kept, history, stopped, held = rules.supervised(f, "triggering", start)
    assert stopped is None and len(history) == 4 and min(history[1:]) < history[0]
    t2, t3 = (f.names[order[k]] for k in (1, 2))
    assert held == {t2: f"from round 1 on: its new run left {t3} no run buffer_m 60 m behind it"}
    assert buffer_missed(f, kept) is None
    assert all(np.array_equal(a.s, b.s) for a, b in zip(kept[order[1]], start[order[1]]))  # T2 as it started


def test_no_saving_is_read_against_independent_runs_that_break_the_buffer(tmp_path):
    """The independent runs break the buffer (flagged): receptivity's 'saving_vs_independent_pct'
    (-31.5 %) and summary.json's least_saving_vs_independent_pct were measured against them as if
    they were a result. Now the savings are empty, and the table, the console and summary.json say why."""
    import pandas as pd
    study = write_yaml(tmp_path / "s.yaml", {
        "name": "buffer", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "running_times_s": [56.0], "dwell_s": 10, "time_step_s": 1.0,
        "trains": [{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": 30}],
        "substation": {"position_m": 300}, "strategies": ["independent", "receptivity"], "buffer_m": BUFFER,
        "points": 200, "output": str(tmp_path / "out")})
    r = CliRunner().invoke(app, ["network", str(study), "--workers", "1", "--no-plot"])
    assert r.exit_code == 1, r.output
    why = "saving_vs_independent_pct left empty: the independent run it is measured against is flagged"
    assert why in r.output, r.output
    table = pd.read_csv(tmp_path / "out" / "network_substation.csv").set_index("strategy")
    assert table.loc["receptivity", "status"] == "ok", table["status"]
    assert table["saving_vs_independent_pct"].isna().all(), table["saving_vs_independent_pct"]
    assert table["note"].str.startswith(why).all(), table["note"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["least_substation_strategy"] == "receptivity"
    assert summary["least_saving_vs_independent_pct"] is None and summary["saving_note"].startswith(why), summary


def test_one_train_has_no_separation_and_the_console_says_so_without_none(tmp_path):
    """One train has no train ahead: its separation_min_m was printed as 'None'; now '-' (empty in the csv)."""
    import pandas as pd
    study = write_yaml(tmp_path / "s.yaml", {
        "name": "one", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "running_times_s": [56.0], "dwell_s": 10, "time_step_s": 1.0,
        "trains": [{"name": "T1", "offset_s": 0}], "substation": {"position_m": 300}, "strategies": ["independent"],
        "points": 200, "output": str(tmp_path / "out")})
    r = CliRunner().invoke(app, ["network", str(study), "--workers", "1", "--no-plot"])
    assert r.exit_code == 0, r.output
    assert "None" not in r.output, r.output
    lines = [line.split() for line in r.output.splitlines()]
    at = next(i for i, words in enumerate(lines) if words[:1] == ["strategy"])  # the table's header, then its row
    header, row = lines[at], lines[at + 1]
    assert row[header.index("separation_min_m")] == "-", r.output
    assert pd.read_csv(tmp_path / "out" / "network_substation.csv")["separation_min_m"].isna().all()
