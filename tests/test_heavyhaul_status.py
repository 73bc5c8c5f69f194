"""`ecostudy heavyhaul` says when a run missed: every failure class is flagged (exit 1) or refused
in one line before computing (exit 2), each by a real run or a real expansion on a 5 km line."""
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.core.status import off_stop
from ecostudy.io.loaders import load_consist
from ecostudy.core.units import KMH
from ecostudy.heavyhaul.loop import STANDING, LoopRecord, target_words
from ecostudy.heavyhaul.metrics import STOOD, Tolerances, ended, reasons
from ecostudy.studies.heavyhaul import expand

from .conftest import load_yaml, write_yaml
from .test_heavyhaul_study import PAPER, study

runner = CliRunner()


def invoke(path, out):
    return runner.invoke(app, ["heavyhaul", str(path), "--out", str(out), "--no-progress", "--no-plot"])


def refused(result, *words):
    """Exit 2, one line naming ``words``, no traceback."""
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2, result.output
    assert len(lines) == 1 and all(w in lines[0] for w in words) and "Traceback" not in result.output, result.output


def test_a_sample_cap_before_the_reference_ends_is_refused(tmp_path):
    refused(invoke(study(tmp_path, brake_penalty=[1], max_samples=3), tmp_path / "out"),
            "max_samples", "before the reference's")


def test_a_sample_cap_short_of_the_stop_is_flagged(tmp_path):
    """24 samples of 20 s reach past the reference's 472 s, but the train is not at the stop by then."""
    result = invoke(study(tmp_path, brake_penalty=[1], max_samples=24), tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["status"] == "flagged" and not run["arrived"] and run["ended"] == "sample cap" and run["samples"] == 24
    assert "sample cap (24)" in run["reason"] and "before the stop" in run["reason"]
    assert run["stop_error_m"] < -1.0
    assert run["ended_s"] == 20 * 24 and np.isnan(run["arrival_s"])  # it never arrived: no arrival time, no lateness
    assert np.isnan(run["arrival_late_s"]) and np.isnan(run["arrival_late_pct"]) and "after the reference" not in run["reason"]


def test_a_coupler_over_its_limit_and_a_stop_off_the_mark_are_flagged(tmp_path):
    """With a coupler limit of 600 kN (above the 230-380 kN the start on the ruling grade needs, so
    the file is accepted) the plant's start pulls about 980 kN through the head couplers: flagged for
    that alone (the train stops within the 1 m tolerance); with a tolerance of a micrometre the same stop
    is flagged too."""
    weak = load_yaml(PAPER)
    weak["couplers"]["force_limit_kN"] = 600
    write_yaml(tmp_path / "weak.yaml", weak)
    result = invoke(study(tmp_path, brake_penalty=[1], consist=str(tmp_path / "weak.yaml")), tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["status"] == "flagged" and run["arrived"] and run["ended"] == "at the stop" and run["force_limit_kN"] == 600
    assert run["force_max_kN"] > 600 and "above the consist's 600 kN limit" in run["reason"]
    assert abs(run["stop_error_m"]) < 1 and "stop" not in run["reason"]
    assert run["arrival_s"] > 0 and run["speed_excess_kmh"] >= 0
    assert run["J_force"] > 0 and run["J_tracking"] > 0 and run["J_braking"] >= 0
    exact = invoke(study(tmp_path, brake_penalty=[1], consist=str(tmp_path / "weak.yaml"), stop_tolerance_m=1e-6),
                   tmp_path / "exact")
    assert exact.exit_code == 1, exact.output
    run = pd.read_csv(tmp_path / "exact" / "runs.csv").iloc[0]
    assert "the stop (tolerance 1e-06 m)" in run["reason"]  # it stood, but not at the stop: not arrived
    assert not run["arrived"] and run["ended"] in ("short of the stop", "beyond the stop")


def test_an_energy_balance_that_does_not_close_is_a_reason():
    """A residual beyond 0.1 % of the traction's work flags the run, naming the residual; the
    integrator's usual error (1.6e-4 of traction at most on the shipped lines) does not."""
    good = {"arrived": True, "ended": "at the stop", "stop_error_m": 0.1, "force_max_kN": 900.0, "force_limit_kN": 2000.0,
            "speed_excess_kmh": 0.0, "arrival_late_s": 10.0, "arrival_late_pct": 1.0, "traction_kWh": 23011.5}
    assert reasons({**good, "balance_residual_kWh": 3.6}, 100, 0) == []
    assert reasons({**good, "balance_residual_kWh": -20315.9}, 100, 0) == [
        "the energy balance does not close: residual -20315.90 kWh, 88 % of the 23012 kWh of traction (tolerance "
        "0.1 % of the balance's largest term, at least 1 kWh): the plant's integration is not to be trusted"]
    assert reasons({**good, "balance_residual_kWh": 3.6}, 100, 0, Tolerances(balance=1e-4))[0].startswith(
        "the energy balance does not close: residual 3.60 kWh, 0.016 % of the 23012 kWh")


def test_how_a_run_ended_is_read_from_its_record():
    """metrics.ended on a loop's record: a run the loop ended with the train rolling back reads
    'rolling back' and is not arrived, even within the stop's tolerance (when the loop ends a run:
    loop.finished, tests/test_heavyhaul_hold.py); standing, it reads 'at the stop' within the
    tolerance, 'beyond the stop' or 'short of the stop' outside it, 'stalled short of the stop'
    where the pull back exceeds the locomotives' utmost traction; not standing, 'sample cap'."""
    columns = [np.zeros(1)] * 13
    back = LoopRecord(*columns, 0.0, 0.0, 0.0, stood=False, rolling_back=True)
    assert ended(back, -0.5, 1.0) == "rolling back" and "rolling back" not in STOOD
    stood = back._replace(stood=True, rolling_back=False, end_forces=(400e3, 500e3))
    assert [ended(stood, error, 1.0) for error in (-0.5, 2.7, -2.7)] == ["at the stop", "beyond the stop", "short of the stop"]
    assert ended(stood._replace(end_forces=(500e3, 400e3)), -2.7, 1.0) == "stalled short of the stop"
    assert ended(stood._replace(stood=False), -2.7, 1.0) == "sample cap"


def test_each_missed_limit_is_a_reason():
    """The rule itself on the numbers of a run: an overrun of metres, a car over the line's limit,
    solves over Ts, an arrival later than the reference by more than 5 % of its running time; a run
    within every tolerance is ok."""
    good = {"arrived": True, "ended": "at the stop", "stop_error_m": 0.4, "force_max_kN": 900.0, "force_limit_kN": 2000.0,
            "speed_excess_kmh": 0.5, "arrival_late_s": 134.0,
            "arrival_late_pct": 4.9}
    assert reasons(good, 100, 0) == []
    assert reasons({**good, "stop_error_m": 2.7}, 100, 0) == ["stopped 2.7 m beyond the stop (tolerance 1 m)"]
    assert reasons({**good, "speed_excess_kmh": 3.0}, 100, 0) == [
        "a car ran 3.0 km/h over the line's limit (tolerance 1 km/h)"]
    assert reasons({**good, "force_max_kN": 815.6, "force_limit_kN": 800.0}, 100, 0) == [
        "largest coupler force 815.6 kN above the consist's 800 kN limit"]
    assert reasons(good, 100, 2) == ["2 solves over Ts (the previous input was held)"]
    grip = {"adhesion_use_max": 1.47, "adhesion_use_effort_kN": -400.0, "adhesion_use_kmh": 43.2,
            "adhesion_use_time_s": 340.0, "adhesion_use_head_m": 1200.0}
    assert reasons({**good, **grip}, 100, 0) == [
        "a locomotive asked 1.47 of its adhesion (mu(v) m g, Curtius & Kniffler, tolerance 1 %), braking 400 kN at "
        "43.2 km/h, 340 s, head at 1200 m, which the plant does not limit (adhesion: false): set adhesion: true or "
        "lower the locomotives' envelopes"]
    assert reasons({**good, **grip, "adhesion_use_max": 1.0099}, 100, 0) == []  # within the 1 % of the inputs' digits
    back = {**good, "arrived": False, "ended": "rolling back", "rolling_back": True, "speed_at_end_kmh": -0.26, "stop_error_m": -1329.52}
    assert reasons(back, 100, 0) == ["rolling back at 0.26 km/h 1329.5 m before the stop when the run ended (the loop "
                                     "ends a run on the reference's final approach when the train stands or rolls back)"]
    stall = {**good, "arrived": False, "ended": "stalled short of the stop", "stop_error_m": -1323.14, "reference_at_end_kmh": 36.1, "resistance_at_end_kN": 478.9,
             "traction_utmost_at_end_kN": 407.9}
    assert reasons(stall, 100, 0) == ["stopped 1323.1 m short of the stop (tolerance 1 m) with the reference at 36.1 "
                                      "km/h there, stalled: the grade and resistance there (479 kN) exceed the "
                                      "locomotives' utmost traction (408 kN)"]
    start = {**good, "rollback_m": 183.0, "stalled_before_stop_m": 19305.4, "stalled_after_start_m": 0.0}
    assert reasons(start, 100, 0) == ["the train rolled back 183 m from the start before it moved off"]
    assert reasons({**stall, "traction_utmost_at_end_kN": 480.0}, 100, 0) == [
        "stopped 1323.1 m short of the stop (tolerance 1 m) with the reference at 36.1 km/h there"]
    assert reasons({**good, "arrived": False, "ended": "sample cap", "stop_error_m": 50.0}, 100, 0) == [
        "the sample cap (100) came with the train 50 m beyond the stop, not stopped"]
    assert reasons({**good, "stop_error_m": 2.7}, 100, 0, Tolerances(5.0, 2 * KMH)) == []
    late = {**good, "arrival_late_s": 201.0, "arrival_late_pct": 7.8}
    assert reasons(late, 100, 0) == [
        "arrived 201 s (7.8 %) after the reference's running time (tolerance 5 % or 60 s, the larger)"]
    assert reasons(late, 100, 0, Tolerances(arrival=0.10)) == []
    assert reasons(late, 100, 0, Tolerances(arrival_s=300.0)) == []  # a short trip: 7.8 % but under the seconds
    assert reasons({**good, "arrival_late_s": -90.0, "arrival_late_pct": -3.0}, 100, 0,
                   Tolerances(arrival=0.0, arrival_s=0.0)) == []  # early is on time
    assert reasons({**late, "arrived": False, "ended": "sample cap", "stop_error_m": -50.0}, 100, 0) == [
        "the sample cap (100) came 50 m before the stop"]  # not arrived: the cap says it, not a late arrival
    assert reasons({**late, "arrived": False, "ended": "short of the stop", "stop_error_m": -2.0}, 100, 0) == [
        "stopped 2.0 m short of the stop (tolerance 1 m)", "arrived 201 s (7.8 %) after the reference's running time "
        "(tolerance 5 % or 60 s, the larger)"]  # it stood off the mark, late: both said


def reference_table(tmp_path, rows):
    (tmp_path / "ref.csv").write_text("distance_m,speed_kmh\n" + "\n".join(f"{d},{v}" for d, v in rows) + "\n")
    return {"table": str(tmp_path / "ref.csv")}


@pytest.mark.parametrize("changes, words", [
    ({"fence": [300]}, ["fence", "300", "1..204"]),
    ({"brake_penalty": [60, 1, 60]}, ["brake_penalty", "60", "twice"]),
    ({"horizons": [{"np": 4, "nc": 2}, {"np": 4, "nc": 2}]}, ["horizons", "twice"]),
    ({"rate_kN_per_sample": 1e-9}, ["rate_kN_per_sample", "1e-09 kN per sample"]),
    ({"observer": True, "observer_q": 0}, ["observer_q", "greater than 0"]),
    ({"observer": True, "observer_r": -0.01}, ["observer_r", "greater than 0"]),
])
def test_bad_sweeps_are_refused_in_one_line(tmp_path, changes, words):
    refused(invoke(study(tmp_path, **changes), tmp_path / "out"), *words)


@pytest.mark.parametrize("rows, words", [
    ([(0, 0), (100, 30), (4000, 30), (4600, 0)], ["ref.csv: distance_m, row 5: 4600", "400 m before the stop at 5000 m"]),
    # short of the stop and not standing there: one line, the row's (its speed is not a second problem)
    ([(0, 0), (100, 30), (4000, 30), (4600, 20)], ["ref.csv: distance_m, row 5: 4600", "400 m before the stop at 5000 m"]),
    ([(0, 0), (100, 300), (4900, 300), (5000, 0)], ["reference.table", "300 km/h", "cannot be followed"]),
    ([(0, 0), (100, "fast"), (5000, 0)], ["ref.csv", "speed_kmh, row 3", "'fast' is not a finite number"]),
    # the sample cap came with the train 176 km beyond a 5 km line's stop, its energies those of the fiction
    ([(0, 0), (100, 20), (200, 30), (5000, 30)], ["reference.table", "ends at 30 km/h at 5000 m", "run past the stop"]),
    ([(0, 0), (100, 30), (2000, 0), (2100, 30), (5000, 0)], ["reference.table", "0 km/h at 2000 m", "stand there"]),
    ([(0, 30), (4900, 30), (5000, 0)], ["reference.table", "starts at 30 km/h", "from rest"]),
    # 30 km/h to 0 in 10 m: (8.33 m/s)^2 / 20 m, beyond the ore train's 37 600 kN of brakes over 13 704 t
    ([(0, 0), (100, 30), (4990, 30), (5000, 0)], ["ref.csv: 4990-5000 m (30 to 0 km/h)", "asks 3.47 m/s^2 of braking",
                                                  "more than the 2.74 m/s^2", "cannot be followed"]),
])
def test_unfollowable_reference_tables_are_refused_in_one_line(tmp_path, rows, words):
    refused(invoke(study(tmp_path, reference=reference_table(tmp_path, rows)), tmp_path / "out"), *words)


def test_a_reference_table_braking_beyond_the_service_rate_is_followed_with_a_warning(tmp_path):
    """30 km/h to 0 over the last 50 m asks 0.69 m/s^2: within the ore train's brakes (2.74 m/s^2),
    beyond its 0.3 m/s^2 service rate: one line naming the table and the piece, and the study runs."""
    path = study(tmp_path, reference=reference_table(tmp_path, [(0, 0), (100, 30), (4950, 30), (5000, 0)]))
    with pytest.warns(EcostudyWarning) as caught:
        expand(path, tmp_path / "out")
    assert [str(w.message) for w in caught] == [
        f"{tmp_path / 'ref.csv'}: 4950-5000 m (30 to 0 km/h): asks 0.69 m/s^2 of braking, within the 2.74 m/s^2 the "
        "train's brakes give at the most (every brake at full force), beyond the 0.3 m/s^2 it brakes at in service "
        "(reference.service_deceleration_mps2)"]


def climb_study(tmp_path, permille, wagons=40, motors_kN=None, gradients=(), limit_kmh=60, start_permille=0, **changes):
    """One locomotive and 40 ``wagons`` (2766 t) from rest to rest over 3 km, ``start_permille`` to 300 m,
    climbing ``permille`` from there (then the ``gradients``, (position m, per mille) pairs) under ``limit_kmh``; K_b = 60, f = 10,
    Np = Nc = 1; ``motors_kN``: the locomotive's traction and dynamic brake at most this force (560 and
    400 kN)."""
    consist = load_yaml(PAPER)
    consist["vehicles"] = [{"type": "locomotive", "count": 1}, {"type": "wagon", "count": wagons}]
    if motors_kN is not None:
        for envelope in ("traction", "dynamic_brake"):
            consist["types"]["locomotive"][envelope]["max_force_kN"] = motors_kN
    write_yaml(tmp_path / "one.yaml", consist)
    line = {"name": "climb", "source": "test", "length_m": 4000,
            "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 3000}],
            "gradients": [{"position_m": 0, "gradient_permille": start_permille},
                          {"position_m": 300, "gradient_permille": permille},
                          *({"position_m": x, "gradient_permille": g} for x, g in gradients)],
            "speed_limits": [{"position_m": 0, "speed_kmh": limit_kmh}]}
    write_yaml(tmp_path / "climb.yaml", line)
    return study(tmp_path, consist=str(tmp_path / "one.yaml"), track=str(tmp_path / "climb.yaml"), brake_penalty=[60],
                 horizons=[{"np": 1, "nc": 1}], **changes)


def test_a_train_that_stalls_on_a_climb_and_rolls_back_says_so(tmp_path):
    """One locomotive (560 kN) and 40 wagons (2766 t: 678 kN of grade alone) told by a reference
    table to climb 25 per mille at 30 km/h: the train stalls on the climb about 1.6 km before the
    stop and rolls back hundreds of metres before the sample cap (25 samples, 500 s) ends the run.
    Flagged, and the reason names the stall and the roll back, not only the cap."""
    path = climb_study(tmp_path, 25, max_samples=25,
                       reference=reference_table(tmp_path, [(0, 0), (200, 30), (2800, 30), (3000, 0)]))
    result = invoke(path, tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["status"] == "flagged" and not run["arrived"] and run["ended"] == "sample cap"
    assert run["rollback_m"] > 100 and 1000 < run["stalled_before_stop_m"] < 2500
    assert "stalled" in run["reason"] and "rolled back" in run["reason"] and "sample cap (25)" in run["reason"]


def test_a_reference_table_over_a_restriction_between_its_rows_is_refused(tmp_path):
    """A table at 50 km/h from 500 m to 4500 m over a line limited to 30 km/h from 2000 to 3000 m:
    no row of the table lies in the restriction, yet the table asks for 50 km/h all through it. It
    cannot be followed: refused in one line before computing (a 2 + 20 + 2 train, 323 m, ran it and a
    car went 20 km/h over the limit)."""
    small = load_yaml(PAPER)
    small["vehicles"][1]["count"] = 20
    write_yaml(tmp_path / "small.yaml", small)
    line = {"name": "restricted", "source": "test", "length_m": 6000,
            "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 5000}],
            "speed_limits": [{"position_m": 0, "speed_kmh": 60}, {"position_m": 2000, "speed_kmh": 30},
                             {"position_m": 3000, "speed_kmh": 60}]}
    write_yaml(tmp_path / "restricted.yaml", line)
    path = study(tmp_path, consist=str(tmp_path / "small.yaml"), track=str(tmp_path / "restricted.yaml"), brake_penalty=[60], horizons=[{"np": 1, "nc": 1}],
                 reference=reference_table(tmp_path, [(0, 0), (500, 50), (4500, 50), (5000, 0)]))
    refused(invoke(path, tmp_path / "out"), "reference.table", "50 km/h at 2000 m", "(30 km/h)", "cannot be followed")
    assert not (tmp_path / "out" / "runs.csv").exists()


def test_a_qp_that_fails_says_where_the_train_was(tmp_path):
    """A 2 + 20 + 2 train with brakes of 300 kN in all (50 kN per locomotive, 5 kN per wagon) told by
    a reference table to hold 40 km/h down 40 per mille (about 700 kN of grade): the train runs
    faster than v_r and no braking brings its mean speed back under it, so the QP has no solution.
    The run is failed, and its reason says when and where, at what speed against v_r, besides the
    solver's word."""
    weak = load_yaml(PAPER)
    weak["vehicles"][1]["count"] = 20
    weak["types"]["locomotive"]["dynamic_brake"] = {"max_force_kN": 50, "max_power_kW": 1000}
    weak["types"]["wagon"]["pneumatic_brake_kN"] = 5
    write_yaml(tmp_path / "weak.yaml", weak)
    line = {"name": "descent", "source": "test", "length_m": 8000,
            "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 7000}],
            "gradients": [{"position_m": 0, "gradient_permille": 0}, {"position_m": 1000, "gradient_permille": -40},
                          {"position_m": 6000, "gradient_permille": 0}],
            "speed_limits": [{"position_m": 0, "speed_kmh": 60}]}
    write_yaml(tmp_path / "descent.yaml", line)
    path = study(tmp_path, consist=str(tmp_path / "weak.yaml"), track=str(tmp_path / "descent.yaml"), brake_penalty=[60],
                 horizons=[{"np": 1, "nc": 1}],
                 reference=reference_table(tmp_path, [(0, 0), (300, 40), (6700, 40), (7000, 0)]))
    result = invoke(path, tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["status"] == "failed" and "daqp exit flag" in run["reason"]
    assert "head at" in run["reason"] and "mean speed" in run["reason"] and "v_r" in run["reason"], run["reason"]


def test_a_train_that_stalls_where_the_reference_runs_says_the_reference_speed(tmp_path):
    """With adhesion (409.7 kN per locomotive at rest, less with speed) one locomotive and 40 wagons
    cannot hold 17 per mille (478 kN of grade and resistance) that its 560 kN motors, and so the
    single-mass reference, can: on the reference's final approach (which begins where the reference
    slows on the climb) the stopping rule pulls with all the grip there is and the train still comes
    to rest about 1.3 km short of the stop (1323.1 m measured). Flagged, and the reason says so, that
    the reference ran about 36 km/h there and that the grade and resistance exceed the locomotives'
    utmost traction, so the end reads as the stall it is."""
    path = climb_study(tmp_path, 17, max_samples=60, adhesion=True, reference={"supplement_percent": 10, "points": 150})
    result = invoke(path, tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["status"] == "flagged" and run["stop_error_m"] < -1000 and run["samples"] < 60
    assert not run["arrived"] and run["ended"] == "stalled short of the stop"  # it stood, stalled: not arrived
    assert run["resistance_at_end_kN"] > run["traction_utmost_at_end_kN"] > 400  # 479 against 408 kN measured
    assert run["reason"] == (f"stopped {-run['stop_error_m']:.1f} m short of the stop (tolerance 1 m) with the reference "
                             f"at {run['reference_at_end_kmh']:.1f} km/h there, stalled: the grade and resistance there "
                             f"({run['resistance_at_end_kN']:.0f} kN) exceed the locomotives' utmost traction "
                             f"({run['traction_utmost_at_end_kN']:.0f} kN)")
    assert run["reference_at_end_kmh"] > 30


@pytest.mark.parametrize("air_brake", [False, True])
@pytest.mark.parametrize("permille, wagons, motors_kN, adhesion", [(20, 20, None, True), (15, 25, 280, False)])
def test_a_train_that_can_hold_the_climb_pulls_into_the_stop(tmp_path, permille, wagons, motors_kN, adhesion, air_brake):
    """One locomotive and 20 wagons on 20 per mille with adhesion on (294 kN of grade and resistance
    against 366 kN of grip at 11 km/h), and one locomotive of 280 kN (within its grip at every speed to
    60 km/h) and 25 wagons on 15 per mille with adhesion off (273 kN), each with the air brake off
    and on: on the final approach, where coasting would stand the train short of the stop (the grade
    alone decelerates it more than v^2 / 2d), the stopping rule pulls the force that leaves v^2 / 2d
    (without the air brake 8.8 and 4.2 kN measured at the first piece, 25 and 19 m before the stop)
    and the train stands at the stop: ok. A rule that coasts there stood the trains short: rolling
    back 0.8 and 0.3 m before the stop, and with the air brake (every sample from the braking point
    on a stopping sample) 114.7 and 53.1 m short."""
    path = climb_study(tmp_path, permille, wagons, motors_kN, max_samples=60, adhesion=adhesion, air_brake=air_brake,
                       reference={"supplement_percent": 10, "points": 150})
    result = invoke(path, tmp_path / "out")
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert result.exit_code == 0 and run["status"] == "ok", run["reason"]
    assert run["arrived"] and run["ended"] == "at the stop" and not run["rolling_back"]
    assert abs(run["stop_error_m"]) < 0.01  # 0.0005 m at most
    assert run["traction_utmost_at_end_kN"] > run["resistance_at_end_kN"]


def test_a_sag_into_the_stop_with_air_brakes_pulls_through_their_release(tmp_path):
    """One locomotive and 20 wagons with the wagons' air brake and adhesion on, down 12 per mille from
    300 m and up 15 per mille from 2800 m into the stop at 3000 m (80 km/h): the final application
    brakes on the descent, and on the climb the wagons' brakes are still releasing (tau_r = 17 s once
    the pipe's signal reaches them), so coasting stands the train short though the grade alone would
    not. The stopping rule's one-mass prediction runs the pipe's release, and where even coasting
    stands the train short the locomotives pull the share of their traction that stands it at the
    stop: ok, within 0.01 m (0.00002 m measured). A rule that pulled only for the grade (v^2 / 2d on
    instant brakes) stood it 2.6 m short."""
    path = climb_study(tmp_path, -12, 20, gradients=[(2800, 15)], limit_kmh=80, max_samples=60, adhesion=True,
                       air_brake=True, reference={"supplement_percent": 10, "points": 150})
    result = invoke(path, tmp_path / "out")
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert result.exit_code == 0 and run["status"] == "ok", run["reason"]
    assert run["arrived"] and run["ended"] == "at the stop" and abs(run["stop_error_m"]) < 0.01


@pytest.mark.parametrize("air_brake", [False, True])
def test_a_train_starting_on_a_climb_is_held_on_its_brakes_until_the_traction_is_up(tmp_path, air_brake):
    """One locomotive and 40 wagons (2766 t) starting from rest on 15 per mille (about 410 kN of grade)
    while the locomotive's effort ramps at the default 200 kN per sample: the brakes hold the standing
    train until the traction exceeds the grade (a hill start; with the air brake on, its wagons' brakes
    then release through the pipe), so at no sample end is the head more than 5 cm behind the start
    (without the hold it rolled back metres), and it arrives at the stop."""
    path = climb_study(tmp_path, 0, start_permille=15, max_samples=60, air_brake=air_brake,
                       reference={"supplement_percent": 10, "points": 150})
    invoke(path, tmp_path / "out")
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["rollback_m"] < 0.05 and run["stalled_after_start_m"] == 0, run["reason"]
    assert "rolled back" not in run["reason"] and run["arrived"] and run["ended"] == "at the stop", run["reason"]


def test_a_train_that_stalls_on_the_final_approach_and_rolls_back_ends_the_run_rolling_back(tmp_path):
    """One locomotive (adhesion on: 410 kN of grip at rest) and 40 wagons told by a reference table to
    slow from 30 km/h at 300 m to the stop at 3000 m, all of it up 40 per mille (874 kN of grade and
    resistance): the reference's final approach begins at 300 m, the train stalls on it about 2.3 km
    before the stop and is rolling back (0.42 km/h measured, more than the 0.07 km/h of a standing
    train) when the loop ends the run there (loop.finished), in 8 samples. The loop says it did not
    stand: flagged, exit 1, ended "rolling back" with the speed and where in the reason. Without the
    loop's check of the speed at the end the same run reads as a stall that stood."""
    path = climb_study(tmp_path, 40, max_samples=40, adhesion=True,
                       reference=reference_table(tmp_path, [(0, 0), (100, 30), (300, 30), (3000, 0)]))
    result = invoke(path, tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["status"] == "flagged" and not run["arrived"] and run["samples"] < 40
    assert run["ended"] == "rolling back" and run["rolling_back"] and run["speed_at_end_kmh"] < -STANDING / KMH
    assert run["stop_error_m"] < -2000 and run["resistance_at_end_kN"] > run["traction_utmost_at_end_kN"]
    assert run["reason"].startswith(f"rolling back at {-run['speed_at_end_kmh']:.2f} km/h "
                                    f"{-run['stop_error_m']:.1f} m before the stop when the run ended"), run["reason"]
    assert "rolling back at" in result.output


def test_a_locomotives_pneumatic_brake_and_a_type_no_group_uses_are_named(tmp_path):
    """A locomotive's pneumatic_brake_kN was added to its dynamic brake beyond the adhesion cap, the
    reason then asking for `adhesion: true`, already set; an unused type was silent."""
    consist = load_yaml(PAPER)
    consist["types"]["locomotive"]["pneumatic_brake_kN"] = 300
    path = write_yaml(tmp_path / "c.yaml", consist)
    with pytest.raises(InputError, match="types.locomotive: pneumatic_brake_kN: a locomotive brakes with its dynamic_brake"):
        load_consist(path)
    consist = load_yaml(PAPER)
    consist["types"]["tank"] = consist["types"]["wagon"]
    with pytest.warns(EcostudyWarning, match="types.tank: no vehicle group is of this type"):
        load_consist(write_yaml(tmp_path / "t.yaml", consist))


def test_a_stop_error_is_not_rounded_into_the_tolerance():
    """1.047 m beyond read 'stopped 1.0 m beyond the stop (tolerance 1 m)'."""
    assert off_stop(1.04684, 1.0, 1) == "stopped 1.05 m beyond the stop (tolerance 1 m)"
    assert off_stop(-2.0, 1.0, 1) == "stopped 2.0 m short of the stop (tolerance 1 m)"


def test_a_failed_solve_past_the_stop_never_states_a_negative_reference_speed():
    """Past the reference's stop the horizon's target continues the final deceleration below zero (the
    controller's internal target); a failed solve's reason states the reference as the user reads it,
    0 km/h past the stop, never a negative speed."""
    assert target_words(-37.1 * KMH) == "v_r 0 km/h at the sample's end (past the reference's stop)"
    assert target_words(0.0) == "v_r 0 km/h at the sample's end (past the reference's stop)"
    assert target_words(40 * KMH) == "v_r 40.0 km/h at the sample's end"
