"""The benchmark harness (``bench/harness.py``, ``python -m bench``): a real case through it, the
table's medians and ratios, the list of every script's cases, and the command line's refusals."""
import importlib.util
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402

# the scripts the docs quote for speed claims: each registers its cases
PRIORITY = ["solve.energy", "solve.time", "leg_options.none", "network.joint", "sizes.run", "monte_carlo.trip",
            "sbpc.nominal", "heavyhaul.qp"] + (["lean.ecostudy", "lean.lean", "casadi.ecostudy", "casadi.casadi"]
                                               if importlib.util.find_spec("casadi") else [])


@pytest.fixture(scope="module")
def solved():
    """solve.energy at K = 60 three times, against solve.time (its reference here) in the same process
    (no files written: the figures would take most of the time)."""
    harness.load(["solve"])
    energy = harness.CASES["solve.energy"]
    harness.register("solve.energy_vs_time", energy.run, params=energy.params, reference="solve.time")
    try:
        yield harness.measure(["solve.energy_vs_time"], 3, {"points": 60, "write": False})
    finally:
        harness.CASES.pop("solve.energy_vs_time")


def test_a_real_case_gives_medians_spreads_stages_and_a_ratio(solved):
    assert list(solved) == ["solve.energy_vs_time", "solve.time"]  # the reference was run too
    runs = solved["solve.energy_vs_time"]
    assert len(runs) == 3 and runs.params["points"] == 60
    rows = {r["case"]: r for r in harness.summarise(solved)}
    row = rows["solve.energy_vs_time"]
    assert row["status"] == "ok" and row["repeats"] == 3 and row["ipopt"] == "optimal" and row["verified"] is True
    walls = [s["wall_s"] for s in runs]
    assert row["wall_s"] == statistics.median(walls)
    assert row["wall_s_min"] == min(walls) <= row["wall_s"] <= row["wall_s_max"] == max(walls)
    assert row["cpu_s"] == statistics.median(s["cpu_s"] for s in runs) > 0
    for stage in ("load", "grid", "build", "nl_write", "solve", "verify", "write"):  # per-stage seconds
        assert 0 <= row[f"{stage}_s"] <= row["wall_s_max"]
    assert 6.0 < row["energy_kWh"] < 6.6 and rows["solve.time"]["energy_kWh"] > row["energy_kWh"]  # all-out costs more
    assert row["reference"] == "solve.time"
    assert row["ratio_wall"] == pytest.approx(row["wall_s"] / rows["solve.time"]["wall_s"])
    assert row["ratio_cpu"] == pytest.approx(row["cpu_s"] / rows["solve.time"]["cpu_s"])
    table = harness.markdown(list(rows.values()))
    line = next(x for x in table.splitlines() if x.startswith("| solve.energy_vs_time |"))
    assert f"| {harness.cell(row['wall_s'])} |" in line and f"| {harness.cell(row['ratio_wall'])} |" in line


def test_machine_files_hold_every_column(solved, tmp_path):
    import json
    import csv
    rows = harness.summarise(solved)
    harness.write(rows, tmp_path / "b.csv", tmp_path / "b.json")
    back = json.loads((tmp_path / "b.json").read_text())
    assert [r["case"] for r in back] == [r["case"] for r in rows] and back[0]["wall_s"] == rows[0]["wall_s"]
    table = list(csv.DictReader((tmp_path / "b.csv").open()))
    assert float(table[0]["wall_s_max"]) == rows[0]["wall_s_max"]


def test_list_shows_the_cases_of_the_scripts(capsys):
    assert harness.main(["list"]) == 0
    out = capsys.readouterr().out
    listed = [line.split(" | ")[0].strip("| ") for line in out.splitlines()[2:]]
    assert set(PRIORITY) <= set(listed), set(PRIORITY) - set(listed)
    assert "| lean.ecostudy |" not in out or "lean.lean" in out.split("| lean.ecostudy |")[1].splitlines()[0]


def test_bad_names_and_parameters_are_refused_before_computing(capsys):
    assert harness.main(["run", "no_such.case"]) == 2
    assert "no_such.case: no such case" in capsys.readouterr().err
    assert harness.main(["run", "solve.energy", "--set", "pointz=60"]) == 2
    assert "--set pointz: no chosen case has this parameter" in capsys.readouterr().err
    assert harness.main(["run", "solve.energy", "--set", "points=many"]) == 2
    assert "--set points=many: not of type int (solve.energy)" in capsys.readouterr().err
    assert harness.main(["run", "solve.energy", "--repeat", "0"]) == 2


def test_a_failing_case_is_reported_failed_and_the_command_exits_1(capsys):
    harness.load(["solve"])
    energy = harness.CASES["solve.energy"]
    harness.register("solve.missing_track", energy.run, params={**energy.params, "track": "no/such/track.yaml"})
    try:
        assert harness.main(["run", "solve.missing_track", "--repeat", "1"]) == 1
    finally:
        harness.CASES.pop("solve.missing_track")
    out = capsys.readouterr().out
    assert "| solve.missing_track | 1 | failed: " in out


def test_command_line_overrides_take_the_defaults_types():
    assert harness.cast("60", 1000) == 60 and harness.cast("0.5", 48.0) == 0.5
    assert harness.cast("true", False) is True and harness.cast("1,2", [1]) == [1, 2]
    assert harness.cast("x.yaml", "studies/a.yaml") == "x.yaml"


@pytest.mark.slow  # a new Python process per script (imports: seconds each on a busy machine)
@pytest.mark.parametrize("script", ["bench_solve", "bench_leg_options", "bench_network", "bench_sizes",
                                    "bench_monte_carlo", "bench_sbpc", "bench_heavyhaul", "bench_warm_duals"])
def test_documented_scripts_still_parse_their_command_lines(script):
    out = subprocess.run([sys.executable, f"bench/{script}.py", "--help"], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "usage:" in out.stdout
