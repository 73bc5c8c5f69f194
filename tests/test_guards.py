"""Hostile input is refused in one line (exit 2) before anything is computed, valid data is not
refused, and nothing ends in an internal error, a hang or a silent wrong answer."""
import json
import re

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.errors import InputError
from ecostudy.io.documents import read_document
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.yamlsafe import MAX_NODES, check_nodes, load_yaml

from .conftest import DATA, STUDIES, TRACKS, TRAINS
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
    return [solve(track, load_train(ttobench_train(tmp, p, f"t{p:g}.json")), supplement_percent=10, points=300)
            for p in (1e6, 1e7)]


def test_a_no_limit_power_of_1e7_kW_solves_like_1e6_kW(no_limit_pair):
    e6, e7 = (s.summary["traction_energy_kWh"] for s in no_limit_pair)
    assert all(s.summary["solver"]["status"] == "optimal" and s.verification["passed"] for s in no_limit_pair)
    assert e7 == pytest.approx(e6, rel=1e-4)


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
