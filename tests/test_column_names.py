"""Every number every command writes is named by one rule (``ecostudy.core.columns``, docs/formats.md
"Column names"): each command runs once, small, and each numeric column of its CSV tables and each
number of its JSON files is checked; a name off the rule fails naming the command, file and column."""
import json

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.columns import json_offences, offence, table_offences

from .test_html_commands import METRO, command

COMMANDS = ["solve", "pareto", "compare", "journey", "run", "network", "simulate", "heavyhaul", "calibrate",
            "validate"]


def offences(folder):
    """['file: column: what is wrong'] of every CSV and JSON file under ``folder``."""
    out = []
    for path in sorted(folder.rglob("*")):
        if path.suffix == ".csv":
            table = pd.read_csv(path)
            numeric = [c for c in table.columns if pd.api.types.is_numeric_dtype(table[c])
                       and not pd.api.types.is_bool_dtype(table[c]) and table[c].notna().any()]  # empty: no number
            found = table_offences(list(table.columns), numeric)
        elif path.suffix == ".json":
            found = json_offences(json.loads(path.read_text()))
        else:
            continue
        out += [f"{path.relative_to(folder)}: {name}: {why}" for name, why in found.items()]
    return out


def small_run(name, tmp_path):
    if name == "solve":
        return ["solve", *METRO, "--time", "80", "--points", "150", "--das", "round", "--out", str(tmp_path / "out")]
    if name == "pareto":
        return ["pareto", *METRO, "--count", "3", "--points", "150", "--weighted", "2", "--out", str(tmp_path / "out")]
    return command(name, tmp_path)


@pytest.mark.parametrize("name", COMMANDS)
def test_every_number_a_command_writes_is_named_by_the_rule(name, tmp_path):
    done = CliRunner().invoke(app, [*small_run(name, tmp_path), *([] if name == "run" else ["--no-plot"])])
    assert done.exit_code in (0, 1), done.output
    found = offences(tmp_path / "out")
    if name == "solve":  # check and export write into a solve folder: their files too
        for more in (["check", str(tmp_path / "out")], ["export", str(tmp_path / "out"), "--every", "10m"]):
            assert CliRunner().invoke(app, more).exit_code in (0, 1)
        found = offences(tmp_path / "out")
    assert not found, f"ecostudy {name} writes numbers named off the rule:\n" + "\n".join(found)


@pytest.mark.parametrize("good", ["stop_error_m", "force_max_kN", "solve_mean_max_ms", "energy_J_per_kg",
                                  "marginal_saving_kWh_per_s", "handle_changes", "adhesion_use_max", "K_b"])
def test_names_on_the_rule_pass(good):
    assert offence(good) is None


@pytest.mark.parametrize("bad, why", [("max_overspeed_kmh", "a statistic first"), ("stop_error_m_max", "after the unit"),
                                      ("softened", "no unit"), ("seconds", "no unit"), ("supplement_percent", "no unit"),
                                      ("rainflow_cycles_100kN", "no unit")])
def test_names_off_the_rule_are_named(bad, why):
    assert why in offence(bad)


def test_a_json_block_named_with_a_unit_gives_it_to_its_keys():
    assert json_offences({"stages_s": {"grid": 0.1}, "cases": {"total": 2}, "plain": {"speed": 3.0}}) \
        == {"plain.speed": "no unit: end it in a unit of ecostudy.core.columns.UNITS or a word of DIMENSIONLESS"}


OLD_NAMES = {"overspeed_max_kmh": "max_overspeed_kmh", "wall_s": "seconds",
             "constraint_violation_max": "max_constraint_violation"}


def _old(data):
    """``data`` with the keys as an ecostudy before the naming rule wrote them."""
    if isinstance(data, dict):
        return {OLD_NAMES.get(k, k): _old(v) for k, v in data.items()}
    return [_old(v) for v in data] if isinstance(data, list) else data


def test_a_solve_folder_with_the_previous_names_is_still_read(tmp_path):
    """``api.load(...).run()``, ``check`` and ``export`` read a run's summary.json written with
    ``max_overspeed_kmh``, ``seconds`` and ``max_constraint_violation`` as they read the current one."""
    from ecostudy import api
    out = tmp_path / "out"
    assert CliRunner().invoke(app, small_run("solve", tmp_path)[:-4] + ["--out", str(out), "--no-plot"]).exit_code == 0
    now = api.load(out).run()
    path = out / "summary.json"
    path.write_text(json.dumps(_old(json.loads(path.read_text()))))
    assert "max_overspeed_kmh" in path.read_text() and "overspeed_max_kmh" not in path.read_text()
    before = api.load(out).run()
    assert before.verification == now.verification and before.solver == now.solver
    for more in (["check", str(out)], ["export", str(out), "--every", "10m"]):
        done = CliRunner().invoke(app, more)
        assert done.exit_code == 0, done.output
