"""Multi-stop journeys: the equal-marginal-saving distribution of a supplement beats the same
percentage on every segment, for the same total running time (shipped 4-stop line)."""
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.journey import equal_marginal, uniform

from .conftest import TRACKS, TRAINS


def test_equal_marginal_allocation_on_synthetic_fronts():
    import pandas as pd
    steep = pd.DataFrame({"running_time_s": [10, 11, 12, 20], "traction_energy_kWh": [10, 5, 4, 3.5]})
    flat = pd.DataFrame({"running_time_s": [10, 11, 12, 20], "traction_energy_kWh": [10, 9.9, 9.8, 9.7]})
    times = equal_marginal([steep, flat], 22.0, step=0.01)
    assert sum(times) == pytest.approx(22.0)
    assert times[0] > 11.5 and times[1] < 10.5  # the steep front gets the time
    assert uniform([steep, flat], 22.0) == pytest.approx([11.0, 11.0])


def test_journey_command_saves_against_the_same_percentage(tmp_path):
    r = CliRunner().invoke(app, ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--supplement", "10", "--points", "300",
                                 "--workers", "2", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    import pandas as pd
    totals = pd.read_csv(tmp_path / "journey_totals.csv").set_index("distribution")
    best, same = totals.loc["equal marginal saving"], totals.loc["same percentage"]
    mareco, whole = totals.loc["MARECO-style"], totals.loc["whole-journey NLP"]
    assert whole["traction_energy_kWh"] <= best["traction_energy_kWh"] * (1 + 1e-6)  # the exact split
    assert whole["running_time_s"] == pytest.approx(best["running_time_s"], rel=1e-6)
    for other in (same, mareco):
        assert best["running_time_s"] == pytest.approx(other["running_time_s"], rel=1e-6)
        assert best["traction_energy_kWh"] <= other["traction_energy_kWh"] * (1 + 1e-6)
    assert (tmp_path / "journey.png").stat().st_size > 10_000


def test_timetable_running_times_and_their_redistribution(tmp_path):
    from .conftest import STUDIES
    r = CliRunner().invoke(app, ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--timetable",
                                 str(STUDIES / "timetables" / "metro_line.yaml"), "--points", "300",
                                 "--workers", "2", "--no-plot", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    import pandas as pd
    table = pd.read_csv(tmp_path / "journey.csv")
    tt = table[table["distribution"] == "as timetabled"]
    assert tt["running_time_s"].round(3).tolist() == [58.0, 98.0, 65.0]  # arrival - (arrival + dwell) before
    totals = pd.read_csv(tmp_path / "journey_totals.csv").set_index("distribution")
    assert totals.loc["equal marginal saving", "traction_energy_kWh"] <= totals.loc["as timetabled",
                                                                                   "traction_energy_kWh"]
