"""Typed results: a run's summary as named attributes with units in the names (``io.runsummary``),
equal to ``summary.json``, which stays the file; an output folder's case counts typed."""
import dataclasses
import json

import pytest

from ecostudy import api
from ecostudy.core.errors import InputError
from ecostudy.core.status import Status
from ecostudy.io.folder import Counts, NotOk, load, write_summary
from ecostudy.io.runsummary import RunSummary
from ecostudy.report.files import write_run

# summary.json keys read under another name, or not typed (the stage times, the regimes' shares)
RENAMED = {"from": "from_stop", "to": "to_stop", "regimes": "regimes"}
UNTYPED = {"stages_s"}


def test_a_run_reads_its_summary_as_attributes(amsterdam_76s):
    s, facts = amsterdam_76s.summary, amsterdam_76s.facts
    assert (facts.train, facts.from_stop, facts.to_stop) == (s["train"], s["from"], s["to"])
    assert facts.running_time_s == s["running_time_s"] == pytest.approx(76.0, abs=1e-6)
    assert facts.traction_energy_kWh == s["traction_energy_kWh"] > 0
    assert facts.points == s["points"] == 1000 and facts.objective == "energy"
    assert facts.solver.status == s["solver"]["status"] == "optimal"
    assert facts.verification.passed and facts.verification.stop_error_m == s["verification"]["stop_error_m"]
    assert facts.regime_sequence == s["regimes"]["sequence"] and facts.regimes[0].start_m == 0.0
    assert facts.pontryagin.agreement_pct == s["pontryagin"]["agreement_pct"]
    assert facts.das is None


def test_every_summary_key_has_its_typed_field(amsterdam_76s):
    """A key added to summary.json without a typed field fails here (or is named untyped above)."""
    names = {f.name for f in dataclasses.fields(RunSummary)}
    keys = set(amsterdam_76s.summary) - UNTYPED
    assert {RENAMED.get(k, k) for k in keys} <= names, sorted({RENAMED.get(k, k) for k in keys} - names)


def test_a_solve_folder_reads_back_typed(amsterdam_76s, tmp_path):
    write_run(amsterdam_76s, tmp_path, plot=False)
    folder = load(tmp_path)
    assert folder.run() == amsterdam_76s.facts == RunSummary.from_dict(json.loads((tmp_path / "summary.json").read_text()))
    assert folder.cases == Counts(total=1, ok=1) and folder.not_ok == () and folder.cases.not_ok == 0
    assert api.Solution(amsterdam_76s).facts.verification.passed


def test_a_folder_counts_its_cases_and_names_those_not_ok(tmp_path):
    statuses = {"a": Status("ok"), "b": Status("flagged", "late"), "c": Status("failed", "infeasible: too short")}
    write_summary(tmp_path, "run", statuses)
    folder = load(tmp_path)
    assert folder.cases == Counts(total=3, ok=1, flagged=1, failed=1) and folder.cases.not_ok == 2
    assert folder.not_ok == (NotOk("b", statuses["b"]), NotOk("c", statuses["c"]))
    report = api.Report(**{f.name: getattr(folder, f.name) for f in dataclasses.fields(folder)})
    assert report.problems() == ["flagged: b: late", "failed: c: infeasible: too short"]
    with pytest.raises(InputError, match="not one run's"):
        folder.run()


def test_a_stored_infeasible_case_says_infeasible_once():
    """A case whose solve raised InfeasibleError is stored as ``infeasible`` with the error's own text
    (which begins ``infeasible:``): read back, the reason says it once."""
    stored = Status.parse("infeasible", "infeasible: the fastest possible run takes 71.7 s (asked for 20.0 s)")
    assert str(stored) == "failed: infeasible: the fastest possible run takes 71.7 s (asked for 20.0 s)"
    assert str(Status.parse("infeasible", "below the all-out time")) == "failed: infeasible: below the all-out time"
    assert str(Status.parse("infeasible")) == "failed: infeasible"
