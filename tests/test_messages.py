"""What the terminal says after a study: each reason once with the cases it applies to, the
calibration table's numbers in one notation per row, and the one wording of a solve Ipopt did not
prove optimal."""
import pandas as pd

from ecostudy import api
from ecostudy.api.cases import CALIBRATION_COLUMNS
from ecostudy.api.outcome import shown
from ecostudy.core.simulate import outside
from ecostudy.core.status import Status, driven_run, from_checks, solver_check
from ecostudy.core.units import number
from ecostudy.io.folder import write_summary
from ecostudy.io.runsummary import Verification

from .conftest import TRACKS

ADHESION = "a locomotive asked 1.04 of mu(v) m g"


def test_a_reason_shared_by_runs_is_printed_once_naming_them(tmp_path):
    runs = {f"K_b={k}, f=10, Np=4, Nc=2": Status("flagged", ADHESION) for k in ("1.0", "40.0", "60.0", "80.0")}
    runs["K_b=100.0, f=10, Np=4, Nc=2"] = Status("failed", "Ipopt ended infeasible")
    write_summary(tmp_path, "heavyhaul", runs)
    assert api.load(tmp_path).problems() == [
        f"flagged: K_b=1.0, 40.0, 60.0, 80.0 (f=10, Np=4, Nc=2): {ADHESION}",
        "failed: K_b=100.0, f=10, Np=4, Nc=2: Ipopt ended infeasible"]
    write_summary(tmp_path, "validate", {"run 0": Status("flagged", "late"), "run 1": Status("flagged", "early"),
                                         "run 2": Status("flagged", "late")})
    assert api.load(tmp_path).problems() == ["flagged: run 0, 2: late", "flagged: run 1: early"]
    write_summary(tmp_path, "run", {"metro 80 s": Status("flagged", "late"), "regional": Status("flagged", "late")})
    assert api.load(tmp_path).problems() == ["flagged: metro 80 s; regional: late"]


def test_the_calibration_table_keeps_one_notation_in_a_row():
    """A prior of 255200 kg beside an estimate of 265310.4 kg (printed '2.552e+05' beside '2.6531e+05'
    with '.5g'): five significant digits in fixed point, the efficiency beside them alike."""
    table = pd.DataFrame({"name": ["mass", "efficiency"], "unit": ["kg", "-"], "prior": [255200.0, 0.9],
                          "estimate": [265310.4, 0.851234], "low": [263000.1, 0.84], "high": [267620.5, 0.862],
                          "identifiable": [True, True]})
    lines = shown(table, CALIBRATION_COLUMNS).splitlines()
    assert lines[1].split() == ["mass", "kg", "255200", "265310", "263000", "267620", "True"]
    assert lines[2].split() == ["efficiency", "-", "0.90000", "0.85123", "0.84000", "0.86200", "True"]
    assert [number(x, "~5") for x in (-0.0000001, float("nan"), 2.6531e6)] == ["-0.00000010000", "nan", "2653100"]


def test_a_solve_ipopt_did_not_prove_optimal_is_worded_in_one_place():
    assert from_checks(solver_check("max_iterations")).reason == "Ipopt ended max_iterations, not optimal"
    assert from_checks(solver_check("optimal")).ok
    written = [p.name for p in (TRACKS.parent / "ecostudy").rglob("*.py") if "ended {" in p.read_text()]
    assert written == ["status.py"]


def test_a_driven_run_off_its_stop_says_short_of_or_beyond_it():
    """'stopped -1.36 m from the stop' left the sign to be guessed; a driven run (a strategy, driver
    advice, a closed-loop run) says it as a heavy-haul run does: short of, or beyond, with the tolerance."""
    assert driven_run(stop_error_m=-1.36).reason == "stopped 1.36 m short of the stop (tolerance 1 m)"
    assert driven_run(stop_error_m=2.5).reason == "stopped 2.50 m beyond the stop (tolerance 1 m)"
    assert driven_run(stop_error_m=0.99).kind == "ok"


def test_a_value_past_its_tolerance_never_reads_as_within_it():
    """A re-simulation 1.0014 m short of its stop (tolerance 1 m) read `stop_error_m -1 (tolerance
    1)`; an adhesion use of 1.0104 (tolerance 1.01) read 1.010: each now keeps the digits that show it
    is beyond, and no more than three where three show it."""
    block = {"stop_error_m": -1.0014, "energy_error_pct": 1.32, "tolerances": {"stop_error_m": 1.0, "energy_error_pct": 1.0}}
    assert outside(block) == ["stop_error_m -1.001 (tolerance 1)", "energy_error_pct 1.32 (tolerance 1)"]
    assert "adhesion use 1.01 of" not in driven_run(adhesion_use=1.0104).reason
    assert "adhesion use 1.0104 of mu(v) m_adh g" in driven_run(adhesion_use=1.0104).reason
    assert "arrived 1.002 s early" in driven_run(early_s=1.0021).reason
    assert driven_run(0.0, 1.004, 0.504).reason == "arrived 1.004 s late; overspeed 0.504 km/h"
    assert driven_run(100.0, moving_kmh=40.9).reason.startswith("ran past the stop without stopping: 40.9 km/h 100 m")
    errors = Verification(passed=False, arrival_time_error_s=0.5004, stop_error_m=-1.0004, energy_error_pct=0.2,
                          overspeed_max_kmh=0.5004, simulated_running_time_s=80.0, simulated_traction_energy_kWh=5.0,
                          simulated_net_energy_kWh=3.0, adhesion_use_max=1.0104).errors
    assert errors == "arrival +0.5004 s, stop -1.0004 m, energy +0.200 %, overspeed 0.5004 km/h, adhesion use 1.0104 " \
        "of mu(v) m_adh g", errors

