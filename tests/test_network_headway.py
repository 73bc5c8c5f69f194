"""A following train inside buffer_m of the train ahead from the timetable on: where the timetable
alone decides it (a train arrives where the one ahead still stands), `ecostudy network` refuses the
study in one line before solving anything (exit 2); where it takes the train ahead's dynamics (it
cannot get far enough ahead by the time the next departs), every strategy says so: the joint
optimum names the trains, the time and the distance, not only Ipopt's "infeasible" (real solves:
two metro trains 10 s apart on one segment, dt 1 s)."""
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.types import Supply
from ecostudy.io.loaders import load_network_study, load_track, load_train
from ecostudy.network import fleet, headway, strategies

from .conftest import STUDIES, TRACKS, TRAINS, write_yaml


def study(tmp_path, dwell, offset, buffer=150.0, strategies=("independent", "joint")):
    return write_yaml(tmp_path / "s.yaml", {
        "name": "inside", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "running_times_s": [56.0], "dwell_s": dwell, "time_step_s": 1.0,
        "trains": [{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": offset}],
        "substation": {"position_m": 300}, "strategies": list(strategies), "points": 200,
        **({"buffer_m": buffer} if buffer else {}), "output": str(tmp_path / "out")})


@pytest.mark.parametrize("buffer, asked", [(150.0, "buffer_m 150 m is asked"), (None, "no overlap is asked")])
def test_a_train_arriving_where_the_train_ahead_still_stands_is_refused_before_solving(tmp_path, buffer, asked):
    """T2 leaves 10 s after T1 and both dwell 10 s: T2 reaches Station (650 m) at 66 s, the last step
    of T1's dwell there; no runs can keep any gap, so the study is refused: one line, the file, the
    field, both trains, the time; no output written."""
    path = study(tmp_path, dwell=10, offset=10, buffer=buffer)
    r = CliRunner().invoke(app, ["network", str(path), "--workers", "1", "--no-plot"])
    assert r.exit_code == 2, r.output
    lines = [line for line in r.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in r.output, r.output
    line = lines[0]
    assert f"{path}: trains: train T2 arrives at Station at 66 s while train T1 stands at Station" in line, line
    assert "at least 90.0 m past T1's tail (they overlap)" in line and asked in line and "offset_s" in line, line
    assert not (tmp_path / "out" / "results.sqlite").exists()


def test_the_shipped_studies_and_the_buffer_study_pass_the_timetable_check():
    """The refusal is only where the timetable decides it: the shipped network studies and two
    trains 30 s apart with buffer_m 150 (tests/test_network_buffer.py, where the buffer binds but
    can be kept) pass (``fleet.plan``'s check, called before anything is solved, stopped there)."""
    class Seen(Exception):
        pass

    def stop(fl):
        raise Seen(headway.timetable_conflict(fl))

    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    plans = [(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 30.0], ["T1", "T2"], 1.0,
              Supply(position=300.0), 200, 150.0)]
    for name in ("network_metro_2trains", "network_metro_3trains"):  # the 20-stop study's times need its all-out runs
        st = load_network_study(STUDIES / f"{name}.yaml")
        plans.append((st.track, st.train, st.stops, st.running_times, st.dwell, st.offsets, st.names, st.dt,
                      st.supply, st.points, st.buffer))
    for args in plans:
        with pytest.raises(Seen) as seen:
            fleet.plan(*args, check=stop)
        assert seen.value.args[0] is None, seen.value.args[0]
    # the same check on a timetable that fails it: T2 4 s after T1 arrives while T1 dwells
    with pytest.raises(Seen) as seen:
        fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 4.0], ["T1", "T2"], 1.0,
                   Supply(position=300.0), 200, None, check=stop)
    found = seen.value.args[0]
    assert (found["train"], found["ahead"], found["time_s"], found["gap_m"]) == ("T2", "T1", 60.0, -90.0), found


@pytest.fixture(scope="module")
def too_close():
    """T2 departs 10 s after T1, no dwell: the timetable alone allows it (T1 may be anywhere up to
    Station by then), T1's dynamics do not (buffer_m 150)."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 0.0, [0.0, 10.0], ["T1", "T2"], 1.0,
                   Supply(position=300.0), points=200, buffer=150.0)
    return f, strategies.run_strategies(f, ["independent", "receptivity", "joint", "following"], progress=None)


def test_the_train_aheads_fastest_start_bounds_every_run(too_close):
    """The furthest T1 can be 10 s after departing (its leg NLP maximising its distance then) is
    beyond where every strategy's T1 is, and short of the 150 m + 90 m that T2's departure needs."""
    f, out = too_close
    assert headway.timetable_conflict(f) is None
    far = headway.furthest(f.legs[0][0], 10)
    ran = out["independent"]["runs"][0][0].s[10]
    assert ran <= far + 1e-6 and far < 150.0 + 90.0, (ran, far)
    found = headway.reach_conflict(f)
    assert (found["train"], found["ahead"], found["time_s"]) == ("T2", "T1", 10.0), found
    assert found["furthest_m"] == pytest.approx(far, abs=1e-9) and found["gap_m"] == pytest.approx(far - 90.0)


def test_the_joint_optimum_says_which_trains_when_and_how_far_not_only_infeasible(too_close):
    f, out = too_close
    why = out["joint"]["failed"]
    assert why.startswith("train T2 departs Noord at 10 s, when train T1, 10 s after it departed, can be at most"), why
    far = headway.furthest(f.legs[0][0], 10)
    assert f"{far:.1f} m along its leg" in why and f"at least {90.0 - far:.1f} m past T1's tail" in why, why
    assert "buffer_m 150 m" in why and "Ipopt" in why, why


def test_the_other_strategies_stay_honest(too_close):
    """The rules and `following` fail with their leg's own reason; the independent runs, which
    ignore the buffer, are flagged with the trains, the time and the place where they overlap."""
    _, out = too_close
    for name in ("receptivity", "following"):
        assert "train T2, leg 1: cannot keep buffer_m 150 m behind the train ahead" in out[name]["failed"], out[name]
    status = out["independent"]["totals"]["status"]
    assert status.startswith("flagged: trains overlap on the line: train T2's head came"), status
    assert "past the tail of train T1 at" in status and "m along the line" in status, status


def test_a_train_behind_that_must_start_while_the_train_ahead_stands_is_named(tmp_path):
    """T2 departs 60 s after T1, buffer_m 560: when T2 departs, T1 stands at Station, its tail exactly
    560 m ahead, so the timetable passes. But T1 stands there until 66 s (its terminus dwell) and T2,
    to cover the 650 m by 116 s, must have left Noord by then (its latest start: 0.8 m along at 66 s
    measured, its all-out time 50.x s): no run keeps the buffer. The joint optimum's NLP with the
    buffer's rows is infeasible, and its reason names T2's latest start and T1 standing, not only
    Ipopt's word; the rules' and `following`'s leg NLP, given T1's run, is infeasible too, and its
    reason says how near T2 must come and when."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 60.0], ["T1", "T2"], 1.0,
                   Supply(position=300.0), points=200, buffer=560.0)
    assert headway.timetable_conflict(f) is None
    found = headway.reach_conflict(f)
    assert (found["train"], found["ahead"], found["time_s"], found["least"]) == ("T2", "T1", 66.0, True), found
    least = headway.furthest(f.legs[1][0], 6, least=True)
    assert 0.0 < least < 5.0 and found["furthest_m"] == pytest.approx(least, abs=1e-9), least  # 0.8 m measured
    out = strategies.run_strategies(f, ["independent", "receptivity", "joint", "following"], progress=None)
    for name in ("receptivity", "following"):  # the leg's own reason: the nearest any run must come, and when
        assert out[name]["failed"].startswith(
            "train T2, leg 1: cannot keep buffer_m 560 m behind the train ahead: on any run that arrives on time its "
            f"head comes within {560.0 - least:.1f} m of that train's tail, at 66 s (offset_s, dwell_s) (Ipopt "
            "infeasible after"), out[name]
    why = out["joint"]["failed"]
    assert why.startswith("train T2 runs from Noord to Station at 66 s, 6 s after it departed, when train T1 stands at "
                          f"Station: to arrive on time it must be at least {least:.1f} m along its leg (its latest "
                          f"start): T2's head is at most {560.0 - least:.1f} m behind T1's tail"), why
    assert "buffer_m 560 m is asked" in why and "Ipopt" in why, why


@pytest.fixture(scope="module")
def restricted(tmp_path_factory):
    """T2 departs 30 s after T1 over 1200 m with a 15 km/h restriction from 500 to 700 m, 152 s
    each (all-out 141.1 s), buffer_m 150: T1 may be far enough ahead when T2 departs and T2 far
    enough behind when T1 arrives (both checks pass), but through the restriction both crawl and
    30 s at 4.2 m/s is 125 m, less than buffer_m plus the 90 m train: no runs of both keep it."""
    path = write_yaml(tmp_path_factory.mktemp("restricted") / "track.yaml", {
        "name": "restricted", "source": "test: a 15 km/h restriction mid-segment", "length_m": 1200,
        "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1200}],
        "gradients": [{"position_m": 0, "gradient_permille": 0}], "curves": [{"position_m": 0, "radius_m": None}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 80}, {"position_m": 500, "speed_kmh": 15},
                         {"position_m": 700, "speed_kmh": 80}]})
    f = fleet.plan(load_track(path), load_train(TRAINS / "amsterdam_metro.yaml"), ["A", "B"], [152.0], 0.0, [0.0, 30.0],
                   ["T1", "T2"], 1.0, Supply(position=600.0), points=200, buffer=150.0)
    return f, strategies.run_strategies(f, ["independent", "joint"], progress=None)


@pytest.mark.slow  # about a minute of CPU: three Ipopt solves of both trains' legs
def test_a_conflict_while_both_trains_run_names_the_trains_the_least_gap_and_when(restricted):
    """Neither the timetable nor a departure or arrival explains the joint NLP's infeasibility; its
    reason is the nearest any runs of both must come (``headway.running_conflict``: both trains'
    leg NLPs minimising the largest shortfall of the buffer's rows, the legs' own formula), the
    trains and the time, not only Ipopt's word and the closest approach of the optimum without the
    rows."""
    f, out = restricted
    assert headway.timetable_conflict(f) is None and headway.reach_conflict(f) is None
    found = headway.running_conflict(f)
    assert (found["train"], found["ahead"]) == ("T2", "T1") and 0.0 < found["gap_m"] < 150.0, found
    assert found["doing"] == "runs from A to B" and found["ahead_doing"] == "runs from A to B", found
    why = out["joint"]["failed"]
    assert why.startswith(f"train T2 runs from A to B at {found['time_s']:g} s while train T1 runs from A to B: on any "
                          f"runs of both that keep the timetable, T2's head is at most {found['gap_m']:.1f} m behind "
                          "T1's tail there, where buffer_m 150 m is asked"), why
    assert "(joint optimum with buffer_m's rows: Ipopt infeasible after" in why, why
    # the independent runs ignore the buffer: they come no further apart than the most any runs keep
    assert out["independent"]["totals"]["separation_min_m"] <= found["gap_m"] + 1e-3, out["independent"]["totals"]
