"""A network study's departures (offset_s) and dwell (dwell_s) on its clock of time_step_s steps:
one that falls between two steps is refused on loading, one line each naming the file, the field
and the two nearest times on the clock (exit 2, nothing solved, nothing written), not moved to a
step (at 0.5 s steps 0.75 s and 1.25 s both landed on 1.0 s, silently). Times the clock holds but
binary floats do not (48 s at 0.4 s steps) are on it."""
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.types import Supply
from ecostudy.io.loaders import load_network_study, load_track, load_train
from ecostudy.io.timetable import clock_steps
from ecostudy.core.errors import SolverError
from ecostudy.network import fleet, strategies

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml


def study(tmp_path, **changes):
    doc = load_yaml(STUDIES / "network_metro_2trains.yaml")
    doc.update(track=str(TRACKS / "metro_line_4stops.yaml"), train=str(TRAINS / "amsterdam_metro.yaml"),
               output=str(tmp_path / "out"), **changes)
    return write_yaml(tmp_path / "s.yaml", doc)


def errors(tmp_path, **changes):
    path = study(tmp_path, **changes)
    r = CliRunner().invoke(app, ["network", str(path), "--workers", "1", "--no-plot"])
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output
    assert not (tmp_path / "out").exists()  # refused before the output folder, before any solve
    return path, [line for line in r.output.splitlines() if line.strip()]


@pytest.mark.parametrize("offset, near", [(0.75, "give 0.5 or 1"), (1.25, "give 1 or 1.5"), (120.2, "give 120 or 120.5")])
def test_a_departure_between_two_clock_steps_is_refused_naming_the_nearest(tmp_path, offset, near):
    path, lines = errors(tmp_path, trains=[{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": offset}])
    assert lines == [f"error: {path}: trains[1].offset_s: {offset:g} s is not on the 0.5 s clock (time_step_s): {near}"]


def test_every_time_off_the_clock_is_named_at_once(tmp_path):
    path, lines = errors(tmp_path, dwell_s=20.2, time_step_s=0.4,
                         trains=[{"name": "T1", "offset_s": 0.1}, {"name": "T2", "offset_s": 48}])
    assert lines == [f"error: {path}: trains[0].offset_s: 0.1 s is not on the 0.4 s clock (time_step_s): give 0 or 0.4",
                     f"error: {path}: dwell_s: 20.2 s is not on the 0.4 s clock (time_step_s): give 20 or 20.4"], lines


def test_times_on_the_clock_pass_though_binary_floats_miss_it():
    """48 s / 0.4 s is 120.00000000000001 and 0.3 s / 0.1 s 2.9999999999999996: on the clock; the
    shipped studies load (the 20-stop one departs 48 s and 80 s apart at 0.4 s steps)."""
    assert clock_steps(48.0, 0.4) == 120 and clock_steps(0.3, 0.1) == 3 and clock_steps(80.0, 0.4) == 200
    assert clock_steps(0.75, 0.5) is None and clock_steps(1.25, 0.5) is None
    for name in ("network_metro_2trains", "network_metro_3trains", "network_regional_20stops"):
        st = load_network_study(STUDIES / f"{name}.yaml")
        assert all(clock_steps(t, st.dt) is not None for t in [*st.offsets, st.dwell]), name


def test_the_timetable_of_the_python_api_is_not_moved_either():
    """``fleet.plan`` given a departure or a dwell between two steps raises before preparing anything;
    on the clock, each train starts at its own step."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    for dwell, offsets in ((10.0, [0.0, 0.75]), (10.25, [0.0, 30.0])):
        with pytest.raises(ValueError, match="not on the 0.5 s clock"):
            fleet.plan(track, train, ["Noord", "Station"], [56.0], dwell, offsets, ["T1", "T2"], 0.5, Supply(position=300.0))

    class Seen(Exception):
        pass

    def stop(fl):
        raise Seen(fl)

    with pytest.raises(Seen) as seen:
        fleet.plan(track, train, ["Noord", "Station", "Centrum"], [56.0, 110.0], 10.5, [0.0, 1.5], ["T1", "T2"], 0.5,
                   Supply(position=300.0), check=stop)
    fl = seen.value.args[0]
    assert [legs[0].start for legs in fl.legs] == [0, 3] and fl.dwell_steps == 21
    assert fl.legs[1][1].start == 3 + 112 + 21


def _one_leg(stops, seconds, step):
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    return fleet.plan(track, train, stops, [seconds], 0.0, [0.0], ["T1"], step, Supply(position=650.0), points=200)


def test_a_clock_too_coarse_for_the_run_says_so():
    """A clock the schema allows (up to 5 s) can be too coarse for a leg: at 3 s steps Noord ->
    Station (56 s) re-simulates 1.3 % off in traction energy, at 5 s Centrum -> Zuid (65 s, 13 steps)
    has no run; the flag names the leg, what it missed and the clock, the failure the leg's steps
    and the clock (both said only "re-simulation" or "Ipopt infeasible")."""
    out = strategies.run_strategies(_one_leg(["Noord", "Station"], 56.0, 3.0), ["independent"], progress=None)
    status = out["independent"]["totals"]["status"]
    assert status.startswith("flagged") and "T1 leg 1: energy_error_pct" in status and "on the 3 s clock" in status, status
    with pytest.raises(SolverError, match=r"leg 1: Ipopt infeasible after \d+ iterations \(13 steps of 5 s: time_step_s\)"):
        strategies.run_strategies(_one_leg(["Centrum", "Zuid"], 65.0, 5.0), ["independent"], progress=None)
