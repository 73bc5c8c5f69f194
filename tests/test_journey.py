"""Multi-stop journeys: the equal-marginal-saving distribution of a supplement beats the same
percentage on every segment, for the same total running time (shipped 4-stop line)."""
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.errors import InfeasibleError
from ecostudy.io.loaders import load_track, load_train
from ecostudy.studies.journey import equal_marginal, journey, mareco_split, uniform

from .conftest import assert_folder, TRACKS, TRAINS


def test_equal_marginal_allocation_on_synthetic_fronts():
    import pandas as pd
    steep = pd.DataFrame({"running_time_s": [10, 11, 12, 20], "traction_energy_kWh": [10, 5, 4, 3.5]})
    flat = pd.DataFrame({"running_time_s": [10, 11, 12, 20], "traction_energy_kWh": [10, 9.9, 9.8, 9.7]})
    times = equal_marginal([steep, flat], 22.0, step=0.01)
    assert sum(times) == pytest.approx(22.0)
    assert times[0] > 11.5 and times[1] < 10.5  # the steep front gets the time
    assert uniform([steep, flat], 22.0) == pytest.approx([11.0, 11.0])


def test_a_total_below_the_mareco_runs_fastest_is_an_infeasible_split_not_a_crash():
    """journey() fails the MARECO-style rows on it (an InfeasibleError, as the whole-journey NLP's)
    where a ValueError stopped the journey."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    pairs = [("Noord", "Station"), ("Station", "Centrum")]
    assert sum(mareco_split(track, train, pairs, 300.0, 60)) == pytest.approx(300.0)  # a split it can make
    with pytest.raises(InfeasibleError, match="below the MARECO-style runs' fastest"):
        mareco_split(track, train, pairs, 100.0, 60)  # the two segments' all-out runs take about 140 s


@pytest.mark.slow
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
    folder = assert_folder(tmp_path, "journey", ["segments", "totals"])
    assert folder.cases.total == len(folder.table)
    segments = pd.read_csv(tmp_path / "journey.csv")
    assert (segments["status"] == "ok").all() and segments["verified"].all()  # each segment's run: Ipopt and re-simulation


@pytest.mark.flagged_on_purpose
def test_a_journey_segment_is_its_runs_status(tmp_path):
    """K = 16: segments whose re-simulation misses are flagged with the run's own reason (Ipopt's end
    and the re-simulation's numbers), and the command exits 1."""
    import pandas as pd
    r = CliRunner().invoke(app, ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--supplement", "10", "--points", "16",
                                 "--workers", "1", "--no-plot", "--out", str(tmp_path)])
    assert r.exit_code == 1, r.output
    segments = pd.read_csv(tmp_path / "journey.csv")
    bad = segments[segments["status"] != "ok"]
    assert len(bad) and bad["status"].str.startswith("flagged: ").all()
    assert (~bad["verified"] | bad["status"].str.contains("Ipopt ended")).all()


@pytest.mark.slow
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


JOURNEY = "metro_line_4stops_Journey_01.json"  # TTOBench journey format, shipped


def test_ttobench_journey_becomes_a_plan_in_si(tmp_path):
    import json

    from ecostudy.core.errors import InputError
    from ecostudy.io.loaders import load_timetable, load_track
    from ecostudy.io.timetable import journey_plan, name_stops

    from .conftest import STUDIES
    track = load_track(TRACKS / "metro_line_4stops.yaml")
    path = STUDIES / "timetables" / JOURNEY
    plan = journey_plan(*name_stops(load_timetable(path), track, path), path, dwell=20.0)
    assert plan.stops == ("Noord", "Station", "Centrum", "Zuid")
    assert plan.arrival == ((None, 56.0), (175.0, 185.0), (None, 270.0))
    assert plan.dwell == (0.0, 20.0, 20.0) and plan.departure == ((0.0, 0.0), None, None)
    (w,) = plan.windows[1]  # 1400 m is 750 m past Station
    assert (w.distance, w.earliest, w.latest, w.min_speed) == (750.0, 120.0, 135.0, None)
    assert w.max_speed == pytest.approx(40 / 3.6)
    # other units: km and m/s are converted at the boundary
    doc = json.loads(path.read_text())
    doc["timing points"]["units"].update({"position": "km", "lower speed constraint": "m/s",
                                          "upper speed constraint": "m/s"})
    doc["timing points"]["values"] = [[p / 1000 if p is not None else None, a, b, c, d]
                                      for p, a, b, c, d in doc["timing points"]["values"]]
    doc["timing points"]["values"][3][4] = 10.0  # m/s: the passing point at 1400 m
    other = tmp_path / "journey_km.json"
    other.write_text(json.dumps(doc))
    plan = journey_plan(*name_stops(load_timetable(other), track, other), other)
    assert plan.windows[1][0].distance == pytest.approx(750.0) and plan.windows[1][0].max_speed == pytest.approx(10.0)
    # a stop anywhere on the track (TTOBench journeys stop where they like): the track gets that stop
    for row in (1, 2):  # Station's arrival and departure points
        doc["timing points"]["values"][row][0] = 0.7
    other.write_text(json.dumps(doc))
    tt, extended = name_stops(load_timetable(other), track, other)
    assert extended.stops["at_700m"] == 700.0 and tt.stops[1].stop == "at_700m" and "at_700m" not in track.stops
    assert list(extended.stops) == ["Noord", "Station", "at_700m", "Centrum", "Zuid"]
    # a station as TTOBench writes it: two stopping points at one position, arrival then departure
    # window; the dwell follows from them
    station = json.loads(path.read_text())
    rows = station["timing points"]["values"]
    at = next(i for i, r in enumerate(rows) if i and r[3] == 0 and r[4] == 0)
    rows[at + 1][1:3] = [90.0, 100.0]  # its departure point, open in the file
    other.write_text(json.dumps(station))
    plan = journey_plan(*name_stops(load_timetable(other), track, other), other)
    assert plan.departure[1] == (90.0, 100.0) and len(plan.stops) == 4
    # a point before the one above it; the last stop not on the track at all; a departure that is not at standstill
    for row in (1, 2):
        doc["timing points"]["values"][row][0] = 9.0
    other.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"timing points\.values\[3\]: position 1\.4 km before the point above it"):
        load_timetable(other)
    for row in (1, 2):
        doc["timing points"]["values"][row][0] = 0.7
    doc["timing points"]["values"][-1][0] = 9.0
    other.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"stops\[3\]\.position_m: 9000 m is not on track"):
        name_stops(load_timetable(other), track, other)
    doc["timing points"]["values"][0][4] = 5
    other.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"timing points\.values\[0\]: the departure and the arrival need"):
        load_timetable(other)


@pytest.mark.slow
def test_journey_with_timing_windows_keeps_them_where_the_splits_do_not(tmp_path):
    from .conftest import STUDIES
    r = CliRunner().invoke(app, ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--timetable",
                                 str(STUDIES / "timetables" / JOURNEY), "--dwell", "20", "--points", "200",
                                 "--workers", "2", "--no-plot", "--out", str(tmp_path)])
    # the comparison splits spread the NLP's total without its windows: a row that breaks the
    # timetable is flagged naming the window, and the command exits 1
    assert r.exit_code == 1, r.output
    import pandas as pd
    table = pd.read_csv(tmp_path / "journey.csv")
    nlp = table[table["distribution"] == "timing windows NLP"]
    assert nlp["verified"].all() and nlp["windows_kept"].all()  # simulated passing times and speeds
    assert (nlp["status"] == "ok").all()
    same = table[table["distribution"] == "same percentage"].iloc[0]
    assert not same["windows_kept"] and same["status"].startswith("flagged: breaks the timetable: arrives at ")
    assert "window [, 56] s" in same["status"]
    assert (table["status"] == "ok").eq(table["windows_kept"] & table["verified"]).all()
    assert nlp["arrival_s"].iloc[0] <= 56.0 + 1e-6 and 175 - 1e-6 <= nlp["arrival_s"].iloc[1] <= 185 + 1e-6
    assert nlp["departure_s"].iloc[1] == pytest.approx(nlp["arrival_s"].iloc[0] + 20.0)
    assert nlp["arrival_latest_s"].iloc[0] == 56.0 and table["arrival_earliest_s"].dtype == float  # numbers, not text
    totals = pd.read_csv(tmp_path / "journey_totals.csv").set_index("distribution")
    assert totals.loc["timing windows NLP", "windows_kept"]
    assert not totals.loc["same percentage", "windows_kept"]  # Station reached after 56 s
    # without the windows the same total time needs no more energy: the windows' price
    assert (totals.loc["whole-journey NLP", "traction_energy_kWh"]
            <= totals.loc["timing windows NLP", "traction_energy_kWh"] * (1 + 1e-6))


def test_departure_windows_in_the_journey_nlp_and_unreachable_points_refused(tmp_path):
    """A station as TTOBench writes it (arrival window, then departure window at one position):
    the journey NLP departs inside the departure window, after the arrival; timing points no run
    can keep are refused before any NLP, naming both points and the fastest time between them."""
    import json

    from ecostudy.core.errors import InfeasibleError
    from ecostudy.io.loaders import load_timetable, load_track, load_train
    from ecostudy.io.timetable import journey_plan, name_stops
    from ecostudy.studies.journey import windowed_journey

    from .conftest import STUDIES
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    doc = json.loads((STUDIES / "timetables" / JOURNEY).read_text())
    rows = doc["timing points"]["values"]
    rows[1:] = [[650, 50, 70, 0, 0], [650, 95, 100, 0, 0], [2100, 190, 215, 0, 0]]  # Station, then Centrum
    path = tmp_path / "j.json"
    path.write_text(json.dumps(doc))
    tt, trk = name_stops(load_timetable(path), track, path)
    plan = journey_plan(tt, trk, path)
    times, departures, status = windowed_journey(trk, train, plan, 120)
    tol = 1e-4  # Ipopt's tolerance on the scaled clock constraints
    assert status.ok, status
    assert 95 - tol <= departures[1] <= 100 + tol and departures[1] >= times[0] - tol
    assert 50 - tol <= times[0] <= 70 + tol and 190 - tol <= departures[1] + times[1] <= 215 + tol
    rows[-1] = [2100, 100, 120, 0, 0]  # 1450 m in at most 25 s after leaving at 95 s: impossible
    path.write_text(json.dumps(doc))
    tt, trk = name_stops(load_timetable(path), track, path)
    with pytest.raises(InfeasibleError, match=r"the departure from Station \(not before 95 s\) and the arrival at "
                                              r"Centrum \(not after 120 s\) leave 25 s; the fastest run between them"):
        windowed_journey(trk, train, journey_plan(tt, trk, path), 120)


def test_a_large_supplement_s_fronts_end_at_the_longest_run_solved():
    """+170 %: the fronts would reach 2.5 x 170 % over each all-out time, past SLOWEST x the fastest
    envelope's time, where a run is refused as crawling (a front's point retried cold was refused
    part-way). Each front ends there instead; the equal-marginal split stays inside every front and
    every distribution's runs are solved (K = 60: seconds)."""
    from ecostudy.core.defaults import SLOWEST
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.ocp.problem import prepare
    from ecostudy.studies.journey import journey
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    stops = list(track.stops)
    table, totals, _, fronts = journey(track, train, stops, supplement=1.7, points=60)
    for (a, b), front in zip(zip(stops, stops[1:]), fronts):
        slowest, times = SLOWEST * prepare(track, train, a, b, 60).estimate, front["running_time_s"]
        assert 0.999 * slowest < times.iloc[-1] <= slowest, (a, b, times.iloc[-1], slowest)
        split = table[(table["distribution"] == "equal marginal saving") & (table["from"] == a)]["running_time_s"]
        assert times.iloc[0] <= float(split.iloc[0]) <= times.iloc[-1], (a, b, float(split.iloc[0]), times.tolist())
    assert (table["status"] == "ok").all(), table[["distribution", "from", "status"]]
    assert totals["running_time_s"].to_numpy() == pytest.approx(2.7 * sum(f["running_time_s"].iloc[0] for f in fronts),
                                                                rel=1e-6)


def test_a_journey_nlp_ipopt_did_not_prove_optimal_flags_its_distribution():
    """Ipopt asked for a tolerance it cannot reach (tol 1e-20) ends the whole-journey NLP
    ``acceptable``: a feasible split, kept, but not proven optimal. Every row of that distribution
    is flagged saying so, the other distributions' rows are not (K = 60: seconds)."""
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.studies.journey import journey
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    table, _, _, _ = journey(track, train, list(track.stops), supplement=0.1, points=60,
                             nlp_options={"tol": 1e-20})
    whole = table["distribution"] == "whole-journey NLP"
    reason = "flagged: the whole-journey NLP: Ipopt ended acceptable, not optimal"
    assert (table.loc[whole, "status"] == reason).all(), table.loc[whole, "status"].tolist()
    assert not table.loc[~whole, "status"].str.contains("journey NLP").any()


def test_a_total_time_over_all_out_runs_ipopt_did_not_prove_optimal_flags_every_row(monkeypatch):
    """The total is a supplement over the segments' all-out runs (each front's first point); solved
    with a tolerance Ipopt cannot reach (tol 1e-20 on every space NLP, and Ipopt stopping at the first
    point within its acceptable tolerance) they end ``acceptable``, and every row of every
    distribution says so, naming the segment (K = 60: seconds)."""
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.ocp.solver import IPOPT
    from ecostudy.studies.journey import journey
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    stops = list(track.stops)
    monkeypatch.setitem(IPOPT["space"], "tol", 1e-20)
    monkeypatch.setitem(IPOPT["space"], "acceptable_iter", 1)
    table, _, _, _ = journey(track, train, stops, supplement=0.1, points=60)
    first = f"the all-out run from {stops[0]} to {stops[1]}: Ipopt ended acceptable, not optimal"
    assert table["status"].str.contains(first, regex=False).all(), table["status"].tolist()


def test_a_broken_window_names_only_the_bounds_it_has():
    """A timing point with a time window and no speed bounds is reported by its times alone: the
    reason reads "window [1, 2] s", not "window [1, 2] s and [, ] km/h"."""
    from types import SimpleNamespace
    from ecostudy.analysis.single import solve_run
    from ecostudy.core.types import Timing, Window
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.studies.journey import timing_columns
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    run = solve_run(track, train, "Noord", "Station", Timing(running_time=56.0), points=50)
    plan = SimpleNamespace(stops=["Noord", "Station"], arrival=[(None, None)], departure=[None],
                           windows=[(Window(300.0, earliest=1.0, latest=2.0),)])
    columns, broken = timing_columns(plan, 0, 0.0, 56.0, run)
    assert not columns["windows_kept"]
    assert broken.startswith("passes 300 m after Noord at ") and broken.endswith("window [1, 2] s"), broken
    assert "km/h]" not in broken and "[, ]" not in broken


def test_a_timetabled_segment_faster_than_any_run_is_refused_naming_its_arrival(tmp_path):
    """Station timetabled 40 s after Noord, where the fastest run takes 50.4 s: refused in one line
    naming the timetable and the arrival, before any segment's front is solved (none written)."""
    from .conftest import STUDIES
    path = tmp_path / "tight.yaml"
    path.write_text((STUDIES / "timetables" / "metro_line.yaml").read_text().replace("arrival_s: 58", "arrival_s: 40"))
    r = CliRunner().invoke(app, ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--timetable", str(path), "--points", "100",
                                 "--out", str(tmp_path / "out"), "--no-plot"])
    lines = [line for line in r.output.splitlines() if line.startswith("error:")]
    assert r.exit_code == 2 and len(lines) == 1 and "Traceback" not in r.output, r.output
    assert lines[0] == (f"error: {path}: stops[1].arrival_s: infeasible: 40.0 s from Noord to Station, below the "
                        "fastest possible run's 50.4 s (kinematic envelope)")
    assert not (tmp_path / "out" / "journey.csv").exists()


def test_a_total_a_hair_under_the_all_out_runs_is_refused_with_the_digits_that_tell_them_apart(tmp_path):
    """--time 199.5 s against all-out runs summing to 199.53 s: not 'is below ... 199.5 s'."""
    r = CliRunner().invoke(app, ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--time", "199.5", "--points", "100",
                                 "--out", str(tmp_path), "--no-plot"])
    lines = [line for line in r.output.splitlines() if line.startswith("error:")]
    assert r.exit_code == 2 and len(lines) == 1, r.output
    assert lines[0] == ("error: command line: --time: infeasible: the total time 199.50 s is below the sum of the "
                        "all-out times 199.53 s")


def test_at_supplement_0_every_distribution_is_the_all_out_run_of_each_segment():
    """--supplement 0: there is no time to spread. The MARECO-style split, computed on the kinematic
    envelope, gives Noord-Station 50.480 s, a hair under its all-out NLP's 50.488 s (K = 100): that
    segment is run all-out, not refused, and every distribution's every segment is solved and ok."""
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.studies.journey import journey
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    table, totals, results, _ = journey(track, train, list(track.stops), supplement=0.0, points=100)
    assert (table["status"] == "ok").all(), table[["distribution", "from", "status"]]
    assert (table["running_time_s"] >= table["all_out_time_s"] * (1 - 1e-6)).all()
    assert set(table["distribution"]) == set(results) and "MARECO-style" in results
    assert totals["traction_energy_kWh"].notna().all()


def test_a_segment_faster_than_any_run_is_a_failed_row_and_the_other_runs_are_solved(tmp_path):
    """A timetable giving Noord-Station 50.2 s, under both its kinematic envelope (50.42 s) and its
    all-out NLP (50.49 s, K = 100), yet within the 1 % the refusal before the fronts leaves to the
    NLP: that row of the timetabled distribution is ``failed`` with the solve's reason, every other
    row is solved, the distribution's totals are NaN (not a partial sum) and the command exits 1."""
    import pandas as pd
    from .conftest import STUDIES
    path = tmp_path / "tight.yaml"
    path.write_text((STUDIES / "timetables" / "metro_line.yaml").read_text().replace("arrival_s: 58", "arrival_s: 50.2"))
    r = CliRunner().invoke(app, ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--timetable", str(path), "--points", "100",
                                 "--out", str(tmp_path / "out"), "--no-plot"])
    assert r.exit_code == 1, r.output
    table = pd.read_csv(tmp_path / "out" / "journey.csv")
    bad = (table["distribution"] == "as timetabled") & (table["from"] == "Noord")
    assert table.loc[bad, "status"].tolist() == [
        "failed: infeasible: the fastest possible run takes 50.5 s (asked for 50.2 s)"]
    assert table.loc[bad, "traction_energy_kWh"].isna().all() and not table.loc[bad, "verified"].any()
    assert table.loc[bad, "distance_m"].tolist() == [650.0]  # the segment's length, from the stops
    assert (table.loc[~bad, "status"] == "ok").all(), table.loc[~bad, ["distribution", "from", "status"]]
    totals = pd.read_csv(tmp_path / "out" / "journey_totals.csv").set_index("distribution")
    assert totals.loc["as timetabled", ["running_time_s", "traction_energy_kWh", "net_energy_kWh"]].isna().all()
    assert totals.drop("as timetabled")["traction_energy_kWh"].notna().all()


def test_a_whole_journey_nlp_that_ends_without_a_split_fails_its_rows_and_the_others_are_driven():
    """Ipopt allowed no iteration (max_iter 0) ends the whole-journey NLP without a feasible point:
    its three rows are ``failed`` saying how Ipopt ended, its totals NaN and it is not drawn; the
    other distributions are solved and ok (K = 60: seconds)."""
    import math
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.studies.journey import journey
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    table, totals, results, _ = journey(track, train, list(track.stops), supplement=0.1, points=60,
                                        nlp_options={"max_iter": 0})
    whole = table["distribution"] == "whole-journey NLP"
    assert (table.loc[whole, "status"] == "failed: the whole-journey NLP: Ipopt max_iterations after 0 iterations").all()
    assert (table.loc[~whole, "status"] == "ok").all(), table.loc[~whole, "status"].tolist()
    totals = totals.set_index("distribution")
    assert math.isnan(totals.loc["whole-journey NLP", "traction_energy_kWh"]) and "whole-journey NLP" not in results
    assert totals.drop("whole-journey NLP")["traction_energy_kWh"].notna().all()


def test_a_small_supplement_s_equal_marginal_split_comes_near_the_whole_journey_nlp():
    """At +1 % the split falls where the fronts bend most, below their evenly spaced points; the
    fronts are solved around it too, so the equal-marginal split comes within 0.2 % of the exact
    whole-journey NLP and below the same percentage (without those points: 2.9 % above the NLP and
    above the same percentage, a split that claims the Lagrange condition and loses to the naive one)."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    _, totals, _, _ = journey(track, train, list(track.stops), supplement=0.01, points=100)
    energy = totals.set_index("distribution")["traction_energy_kWh"]
    assert energy["equal marginal saving"] <= 1.002 * energy["whole-journey NLP"], energy
    assert energy["equal marginal saving"] < energy["same percentage"], energy


HOSTILE = {"name": "short and steep", "source": "test", "length_m": 2400,
           "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 250}, {"name": "C", "position_m": 1350},
                     {"name": "D", "position_m": 2400}],
           "gradients": [{"position_m": 0, "gradient_permille": 0}, {"position_m": 300, "gradient_permille": -40},
                         {"position_m": 800, "gradient_permille": 35}, {"position_m": 1300, "gradient_permille": 0},
                         {"position_m": 1500, "gradient_permille": -35}, {"position_m": 2300, "gradient_permille": 0}],
           "speed_limits": [{"position_m": 0, "speed_kmh": 50}, {"position_m": 300, "speed_kmh": 80},
                            {"position_m": 2370, "speed_kmh": 15}]}


def test_every_distribution_takes_the_journeys_total_and_says_its_status(tmp_path):
    """A 250 m segment, +-40 per mille and 15 km/h before the last stop, the metro without its electric
    brake, +0.1 %: the MARECO-style time of C - D (on the envelope, integrated exactly) fell under the
    segment's fastest run on the grid, which it was solved at; its runs took 168.374 s against the
    journey's 168.207 and 'beat' the whole-journey NLP (23.800 against 24.236 kWh), every row ok. Now
    the split counts such a segment at its fastest run and every distribution takes the total; the
    totals carry their status, and a distribution whose runs do not take the total is flagged."""
    from .conftest import load_yaml, write_yaml
    train = load_yaml(TRAINS / "amsterdam_metro.yaml")
    del train["regenerative_braking"]
    r = CliRunner().invoke(app, ["journey", "--track", str(write_yaml(tmp_path / "line.yaml", HOSTILE)), "--train",
                                 str(write_yaml(tmp_path / "train.yaml", train)), "--supplement", "0.1", "-K", "100",
                                 "--no-plot", "--out", str(tmp_path / "j")])
    assert r.exit_code == 0, r.output
    import pandas as pd
    totals = pd.read_csv(tmp_path / "j" / "journey_totals.csv").set_index("distribution")
    assert (totals["status"] == "ok").all(), totals
    target = totals.loc["whole-journey NLP", "running_time_s"]
    assert (abs(totals["running_time_s"] - target) < 2e-3).all(), totals  # as written, to 3 decimals
    assert (totals["traction_energy_kWh"] >= totals.loc["whole-journey NLP", "traction_energy_kWh"] - 1e-3).all(), totals
    from ecostudy.studies.journey import off_total
    table = pd.read_csv(tmp_path / "j" / "journey.csv")
    longer = off_total(table.assign(running_time_s=table["running_time_s"] + (table["distribution"] == "MARECO-style")),
                       target, 3)
    mareco = longer[longer["distribution"] == "MARECO-style"]["status"]
    assert mareco.str.startswith("flagged: the distribution's runs take 171.207 s together, not the journey's").all()
    assert (longer[longer["distribution"] != "MARECO-style"]["status"] == "ok").all()
