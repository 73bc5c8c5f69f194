"""Hostile input is refused in one line (exit 2) before anything is computed, valid data is not
refused, and nothing ends in an internal error, a hang or a silent wrong answer."""
import json
import re

import pytest

from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.io.documents import read_document
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.yamlsafe import MAX_NODES, check_nodes, load_yaml

from .conftest import DATA, STUDIES, TRACKS, TRAINS, write_yaml
from .test_bad_input import one_line, run

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"


# ----------------------------------------------------------------------------------- alias bombs
def laughs(levels, width):
    """The 'billion laughs': each level a list of ``width`` aliases of the level below."""
    lines = [f"a0: &a0 [{', '.join(['lol'] * width)}]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * width)}]" for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("levels, width", [(9, 9), (8, 10), (30, 2), (2, 3000)])
def test_alias_bombs_are_refused_by_a_node_budget(tmp_path, levels, width):
    path = tmp_path / "bomb.yaml"
    path.write_text(laughs(levels, width))
    with pytest.raises(InputError, match="aliases expand to more than"):
        read_document(path)


def test_alias_bomb_is_refused_by_every_command(tmp_path):
    path = tmp_path / "bomb.yaml"
    path.write_text(laughs(9, 9))
    one_line(run("run", path), "bomb.yaml", "alias bomb")
    one_line(run("solve", "--track", AMS, "--train", path, "--time", 80, "--out", tmp_path / "o"), "bomb.yaml",
             "alias bomb")
    one_line(run("solve", "--track", path, "--train", METRO, "--time", 80, "--out", tmp_path / "o"), "bomb.yaml")


def test_aliases_within_the_budget_are_read_as_before():
    assert load_yaml("a: &a [1, 2]\nb: *a\nc: {<<: {x: 1}, y: 2}\n") == {"a": [1, 2], "b": [1, 2], "c": {"x": 1, "y": 2}}
    small = load_yaml(laughs(3, 9))  # 9^3 values: fine
    assert len(small["a3"]) == 9 and small["a3"][0][0][0][0] == "lol"
    assert len(load_yaml(laughs(4, 9))["a4"]) == 9  # 9^4 ≈ 6 600 values, far below the budget


def expanded(data):
    """Values in ``data`` once expanded, keys counted: what :func:`check_nodes` counts on the nodes."""
    if isinstance(data, dict):
        return 1 + sum(1 + expanded(v) for v in data.values())
    if isinstance(data, list):
        return 1 + sum(expanded(v) for v in data)
    return 1


@pytest.mark.parametrize("levels, width", [(3, 9), (5, 4), (1, 2)])
def test_the_budget_counts_expanded_values_exactly(levels, width):
    import yaml
    text = laughs(levels, width)
    size = expanded(load_yaml(text))
    node = yaml.compose(text, Loader=yaml.SafeLoader)
    check_nodes(node, budget=size)
    with pytest.raises(ValueError, match=f"expand to more than {size - 1:,} values"):
        check_nodes(node, budget=size - 1)
    assert MAX_NODES >= 1_000_000


@pytest.mark.parametrize("text, fragment", [
    ("a: &a [1, *a]\n", "refers to the value that contains it"),
    ("a: &a {b: *a}\n", "refers to the value that contains it"),
    ("a: &a [[[[1]]]]\nb: " + "[" * 62 + "*a" + "]" * 62 + "\n", "nested more than 64 levels"),
])
def test_recursive_and_deep_aliases_are_refused(tmp_path, text, fragment):
    path = tmp_path / "r.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=fragment):
        read_document(path)


def test_every_shipped_yaml_file_reads():
    for path in [*STUDIES.glob("*.yaml"), *TRAINS.glob("*.yaml"), *TRACKS.glob("*.yaml")]:
        assert isinstance(read_document(path), dict), path


# ----------------------------------------------------------------------------------- valid data refused
def ttobench_train(tmp_path, power_kW, name="t.json"):
    doc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    doc["max traction power"]["value"] = power_kW
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture(scope="module")
def no_limit_pair(tmp_path_factory):
    """The TTOBench subway train with 'max traction power' 1e6 kW and 1e7 kW ("no limit")."""
    from ecostudy.api import solve
    tmp = tmp_path_factory.mktemp("power")
    track = load_track(DATA / "ttobench_track.json")
    out = []
    for p in (1e6, 1e7):
        # neither limit can bind on this line: the solve drops the row and says so
        with pytest.warns(EcostudyWarning, match="traction power limit never binds: dropped") as notes:
            out.append(solve(track, load_train(ttobench_train(tmp, p, f"t{p:g}.json")), supplement_percent=10,
                             points=300))
        assert len(notes) >= 1
    return out


def test_a_no_limit_power_of_1e7_kW_solves_like_1e6_kW(no_limit_pair):
    e6, e7 = (s.summary["traction_energy_kWh"] for s in no_limit_pair)
    assert all(s.summary["solver"]["status"] == "optimal" and s.verification["passed"] for s in no_limit_pair)
    assert e7 == pytest.approx(e6, rel=1e-4)  # the same problem once the row is dropped: measured equal to 1e-12


@pytest.mark.parametrize("power", [1e7, 1e9, 3100.0])
def test_any_positive_finite_power_limit_is_read(tmp_path, power):
    assert load_train(ttobench_train(tmp_path, power)).traction.max_power == pytest.approx(power * 1e3)


@pytest.mark.parametrize("edit, fragment", [
    (lambda t: t.replace('"value": 3100.0', '"value": 0'), "max traction power"),
    (lambda t: t.replace('"value": 3100.0', '"value": -5'), "max traction power"),
    (lambda t: t.replace('"value": 3100.0', '"value": NaN'), "max traction power"),
    (lambda t: t.replace('"value": 3100.0', '"value": Infinity'), "max traction power"),
])
def test_non_positive_or_non_finite_power_limits_are_refused(tmp_path, edit, fragment):
    path = tmp_path / "t.json"
    path.write_text(edit((DATA / "ttobench_subway_train.json").read_text()))
    one_line(run("solve", "--track", DATA / "ttobench_track.json", "--train", path, "--supplement", 10,
                 "--out", tmp_path / "o", "--no-plot"), "t.json", fragment)


@pytest.mark.parametrize("value, ok", [("1.0e+7", True), ("0", False), (".nan", False), (".inf", False), ("-1", False)])
def test_yaml_train_power_limits(tmp_path, value, ok):
    text = METRO.read_text()
    assert "max_power_kW" in text
    path = tmp_path / "t.yaml"
    path.write_text(re.sub(r"max_power_kW: [0-9.e+]+", f"max_power_kW: {value}", text, count=1))
    if ok:
        assert load_train(path).regeneration.max_power == pytest.approx(1e10)
    else:
        with pytest.raises(InputError, match="max_power_kW"):
            load_train(path)


# ----------------------------------------------------------------------------------- silent wrong answers
LINE4 = TRACKS / "metro_line_4stops.yaml"


@pytest.mark.parametrize("stops, fragment", [
    ("", "--stops[0]: an empty stop name"),
    ("Noord,", "--stops[1]: an empty stop name"),
    (" ,Zuid", "--stops[0]: an empty stop name"),
    ("Noord,Station,Station,Zuid", "--stops[2]: 'Station' straight after 'Station'"),
    ("Noord,Nowhere", "--stops[1]: unknown stop 'Nowhere'"),
    ("Noord", "--stops: need two or more stops"),
])
def test_journey_stops_are_names_never_all_stops(tmp_path, stops, fragment):
    one_line(run("journey", "--track", LINE4, "--train", METRO, "--stops", stops, "--supplement", 10,
                 "--out", tmp_path / "o", "--no-plot"), fragment)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("options, fragment", [
    (["--from", ""], "command line: --from: unknown stop ''"),
    (["--to", ""], "command line: --to: unknown stop ''"),
])
def test_an_empty_stop_option_is_not_the_default_stop(tmp_path, options, fragment):
    one_line(run("solve", "--track", AMS, "--train", METRO, *options, "--time", 80, "--out", tmp_path / "o"), fragment)


@pytest.mark.parametrize("edit, fragment", [
    (lambda t: t.replace("{name: Station,", "{name: '',"), "stops[1].name: an empty name"),
    (lambda t: t.replace("{name: Station,", "{name: '   ',"), "stops[1].name: an empty name"),
    (lambda t: t.replace("name: Representative metro line, 4 stops", "name: ''"), "name: an empty name"),
])
def test_empty_names_in_files_are_refused(tmp_path, edit, fragment):
    path = tmp_path / "line.yaml"
    path.write_text(edit(LINE4.read_text()))
    one_line(run("journey", "--track", path, "--train", METRO, "--supplement", 10, "--out", tmp_path / "o"), fragment)


@pytest.mark.parametrize("stops, fragment", [
    (["Noord", ""], "stops[1]: an empty name"),
    (["Noord", "Noord", "Zuid"], "stops[1]: 'Noord' straight after 'Noord'"),
    (["Zuid"], "stops: need two or more stops"),
])
def test_network_study_stops(tmp_path, stops, fragment):
    from ecostudy.io.loaders import load_network_study
    doc = load_yaml((STUDIES / "network_metro_2trains.yaml").read_text())
    doc.update(track=str(LINE4), train=str(METRO), stops=stops)
    path = write_yaml(tmp_path / "net.yaml", doc)
    with pytest.raises(InputError, match=re.escape(fragment)):
        load_network_study(path)


def study_with(tmp_path, scenario):
    doc = load_yaml((STUDIES / "metro_supplements.yaml").read_text())
    doc.update(track=str(AMS), train=str(METRO), output=str(tmp_path / "out"), scenarios=[{"name": "bad", **scenario}])
    return write_yaml(tmp_path / "study.yaml", doc)


@pytest.mark.parametrize("scenario, fragment", [
    ({"train_overrides": {"mass_t": 1.0e9}}, "scenarios[0] (bad) train: mass_t"),
    ({"train_overrides": {"mas_t": 100}}, "mas_t: unknown field"),
    ({"train_overrides": {"mass_t": float("nan")}}, "mass_t: Input should be a finite number"),
    ({"train": "nowhere.yaml"}, "scenarios[0].train: 'nowhere.yaml': file not found"),
    ({"points": 5}, "scenarios[0].points"),
    ({"name": ""}, "scenarios[0].name: an empty name"),
])
@pytest.mark.parametrize("command", ["solve", "pareto", "compare"])
def test_commands_on_a_study_check_every_scenario_first(tmp_path, scenario, fragment, command):
    one_line(run(command, study_with(tmp_path, scenario), "--out", tmp_path / "o", "--no-plot"), fragment)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("count, top", [(2, 0.4), (3, 0.2), (4, 0.3), (5, 0.4), (20, 0.4), (20, 0.04), (37, 0.6),
                                        (100, 1.0)])
def test_a_front_has_exactly_count_points(count, top):
    from ecostudy.studies.pareto import REPORTED_SUPPLEMENTS, front_supplements
    points = front_supplements(count, top)
    assert len(points) == count and points[0] == 0 and points[-1] == pytest.approx(top)
    assert all(b > a for a, b in zip(points, points[1:]))
    if count >= 4:
        assert all(x in points.round(12) for x in REPORTED_SUPPLEMENTS if x <= top)


def test_no_plot_lists_no_plot(tmp_path):
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "speed.png").write_bytes(b"an earlier run's plot")
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 100, "--out", tmp_path / "o",
            "--no-plot")
    assert r.exit_code == 0, r.output
    assert "speed.png" not in r.output and "(profile.csv, inputs.json, report.html, summary.json)" in r.output
    assert not (tmp_path / "o" / "speed.png").exists()


def test_the_store_lock_is_removed_on_a_clean_exit_and_still_excludes_a_second_writer(tmp_path):
    from ecostudy.io.store import Store
    path = tmp_path / "results.sqlite"
    first = Store(path)
    assert (tmp_path / "results.sqlite.lock").exists()
    with pytest.raises(InputError, match="another ecostudy run is writing this store"):
        Store(path)
    first.close()
    assert not (tmp_path / "results.sqlite.lock").exists()
    second = Store(path)  # the next run takes it as before
    with pytest.raises(InputError, match="another ecostudy run"):
        Store(path)
    second.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.sqlite"]


KILLED_WRITER = """
import signal, sys, time
from ecostudy.io.store import Store
from ecostudy.studies.workers import worker_pool

def stubborn(_):
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a worker that outlives its parent for a while
    time.sleep(20)

store = Store(sys.argv[1])
with worker_pool(1) as pool:
    pool.submit(stubborn, 0)
    time.sleep(2)  # the worker has started and ignores SIGTERM
    print("ready", flush=True)
    time.sleep(60)
"""


def test_a_store_is_free_as_soon_as_its_writer_is_killed_even_while_a_worker_lives_on(tmp_path):
    """kill -9 of a study: its store's lock goes with the process, not with its last worker (a
    forked worker closes its copies of the parent's lock files, ``io.store.release_inherited``)."""
    import signal
    import subprocess
    import sys
    from ecostudy.io.store import Store
    path = tmp_path / "results.sqlite"
    writer = subprocess.Popen([sys.executable, "-c", KILLED_WRITER, str(path)], stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "ready"
        with pytest.raises(InputError, match="another ecostudy run is writing this store"):
            Store(path)  # the writer holds it
        writer.send_signal(signal.SIGKILL)
        writer.wait(timeout=30)
        Store(path).close()  # at once, while the stubborn worker still sleeps
    finally:
        writer.kill()
        subprocess.run(["pkill", "-KILL", "-f", str(path)], check=False)  # the worker ignores SIGTERM


def test_a_study_run_leaves_no_lock(tmp_path):
    doc = load_yaml((STUDIES / "metro_supplements.yaml").read_text())
    doc.update(track=str(AMS), train=str(METRO), points=60, scenarios=[], sweep={"supplement_percent": [10]})
    path = write_yaml(tmp_path / "study.yaml", doc)
    r = run("run", path, "--out", tmp_path / "o", "--no-progress")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "o" / "results.sqlite").exists() and not (tmp_path / "o" / "results.sqlite.lock").exists()


# ----------------------------------------------------------------------------------- internal errors
@pytest.fixture(scope="module")
def saved_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("saved") / "run"
    r = run("solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 100, "--out", out, "--no-plot")
    assert r.exit_code == 0, r.output
    return out


def edited_copy(saved_run, tmp_path, edit):
    import shutil
    folder = tmp_path / "copy"
    shutil.copytree(saved_run, folder)
    lines = (folder / "profile.csv").read_text().splitlines()
    (folder / "profile.csv").write_text("\n".join(edit(lines)) + "\n")
    return folder


def cell(lines, row, column, value):
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    return lines[:row] + [",".join(cells)] + lines[row + 1:]


@pytest.mark.parametrize("edit, fragments", [
    (lambda ls: ls[:40], ["profile.csv", "39 rows where the run has 100"]),
    (lambda ls: ls[:40] + [ls[40][:7]], ["profile.csv", "row 41", "is not a finite number"]),
    (lambda ls: cell(ls, 5, "speed_kmh", "nan"), ["speed_kmh, row 6: 'nan' is not a finite number"]),
    (lambda ls: cell(ls, 9, "time_s", "abc"), ["time_s, row 10: 'abc' is not a finite number"]),
    (lambda ls: cell(ls, 3, "traction_force_kN", "inf"), ["traction_force_kN, row 4: 'inf'"]),
    (lambda ls: cell(ls, 3, "position_m", "12.5"), ["position_m", "rows 3-4", "an edited profile"]),
    (lambda ls: [ls[0].replace("speed_kmh", "v")] + ls[1:], ["speed_kmh: missing column"]),
    (lambda ls: [], ["profile.csv: not a readable CSV table"]),
])
def test_check_refuses_a_damaged_profile_in_one_line(saved_run, tmp_path, edit, fragments):
    one_line(run("check", edited_copy(saved_run, tmp_path, edit)), *fragments)


def test_check_reads_an_intact_profile(saved_run):
    assert run("check", saved_run).exit_code == 0


def library_study(tmp_path, tracks):
    lib = tmp_path / "ttobench"
    (lib / "tracks").mkdir(parents=True)
    (lib / "trains").mkdir()
    (lib / "trains" / "subway.json").write_text((DATA / "ttobench_subway_train.json").read_text())
    for name, limit in tracks.items():
        doc = json.loads((DATA / "ttobench_track.json").read_text())
        doc["speed limits"]["values"] = [[0.0, limit]]
        (lib / "tracks" / f"{name}.json").write_text(json.dumps(doc))
    study = tmp_path / "lib.yaml"
    study.write_text(f"name: lib\nlibrary: {{path: ttobench}}\nsupplement_percent: 10\noutput: {tmp_path / 'out'}\n")
    return study


@pytest.mark.parametrize("tracks, fragment", [
    ({"T2": 200}, "no case to run: every track and train pair is left out (T2/subway: top speed 80 km/h"),
    ({"T2": 200, "T3": 300}, "T3/subway"),
    ({}, "no case to run: its tracks/ or trains/ folder holds no .json file"),
])
def test_a_library_study_with_no_cases_is_refused(tmp_path, tracks, fragment):
    one_line(run("run", library_study(tmp_path, tracks), "--no-progress"), "lib.yaml: library", fragment)


def test_an_empty_library_selection_is_refused(tmp_path):
    study = library_study(tmp_path, {"T1": 80})
    study.write_text(study.read_text().replace("{path: ttobench}", "{path: ttobench, tracks: []}"))
    one_line(run("run", study, "--no-progress"), "library.tracks")


@pytest.mark.parametrize("edit, fragment", [
    (lambda ls: cell(ls, 4, "speed_kmh", "fast"), "speed_kmh, row 5: 'fast' is not a finite number"),
    (lambda ls: cell(ls, 2, "distance_m", "nan"), "distance_m, row 3: 'nan'"),
    (lambda ls: cell(ls, 6, "distance_m", ""), "distance_m, row 7: '' is not a finite number"),
    (lambda ls: [ls[0].replace("distance_m", "x_m")] + ls[1:], "distance_m: missing column"),
])
def test_text_in_a_reference_table_is_one_line(tmp_path, edit, fragment):
    from ecostudy.studies.heavyhaul import expand
    doc = load_yaml((STUDIES / "heavyhaul_brake_penalty_limits.yaml").read_text())
    for key in ("consist", "track"):
        doc[key] = str((STUDIES / doc[key]).resolve())
    lines = (STUDIES / "heavyhaul_limit_reference.csv").read_text().splitlines()
    (tmp_path / "heavyhaul_limit_reference.csv").write_text("\n".join(edit(lines)) + "\n")
    with pytest.raises(InputError, match=re.escape(fragment)):
        expand(write_yaml(tmp_path / "study.yaml", doc))
