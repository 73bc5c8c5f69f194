"""Unclear messages made clear and runaways refused before computing with their estimate
(``--force`` to run anyway); the companion of ``test_guards.py``."""
import json
import re

import pytest

from ecostudy.core.errors import InputError
from ecostudy.io.loaders import load_train
from ecostudy.io.yamlsafe import load_yaml

from .conftest import DATA, STUDIES, TRACKS, TRAINS, write_yaml
from .test_bad_input import one_line, run

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"
LINE4 = TRACKS / "metro_line_4stops.yaml"


# ----------------------------------------------------------------------------------- unclear messages
def weak_train(tmp_path, share):
    """The Yazhemsky 2017 commuter train with ``share`` of its traction force table."""
    text = (TRAINS / "yazhemsky2017_commuter.yaml").read_text()
    table = re.search(r"force_kN: \[([^\]]*)\]", text)
    forces = ", ".join(f"{float(x) * share:g}" for x in table.group(1).split(","))
    path = tmp_path / f"weak{share:g}.yaml"
    path.write_text(text[:table.start()] + f"force_kN: [{forces}]" + text[table.end():])
    return path


def hill(tmp_path, permille):
    text = (TRACKS / "yazhemsky2017_advanced_1km.yaml").read_text()
    text = text.replace("{position_m: 200, gradient_permille: -20.3943}", "{position_m: 200, gradient_permille: 0}")
    text = text.replace("{position_m: 400, gradient_permille: 20.3943}", f"{{position_m: 400, gradient_permille: {permille}}}")
    path = tmp_path / "hill.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("share, permille, fragments", [
    (0.05, 20.3943, ["the train cannot climb", "stops 4", "m after A", "kN of gradient and curves"]),
    (0.05, 60, ["the train cannot climb", "m after A"]),
    (0.01, 20.3943, ["the train cannot overcome its running resistance", "stops 0 m after A"]),
])
def test_a_train_that_cannot_climb_is_told_where(tmp_path, share, permille, fragments):
    r = run("solve", "--track", hill(tmp_path, permille), "--train", weak_train(tmp_path, share), "--time", 200,
            "--out", tmp_path / "o", "--no-plot")
    one_line(r, "infeasible:", *fragments)
    assert "nan" not in r.output


def weak_brakes(tmp_path, share):
    """The Yazhemsky 2017 commuter train with ``share`` of its braking force (its braking envelope and
    service deceleration scaled)."""
    doc = load_yaml((TRAINS / "yazhemsky2017_commuter.yaml").read_text())
    braking = doc["braking"]
    for key in ("max_force_kN", "max_power_kW"):
        if key in braking:
            braking[key] *= share
    if "table" in braking:
        braking["table"]["force_kN"] = [f * share for f in braking["table"]["force_kN"]]
    return write_yaml(tmp_path / f"weak_brakes{share:g}.yaml", doc)


def descent_then_slow(tmp_path):
    """1.5 km: level, 40 per mille down from 200 to 700 m, level again with 20 km/h from 700 m to the stop."""
    return write_yaml(tmp_path / "descent.yaml", {
        "name": "descent", "source": "made for this test", "length_m": 1500,
        "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1500}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}, {"position_m": 200, "gradient_permille": -40},
                      {"position_m": 700, "gradient_permille": 0}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 80}, {"position_m": 700, "speed_kmh": 20}]})


@pytest.mark.parametrize("track, fragments", [
    (lambda tmp: hill(tmp, -60), ["the train runs away", "m after A", "cannot stand at the stop"]),
    (descent_then_slow, ["the train runs away", "kN more than its brakes and resistance hold",
                         "cannot keep to 20 km/h at 700 m after A"]),
])
def test_a_train_whose_brakes_cannot_hold_it_is_told_where(tmp_path, track, fragments):
    """A descent its brakes (2 % of the commuter train's) cannot hold: refused before any solve with
    the limit or stop it cannot keep (without the check the all-out NLP failed: exit 3)."""
    r = run("solve", "--track", track(tmp_path), "--train", weak_brakes(tmp_path, 0.02), "--time", 300,
            "--out", tmp_path / "o", "--no-plot")
    one_line(r, "infeasible:", *fragments)
    assert not (tmp_path / "o").exists()


def test_a_closed_loop_study_of_a_train_that_cannot_run_says_why(tmp_path):
    doc = load_yaml((STUDIES / "yazhemsky2017_closed_loop.yaml").read_text())
    doc.update(track=str(TRACKS / "yazhemsky2017_advanced_1km.yaml"), train=str(weak_train(tmp_path, 0.01)),
               output=str(tmp_path / "out"))
    r = run("simulate", write_yaml(tmp_path / "loop.yaml", doc), "--no-progress")
    one_line(r, "the train cannot overcome its running resistance")
    assert "nan" not in r.output


def test_a_journey_through_a_repeated_stop_is_refused_not_stalled(tmp_path):
    r = run("journey", "--track", LINE4, "--train", METRO, "--stops", "Noord,Station,Station", "--time", 200,
            "--out", tmp_path / "o")
    one_line(r, "'Station' straight after 'Station'")
    assert "stalls" not in r.output and "warning" not in r.output


@pytest.mark.parametrize("limit", [1, 3])
def test_a_minlp_search_stops_at_its_time_limit_and_says_so(tmp_path, limit):
    """The search runs in a child process killed at the limit: it ends within a generous bound
    (three times the limit, the parent's clock around the child) and its status says the limit
    ended it; no bound is claimed, and no raw solver line reaches the output."""
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 200, "--das", "minlp",
            "--das-time-limit", limit, "--out", tmp_path / "o", "--no-plot")
    assert r.exit_code in (0, 1), r.output
    das = json.loads((tmp_path / "o" / "summary.json").read_text())["das"]
    assert das["search_s"] <= 3 * limit, das
    assert das["search_time_limit_reached"] and f"its {limit} s time limit" in das["status"], das
    line = next(x for x in r.output.splitlines() if "OA iterations" in x)
    assert "no bound" in line and das["bound_kWh"] is None, line
    assert all("against ATO" in x for x in r.output.splitlines() if "MindtPy" in x), r.output  # no raw solver line
    assert das["traction_energy_kWh"] > 0 and abs(das["stop_error_m"]) < 1.0


def test_work_past_its_deadline_is_stopped_and_what_it_posted_kept():
    """The deadline runner on plain Python work: a loop that never ends is killed at its deadline
    with the messages it posted; work that ends returns its value; an exception is reported."""
    from ecostudy.core.deadline import run_until

    def forever(post):
        i = 0
        while True:
            i += 1
            if i % 100000 == 0:
                post(i)

    ended = run_until(0.5, forever)
    assert ended.stopped and not ended.finished and ended.posts and ended.seconds < 10
    done = run_until(30, lambda post, x: post(x) or 2 * x, 21)
    assert done.finished and done.value == 42 and done.posts == [21]
    failed = run_until(30, lambda post: 1 / 0)
    assert not failed.finished and "ZeroDivisionError" in failed.error


# ----------------------------------------------------------------------------------- runaways
def network_study(tmp_path, **fields):
    doc = load_yaml((STUDIES / "network_metro_2trains.yaml").read_text())
    doc.pop("supplement_percent")
    doc.update(track=str(LINE4), train=str(METRO), output=str(tmp_path / "out"), **fields)
    return write_yaml(tmp_path / "net.yaml", doc)


@pytest.mark.parametrize("fields, fragments", [
    ({"running_times_s": [1e7, 200, 120]}, ["running_times_s[0]", "1e+07 s is over 5 times the fastest"]),
    ({"running_times_s": [60, 2e5, 120]}, ["running_times_s[1]", "200000 s is over 5 times the fastest"]),
    ({"running_times_s": [60, 80, 1e5], "time_step_s": 0.05}, ["running_times_s[2]", "100000 s is over 5 times"]),
])
def test_a_network_leg_that_would_crawl_is_refused_before_its_size(tmp_path, fields, fragments):
    """A leg far slower than the train's fastest run is refused as a crawl (``core.defaults.SLOWEST``)
    before its clock steps are counted: no leg a file can give reaches the runaway estimate below."""
    r = run("network", network_study(tmp_path, **fields), "--no-plot")
    one_line(r, "net.yaml", "the train would crawl", *fragments)
    assert not (tmp_path / "out").exists()


def small_steps(tmp_path, dt, **fields):
    """A network study loaded, then given clock steps of ``dt`` [s] (below what a file may give)."""
    import dataclasses
    from ecostudy.io.loaders import load_network_study
    path = network_study(tmp_path, **fields)
    return dataclasses.replace(load_network_study(path), dt=dt), path


@pytest.mark.parametrize("fields, fragments", [
    ({"running_times_s": [200, 200, 120]}, ["running_times_s[0]", "2,000,000 clock steps"]),
    ({"supplement_percent": 100}, ["supplement_percent: the leg Noord - Station", "clock steps"]),
])
def test_a_network_leg_too_big_is_refused_with_its_estimate(tmp_path, fields, fragments):
    """The legs' runaway estimate (``studies.estimate.check_network``) on clock steps of 0.1 ms."""
    from ecostudy.studies.estimate import check_network
    study, path = small_steps(tmp_path, 1e-4, **fields)
    with pytest.raises(InputError) as refused:
        check_network(study, path)
    for fragment in ["net.yaml", "an estimated", "--force", *fragments]:
        assert fragment in str(refused.value), str(refused.value)


def test_force_lifts_the_estimate_and_nothing_else(tmp_path):
    from ecostudy.core.budget import forced
    from ecostudy.studies.estimate import check_network
    study, path = small_steps(tmp_path, 1e-4, running_times_s=[200, 200, 120])
    with pytest.raises(InputError, match="--force"):
        check_network(study, path)
    with forced():
        check_network(study, path)
    with pytest.raises(InputError, match="--force"):
        check_network(study, path)  # only inside the block


def closed_loop_study(tmp_path, traction, draws=1):
    doc = {"name": "weak", "track": str(AMS), "train": str(METRO), "window_s": [0, 76], "points": 200,
           "sample_time_s": 0.1, "controllers": [{"name": "convex", "kind": "convex"}],
           "deviations": {"traction": {"low": traction[0], "high": traction[1]}}, "draws": draws,
           "output": str(tmp_path / "out")}
    return write_yaml(tmp_path / "loop.yaml", doc)


@pytest.mark.parametrize("traction, draws, fragments", [
    ((0.01, 0.01), 1, ["convex draw 0", "traction x0.01", "cannot overcome its running resistance",
                       "the loop's cap of 22,720 s"]),
    ((0.01, 1.0), 40, ["cannot reach the stop", "22,720 s"]),
    ((0.015, 0.02), 2, ["convex draw 0", "cannot reach the stop"]),
])
def test_a_closed_loop_run_that_would_run_to_the_cap_is_refused(tmp_path, traction, draws, fragments):
    r = run("simulate", closed_loop_study(tmp_path, traction, draws), "--no-progress", "--no-plot")
    one_line(r, "loop.yaml: deviations", "--force", *fragments)
    assert not (tmp_path / "out" / "results.sqlite").exists()


def test_every_shipped_study_passes_the_estimates():
    from ecostudy.io.loaders import load_network_study
    from ecostudy.studies.closedloop import expand
    from ecostudy.studies.estimate import check_closed_loop, check_network
    for name in ("network_metro_2trains", "network_metro_3trains", "network_regional_20stops"):
        path = STUDIES / f"{name}.yaml"
        check_network(load_network_study(path), path)
    for name in ("metro_monte_carlo", "yazhemsky2017_closed_loop", "yazhemsky2017_monte_carlo"):
        path = STUDIES / f"{name}.yaml"
        check_closed_loop(expand(path)[2], path)


@pytest.mark.parametrize("points", [5001, 1_000_000])
def test_an_effort_curve_of_a_million_points_is_refused_at_once(tmp_path, points):
    import numpy as np
    doc = json.loads((DATA / "osrd_rolling_stock.json").read_text())
    speeds = np.linspace(0, 40, points)
    efforts = np.interp(speeds, [0, 10, 20, 30, 40], [2e5, 2e5, 1.1e5, 7.5e4, 5.6e4])
    doc["effort_curves"]["modes"]["1500V"]["default_curve"] = {"speeds": speeds.tolist(),
                                                               "max_efforts": efforts.tolist()}
    path = tmp_path / "stock.json"
    path.write_text(json.dumps(doc))
    one_line(run("solve", "--track", AMS, "--train", path, "--supplement", 10, "--out", tmp_path / "o"),
             "stock.json: effort_curves.modes.1500V", f"a table of {points:,} points", "at most 5,000 points",
             "--force")


def test_a_table_at_the_limit_is_read(tmp_path):
    import numpy as np
    doc = load_yaml(METRO.read_text())
    speeds = np.linspace(0, 90, 5000)
    doc["traction"] = {"table": {"speed_kmh": speeds.tolist(),
                                 "force_kN": np.interp(speeds, [0, 60, 80, 90], [171, 171, 150, 140]).tolist()}}
    train = load_train(write_yaml(tmp_path / "t.yaml", doc))
    assert train.traction.force(10.0) == pytest.approx(171e3, rel=1e-3)


def test_force_reads_a_long_table_here_and_in_workers_started_inside(tmp_path):
    import os

    import numpy as np

    from ecostudy.core.budget import ENVIRONMENT, forced
    doc = load_yaml(METRO.read_text())
    speeds = np.linspace(0, 90, 6000)
    doc["traction"] = {"table": {"speed_kmh": speeds.tolist(),
                                 "force_kN": np.interp(speeds, [0, 60, 80, 90], [171, 171, 150, 140]).tolist()}}
    path = write_yaml(tmp_path / "t.yaml", doc)
    with pytest.raises(InputError, match="a table of 6,000 points"):
        load_train(path)
    with forced():
        assert os.environ[ENVIRONMENT] == "1"  # inherited by the worker processes a command starts
        assert load_train(path).traction.force(10.0) == pytest.approx(171e3, rel=1e-3)
    assert ENVIRONMENT not in os.environ


def test_the_deadline_runner_runs_inline_where_no_child_may_be_started():
    """In a daemonic process (a Dask worker) the work runs in place, held only by its own limit."""
    import multiprocessing
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    worker = ctx.Process(target=_inline_probe, args=(queue,), daemon=True)
    worker.start()
    worker.join(60)
    assert queue.get(timeout=5) == (True, 42, [21])


def _inline_probe(queue):
    from ecostudy.core.deadline import run_until
    ended = run_until(30, lambda post, x: post(x) or 2 * x, 21)
    queue.put((ended.finished, ended.value, ended.posts))
