"""A study's scenarios: a train block overridden in part keeps the rest of the block, and a path given as
both track and train is read as each and the wrong one refused in one line."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.io.documents import overlaid

from .conftest import TRACKS, TRAINS, write_yaml

METRO = str(TRAINS / "amsterdam_metro.yaml")
LINE = str(TRACKS / "amsterdam_rokin_centraal.yaml")


def study(tmp_path, **fields):
    return write_yaml(tmp_path / "s.yaml", {"name": "scen", "track": LINE, "train": METRO, "from": "Rokin",
                                            "to": "Centraal", "running_time_s": 76, "points": 60, **fields})


def test_a_mapping_is_merged_field_by_field_and_any_other_value_replaced():
    doc = {"mass_t": 1, "regen": {"efficiency": 0.8, "max_force_kN": 150, "deep": {"a": 1, "b": 2}}, "table": [1, 2]}
    over = overlaid(doc, {"regen": {"efficiency": 0.6, "deep": {"b": 3}}, "table": [5], "mass_t": None})
    assert over == {"mass_t": None, "regen": {"efficiency": 0.6, "max_force_kN": 150, "deep": {"a": 1, "b": 3}},
                    "table": [5]}
    assert doc["regen"] == {"efficiency": 0.8, "max_force_kN": 150, "deep": {"a": 1, "b": 2}}  # not changed


def test_a_scenario_overriding_one_field_of_a_block_keeps_its_other_fields(tmp_path):
    """The metro's own regenerative efficiency (0.8) given alone changes nothing: its 150 kN and 2 MW
    regenerative limits stay (replaced whole, the block lost them and net energy fell about 12 %)."""
    path = study(tmp_path, objective="net_energy", scenarios=[
        {"name": "same", "train_overrides": {"regenerative_braking": {"efficiency": 0.8}}},
        {"name": "weaker", "train_overrides": {"regenerative_braking": {"efficiency": 0.6}}}])
    ran = CliRunner().invoke(app, ["run", str(path), "--workers", "1", "--out", str(tmp_path / "out")])
    assert ran.exit_code == 0, ran.output
    table = pd.read_csv(tmp_path / "out" / "results.csv").set_index("scenario")
    assert table.loc["same", "net_energy_kWh"] == pytest.approx(table.loc["base", "net_energy_kWh"], rel=1e-9)
    assert table.loc["weaker", "net_energy_kWh"] > table.loc["base", "net_energy_kWh"] * 1.05


@pytest.mark.parametrize("fields, said", [
    ({"track": METRO}, f"{METRO}: a train file"),
    ({"scenarios": [{"name": "odd", "track": METRO}]}, f"{METRO}: a train file"),
    ({"scenarios": [{"name": "odd", "train": LINE}]}, f"{LINE}: a track file"),
])
@pytest.mark.parametrize("command", ["run", "pareto"])
def test_one_path_as_track_and_train_is_refused_in_one_line(tmp_path, fields, said, command):
    """The study's files are read once per reader: a train file given as the track (where the train
    file was read before) is refused as a train file, not handed over as the train (exit 3)."""
    args = [command, str(study(tmp_path, **fields)), "--out", str(tmp_path / "out")]
    ran = CliRunner().invoke(app, args + (["--workers", "1"] if command == "run" else ["--no-plot"]))
    assert ran.exit_code == 2 and said in ran.output and len(ran.output.strip().splitlines()) == 1, ran.output


@pytest.mark.parametrize("command", ["pareto", "compare"])
def test_an_arrival_window_refused_by_name(tmp_path, command):
    ran = CliRunner().invoke(app, [command, str(study(tmp_path, running_time_s=None, window_s=[74, 80])),
                                   "--no-plot", "--out", str(tmp_path / "out")])
    assert ran.exit_code == 2 and "window_s: " + command + " does not keep an arrival window" in ran.output, ran.output


def test_a_block_given_another_form_says_how_blocks_merge_and_null_replaces_the_form(tmp_path):
    """The metro's traction is a table: an override giving max_force_kN and max_power_kW merges into it,
    both forms, refused with the way to switch; the table set to null, the scenario runs on the new form."""
    other = {"max_force_kN": 150, "max_power_kW": 1500}
    ran = CliRunner().invoke(app, ["run", str(study(tmp_path, scenarios=[{"name": "s", "train_overrides": {
        "traction": other}}])), "--workers", "1", "--out", str(tmp_path / "a")])
    assert ran.exit_code == 2 and len(ran.output.strip().splitlines()) == 1, ran.output
    assert "traction: give either 'table' or 'max_force_kN'" in ran.output and "set the file's other fields of it to " \
        "null, e.g. traction: {table: null, max_force_kN: 150}" in ran.output, ran.output
    ran = CliRunner().invoke(app, ["run", str(study(tmp_path, scenarios=[{"name": "s", "train_overrides": {
        "traction": {"table": None, **other}}}])), "--workers", "1", "--out", str(tmp_path / "b")])
    assert ran.exit_code == 0, ran.output
    table = pd.read_csv(tmp_path / "b" / "results.csv").set_index("scenario")
    assert table.loc["s", "status"] == "ok" and table.loc["s", "traction_energy_kWh"] != table.loc["base",
                                                                                                  "traction_energy_kWh"]
