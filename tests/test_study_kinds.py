"""A new study kind is one registration on ``studies.batch.STUDY_KINDS`` (docs/architecture.md,
"Adding a study kind"): the engine expands it, runs its cases (resumable from the store, in
workers), tables them and writes summary.json; `ecostudy run --kind` and `api.run_folder` run it."""
from pathlib import Path

import pandas as pd
import pytest
import typer
import yaml
from typer.testing import CliRunner

from ecostudy import api
from ecostudy.cli import app
from ecostudy.core import units
from ecostudy.core.errors import InputError, problem
from ecostudy.core.physics import davis_resistance
from ecostudy.io.folder import Counts
from ecostudy.io.writers import COMMANDS
from ecostudy.studies.batch import STUDY_KINDS, Expanded, StudyKind, outcome, run_kind
from ecostudy.studies.cases import case_key


# --- the toy kind: the running resistance of a train at each speed of a list (Davis, a + b v + c v^2)
def expand_resistance(path: Path) -> Expanded:
    doc = yaml.safe_load(Path(path).read_text())
    cases = []
    for speed in doc["speeds_kmh"]:
        case = {"davis": [doc["a_N"], doc["b_N_per_mps"], doc["c_N_per_mps2"]], "speed": speed * units.KMH,
                "study": doc["name"], "scenario": f"{speed} km/h", "labels": {"speed_kmh": speed}}
        case["key"] = case_key(case)
        cases.append(case)
    return Expanded(Path(doc["output"]), cases)


def resistance_task(case: dict) -> dict:
    def compute():
        if case["speed"] < 0:
            raise InputError(problem("study", "speeds_kmh", f"{case['labels']['speed_kmh']} is negative"))
        return "ok", None, {"resistance_N": float(davis_resistance(case["speed"], *case["davis"]))}
    return outcome(case, compute)


def resistance_table(cases: list, rows: dict) -> pd.DataFrame:
    return pd.DataFrame([{**c["labels"], "status": rows[c["key"]]["status"], "reason": rows[c["key"]]["error"],
                          "resistance_N": (rows[c["key"]]["summary"] or {}).get("resistance_N")} for c in cases])


if "resistance" not in STUDY_KINDS:
    STUDY_KINDS.register("resistance", StudyKind(expand_resistance, resistance_task, resistance_table))


@pytest.fixture
def study(tmp_path):
    path = tmp_path / "resistance.yaml"
    path.write_text(yaml.safe_dump({"name": "toy", "a_N": 1000.0, "b_N_per_mps": 20.0, "c_N_per_mps2": 5.0,
                                    "speeds_kmh": [0, 36, 72, -10], "output": str(tmp_path / "out")}))
    return path


def test_a_registered_kind_runs_through_the_engine_and_resumes(study, tmp_path):
    table, counts, output = run_kind("resistance", study)
    assert output == tmp_path / "out" and counts["total"] == 4 and counts["computed"] == 4
    ok = table[table.status == "ok"].set_index("speed_kmh")["resistance_N"]
    assert ok.loc[36] == pytest.approx(1000 + 20 * 10 + 5 * 100) and ok.loc[72] == pytest.approx(1000 + 400 + 2000)
    failed = table[table.status == "failed"]
    assert list(failed.speed_kmh) == [-10] and "is negative" in failed.reason.iloc[0]
    folder = api.load(output)
    assert folder.kind == "resistance" and folder.cases == Counts(total=4, ok=3, flagged=0, failed=1)
    _, again, _ = run_kind("resistance", study, workers=2)  # nothing left to compute: all four stored
    assert again["stored_before"] == 4 and again["computed"] == 0


def test_the_command_line_and_the_api_run_a_registered_kind(study, tmp_path):
    report = api.run_folder(study, kind="resistance", out=tmp_path / "api")
    assert isinstance(report, api.Report) and len(report.table) == 4 and (tmp_path / "api" / "report.html").is_file()
    r = CliRunner().invoke(app, ["run", str(study), "--kind", "resistance", "--out", str(tmp_path / "cli")])
    assert r.exit_code == 1 and "failed: speed_kmh=-10: study: speeds_kmh: -10 is negative" in r.output, r.output
    unknown = CliRunner().invoke(app, ["run", str(study), "--kind", "nope"])
    known = unknown.output.split("unknown study kind 'nope'; known: ")[-1].strip().split(", ")
    assert unknown.exit_code == 2, unknown.output
    # every built-in kind and this one are named (a kind added to studies/kinds.py later is named too)
    assert {"compare", "heavyhaul", "network", "pareto", "resistance", "run", "simulate"} <= set(known), unknown.output


def test_a_base_case_read_for_a_command_with_no_unused_entry_says_which_table_to_extend():
    """A new kind that reads a study file's base case for itself (``load_checked_study(path, NAME)``)
    learns where its unused fields go, rather than from a bare KeyError."""
    from ecostudy.studies.cases import load_checked_study
    with pytest.raises(ValueError, match="'mass' has no entry in studies.cases.UNUSED"):
        load_checked_study(Path(__file__).resolve().parent.parent / "studies" / "default.yaml", "mass")


def test_a_folder_of_another_kind_names_how_each_kind_is_run(study, tmp_path):
    """A registered kind has no command of its own: a refusal names it as `ecostudy run --kind X`,
    the built-in commands by their own names, and those names are the CLI's."""
    assert COMMANDS <= set(typer.main.get_command(app).commands)
    assert {s.name for s in STUDY_KINDS} - {"resistance"} <= COMMANDS
    api.run_folder(study, kind="resistance", out=tmp_path / "res", plot=False)
    r = CliRunner().invoke(app, ["pareto", "studies/default.yaml", "--out", str(tmp_path / "res")])
    assert r.exit_code == 2 and ("holds the results of `ecostudy run --kind resistance` (its summary.json), not of "
                                 "`ecostudy pareto`") in r.output, r.output
