"""A network study's statuses on timetables and lines built to be hard: every result ok, flagged or
failed with its reason, never an ok for a run that misses a limit (real solves, one metro segment)."""
import subprocess
import sys

from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.types import Supply
from ecostudy.io.loaders import load_track, load_train
from ecostudy.core.errors import SolverError
from ecostudy.network import fleet, joint, strategies

from .conftest import ROOT, TRACKS, TRAINS, write_yaml


def test_a_pantograph_voltage_below_min_voltage_is_flagged():
    """The circuit sags the pantograph to about 680 V (750 V supply, 10 mOhm, 25 mOhm/km); with
    min_voltage_V 700 the run misses the line's voltage limit, so it is not ok."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0], ["T1"], 1.0,
                   Supply(position=650.0, min_voltage=700.0), points=200)
    totals = strategies.run_strategies(f, ["independent"], progress=None)["independent"]["totals"]
    assert totals["voltage_min_V"] < 700.0
    assert totals["status"].startswith("flagged") and "min_voltage_V" in totals["status"], totals["status"]


def test_a_study_whose_every_strategy_failed_says_so(tmp_path):
    """`following` cannot keep 300 m behind a train that left 10 s earlier: the strategy fails, and
    the command says which and why (exit 1), not that its own output cannot be read. (No dwell: with
    one, T2 would arrive where T1 still stands, and the study would be refused before solving,
    tests/test_network_headway.py.)"""
    study = write_yaml(tmp_path / "s.yaml", {
        "name": "allfail", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "running_times_s": [56.0], "dwell_s": 0, "time_step_s": 1.0,
        "trains": [{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": 10}],
        "substation": {"position_m": 300}, "strategies": ["following"], "buffer_m": 300, "points": 200,
        "output": str(tmp_path / "out")})
    r = CliRunner().invoke(app, ["network", str(study), "--workers", "1", "--no-plot"])
    assert r.exit_code == 1, r.output
    assert "failed: following" in r.output and "cannot be read" not in r.output, r.output


def test_a_train_that_departs_inside_the_buffer_fails_with_the_reason():
    """10 s after the first train, the second departs with the first's tail well inside 300 m: the
    leg says that, not only that Ipopt found its NLP infeasible."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 10.0], ["T1", "T2"], 1.0,
                   Supply(position=300.0), points=200, buffer=300.0)
    out = strategies.run_strategies(f, ["independent", "following"], progress=None)["following"]
    assert "cannot keep buffer_m 300 m behind the train ahead" in out["failed"], out["failed"]


def test_a_running_time_rounded_up_past_the_arrival_tolerance_is_flagged():
    """At 1 s steps the 55.2 s asked of the segment become 56 s: the train arrives 0.8 s after its
    timetable, beyond the re-simulation's 0.5 s, and the result says so (the re-simulation itself
    checks the 56 s and passes)."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [55.2], 10.0, [0.0], ["T1"], 1.0, Supply(position=650.0),
                   points=200)
    out = strategies.run_strategies(f, ["independent"], progress=None)["independent"]
    assert out["trains"]["T1"]["arrival_s"] == 56.0 and out["trains"]["T1"]["verified"]
    assert out["totals"]["status"].startswith("flagged") and "time_step_s" in out["totals"]["status"], \
        out["totals"]["status"]


def test_roundings_that_add_up_over_segments_past_the_arrival_tolerance_are_flagged():
    """At 1 s steps 55.5 s and 98.5 s become 56 s and 99 s: each segment within the 0.5 s arrival
    tolerance, but every train reaches Centrum 1 s after its timetable (55.5 + 20 + 98.5 = 174 s
    after departure, the legs 175 s). The sum is flagged, naming the stop; the same roundings from
    a supplement (the timetable is then each segment's time rounded up) are not."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station", "Centrum"], [55.5, 98.5], 20.0, [0.0], ["T1"], 1.0,
                   Supply(position=300.0), points=200)
    assert fleet.late_at_stops(f) == [("Station", 0.5), ("Centrum", 1.0)]
    out = strategies.run_strategies(f, ["independent"], progress=None)["independent"]
    assert out["trains"]["T1"]["arrival_s"] == 175.0 and out["trains"]["T1"]["verified"]
    status = out["totals"]["status"]
    assert status.startswith("flagged") and "reaches Centrum 1.0 s after its timetable" in status, status
    f.timetabled = False  # the same legs as a supplement's timetable: each rounding within the tolerance
    assert strategies.timetable_rounding(f) == []


def test_a_joint_optimum_a_current_limit_makes_infeasible_names_the_limit():
    """600 A at 750 V lets the metro train draw 450 kW, 382 kW at its wheels (traction efficiency
    0.85): its fastest run from Noord to Station then takes about 60 s, more than the 56 s asked.
    The joint NLP has no point, and its reason says why with the numbers, not Ipopt's word alone;
    the independent run's unserved traction names the limit too. With 2000 A the limit does not
    explain a failure and is not named."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0], ["T1"], 1.0,
                   Supply(position=650.0, max_current=600.0), points=200)
    out = strategies.run_strategies(f, ["independent", "joint"], progress=None)
    why = out["joint"]["failed"]
    assert "max_train_current_A 600 A" in why and "450 kW" in why and "382 kW at its wheels" in why, why
    slowest = float(why.split("then takes ")[1].split(" s")[0])
    assert 56.0 < slowest < 70.0, why
    assert "max_train_current_A 600 A or the line" in out["independent"]["totals"]["status"]
    roomy = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0], ["T1"], 1.0,
                       Supply(position=650.0, max_current=2000.0), points=200)
    assert joint.why_not_powered(roomy, SolverError("joint optimum: Ipopt infeasible")) == \
        "joint optimum: Ipopt infeasible"


def test_a_joint_optimum_the_line_cannot_power_names_the_supply(tmp_path):
    """At 100 V (pantograph at least 67 V, 10 mOhm inside the substation) the line gives a train
    at most 67 x 33 / 0.01 W = 222 kW, 189 kW at its wheels: its fastest run from Noord to Station
    takes about 70 s, more than the 56 s asked. The joint NLP's reason says so with the numbers and
    the fields to change (it said only `Ipopt infeasible`), and its start sets no current outside
    its bounds (the command printed Pyomo's W1002 lines, one per step; a whole process, as a user
    runs it)."""
    study = write_yaml(tmp_path / "s.yaml", {
        "name": "v100", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "supplement_percent": 10, "dwell_s": 20, "time_step_s": 1.0, "points": 200,
        "trains": [{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": 120}],
        "substation": {"position_m": 300, "voltage_V": 100}, "strategies": ["joint"], "output": str(tmp_path / "out")})
    done = subprocess.run([sys.executable, "-m", "ecostudy", "network", str(study), "--no-plot", "--workers", "1"],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    said = done.stdout + done.stderr
    assert done.returncode == 1, said
    assert "the line lets a train draw at most 222 kW at its pantograph" in said and "189 kW at its wheels" in said, said
    slowest = float(said.split("then takes ")[1].split(" s")[0])
    assert 56.0 < slowest < 80.0, said
    assert "W1002" not in said, said
