"""What a heavy-haul study refuses before computing, and the checks on a run's physics that its
inputs alone cannot settle: a reference table off the start stop or not standing at its ends
(whatever the overspeed tolerance), weights that cannot drive a run, a coupling closed by its
cars' spacing, and the energy balance's scale."""
import re
import warnings

import pandas as pd
import pytest

from ecostudy.core.errors import EcostudyWarning
from ecostudy.core.grid import make_segment
from ecostudy.heavyhaul.linear import fence, locomotive_groups
from ecostudy.heavyhaul.metrics import reasons
from ecostudy.heavyhaul.plant import CascadePlant
from ecostudy.heavyhaul.reference import single_mass
from ecostudy.io.loaders import load_consist, load_track
from ecostudy.studies.heavyhaul import expand

from .conftest import load_yaml, write_yaml
from .test_heavyhaul_status import invoke, reference_table, refused
from .test_heavyhaul_study import PAPER, short_line, study


def test_a_reference_table_not_starting_at_the_start_stop_is_refused(tmp_path):
    """A table from 500 m was run against a clock with no time for its first 500 m and flagged
    with a roll back of 486 m that never happened: refused, the row named."""
    rows = [(500, 0), (700, 20), (1100, 40), (4500, 40), (4800, 20), (5000, 0)]
    refused(invoke(study(tmp_path, reference=reference_table(tmp_path, rows)), tmp_path / "out"),
            "ref.csv", "distance_m, row 2", "500: the first distance must be 0")


@pytest.mark.parametrize("rows, words", [
    ([(0, 0), (200, 45), (4800, 45), (5000, 40)], ["reference.table", "ends at 40 km/h at 5000 m", "run past the stop"]),
    ([(0, 40), (200, 45), (4800, 45), (5000, 0)], ["reference.table", "starts at 40 km/h", "from rest"]),
    ([(0, 0), (200, 45), (4800, 45), (5000, 0.1)], ["reference.table", "ends at 0.1 km/h", "under 0.072 km/h"]),
])
def test_a_reference_not_standing_at_its_ends_is_refused_whatever_the_overspeed_tolerance(tmp_path, rows, words):
    """speed_tolerance_kmh is how far a car may run over the limit; a table ending at 40 km/h under a
    45 km/h one ran to the sample cap past the stop. Standing is the loop's (under 0.02 m/s)."""
    path = study(tmp_path, reference=reference_table(tmp_path, rows), speed_tolerance_kmh=45)
    refused(invoke(path, tmp_path / "out"), *words)


@pytest.mark.parametrize("changes, words", [
    ({"weights": {"force": 0, "speed": 0, "energy": 0}, "brake_penalty": [0]},
     ["weights", "force, speed and energy are all 0", "identically 0"]),
    ({"weights": {"force": 10, "speed": 0, "energy": 10}}, ["weights", "speed is 0", "sample cap"]),
])
def test_weights_that_cannot_drive_a_run_are_refused(tmp_path, changes, words):
    refused(invoke(study(tmp_path, **changes), tmp_path / "out"), *words)


def test_a_coupling_closed_by_its_cars_spacing_flags_the_run(tmp_path):
    """2 + 20 + 2 cars with couplers of 1 N/m on the 5 km line: the cars' centres pass each other
    (a coupling 41 m shorter than its 16.27 m spacing, far past its draft gears' 0.165 m travel);
    flagged, where and how much said."""
    consist = load_yaml(PAPER)
    consist["vehicles"] = [{"type": "locomotive", "count": 2}, {"type": "wagon", "count": 20},
                           {"type": "locomotive", "count": 2}]
    consist["couplers"]["stiffness_kN_per_m"] = 0.001
    write_yaml(tmp_path / "soft.yaml", consist)
    result = invoke(study(tmp_path, consist=str(tmp_path / "soft.yaml"), brake_penalty=[1]), tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert run["status"] == "flagged" and run["compression_max_m"] > run["compression_spacing_m"] >= 12.07
    assert closed(run) == pytest.approx(run["compression_max_m"], abs=1e-3)
    assert (f"draft gear bottomed out, the cars overlap, and its cars' {run['compression_spacing_m']:.2f} m spacing or "
            "more: the cars would pass through each other") in run["reason"]


def test_the_energy_balance_is_measured_against_its_largest_term_at_least_a_floor():
    """A train that never moved (every term about 1e-23 kWh, no traction) is not flagged for a
    residual of the same size; a residual is measured against the largest term (here the grade)
    and, below the floor, against the floor."""
    good = {"arrived": True, "ended": "at the stop", "stop_error_m": 0.1, "force_max_kN": 900.0, "force_limit_kN": 2000.0,
            "speed_excess_kmh": 0.0, "arrival_late_s": 10.0, "arrival_late_pct": 1.0}
    still = {**good, "traction_kWh": 0.0, "coupler_damping_kWh": 4.7e-23, "balance_residual_kWh": -4.8e-23}
    assert reasons(still, 100, 0) == []
    assert reasons({**still, "balance_residual_kWh": -0.5}, 100, 0) == [
        "the energy balance does not close: residual -0.50 kWh, 50 % of the 1 kWh of the floor, "
        "every term being smaller (tolerance 0.1 % of the balance's largest term, at least 1 kWh): the plant's "
        "integration is not to be trusted"]
    falling = {**good, "traction_kWh": 100.0, "grade_kWh": -3000.0}
    assert reasons({**falling, "balance_residual_kWh": 2.0}, 100, 0) == []  # 0.07 % of the grade's 3000 kWh
    assert reasons({**falling, "balance_residual_kWh": 4.0}, 100, 0)[0].startswith(
        "the energy balance does not close: residual 4.00 kWh, 0.13 % of the 3000 kWh of grade")


def test_tunnels_on_a_heavy_haul_run_are_said_to_be_unmodelled_not_a_missing_consist_field(tmp_path):
    """A consist file has no tunnel_resistance (a train file's field): the one warning names the
    track file's tunnels between the stops and says the heavy-haul plant does not model them; a
    tunnel beyond the stop is not named."""
    track = load_yaml(short_line(tmp_path))
    track["tunnels"] = [{"position_m": 2500, "length_m": 600, "cross_section_m2": 40},
                        {"position_m": 5200, "length_m": 300, "cross_section_m2": 60}]  # beyond B (5000 m)
    write_yaml(tmp_path / "tunnels.yaml", track)
    with pytest.warns(EcostudyWarning) as caught:
        expand(study(tmp_path, track=str(tmp_path / "tunnels.yaml")), tmp_path / "out")
    assert [str(w.message) for w in caught] == [
        f"{tmp_path / 'tunnels.yaml'}: tunnels: the heavy-haul plant does not model tunnel resistance (nor does its "
        "single-mass reference; a consist file has no field for it): every tunnel between 'A' and 'B' (2500-3100 m, "
        "40 m^2) costs nothing in these runs"]


def test_a_stiffness_outside_the_range_of_freight_draft_gear_is_warned_of_naming_file_field_range_and_sources(tmp_path):
    """The published linear equivalents of a coupling of two freight draft gears run from 10 488 kN/m
    (Zhang & Zhuan) to 23 851 kN/m (two Miner TF-880 gears at their maximum capacity); outside
    5000-50 000 kN/m the couplers' and the draft gear's loading stiffness are warned of, one line
    each; the shipped consist (10 488, 13 984 and 6992 kN/m) loads without a warning."""
    load_consist(PAPER)  # EcostudyWarning is an error in the tests
    consist = load_yaml(PAPER)
    consist["couplers"]["stiffness_kN_per_m"] = 2000
    consist["draft_gear"]["loading_stiffness_kN_per_m"] = 2e5
    write_yaml(tmp_path / "odd.yaml", consist)
    with pytest.warns(EcostudyWarning) as caught:
        load_consist(tmp_path / "odd.yaml")
    sources = ("the range plausible for freight draft gear (published linear equivalents of a coupling of two freight "
               "draft gears run from 10488 kN/m (Zhang & Zhuan 2013, Table II) to 23851 kN/m (two Miner TF-880 AAR "
               "M-901E gears in series at their maximum capacity); the range is half the lowest to twice the highest, "
               "docs/heavyhaul.md 'Consist files')")
    assert [str(w.message) for w in caught] == [
        f"{tmp_path / 'odd.yaml'}: couplers.stiffness_kN_per_m: 2000 kN/m is outside 5000-50000 kN/m, {sources}",
        f"{tmp_path / 'odd.yaml'}: draft_gear.loading_stiffness_kN_per_m: 200000 kN/m is outside 5000-50000 kN/m, "
        f"{sources}"]


def test_a_coupling_closed_past_its_draft_gears_travel_is_flagged_though_its_cars_do_not_pass(tmp_path):
    """The ore train with couplers of 5000 kN/m (within the plausible range) on the 5 km line, K_b =
    1: the rear locomotives' push at the start closes coupling 202 by 0.196 m, beyond the 0.1651 m
    its two draft gears travel (2 x 3.25 in, AAR M-901E Group J) though 16 m short of its cars'
    spacing: flagged saying so, exit 1 (the consist's own 10 488 kN/m close it 0.093 m there). With
    the draft gear's slack on, a coupling closes half the slack more before its gears are solid; a
    consist's couplers.draft_gear_travel_m replaces the default."""
    consist = load_yaml(PAPER)
    consist["couplers"]["stiffness_kN_per_m"] = 5000
    write_yaml(tmp_path / "soft.yaml", consist)
    result = invoke(study(tmp_path, consist=str(tmp_path / "soft.yaml"), brake_penalty=[1], speed_tolerance_kmh=5),
                    tmp_path / "out")
    assert result.exit_code == 1, result.output
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert closed(run) == pytest.approx(run["compression_max_m"], abs=1e-3)
    assert (f"at {run['compression_time_s']:.0f} s, its draft gears' travel of 0.165 m or more "
            "(couplers.draft_gear_travel_m; with draft_gear on, plus half the slack): draft gear bottomed out, the cars "
            "overlap (the plant's couplers have no end stop: they are too soft for the forces)") in run["reason"]
    assert run["status"] == "flagged" and run["compression_limit_m"] == pytest.approx(0.1651)
    assert run["compression_limit_m"] < run["compression_max_m"] < run["compression_spacing_m"]
    segment = make_segment(load_track(short_line(tmp_path)), single_mass(load_consist(PAPER), 1.0), "A", "B")
    assert CascadePlant(load_consist(PAPER), segment, draft_gear=True).travel == pytest.approx(0.1651 + 0.0125)
    consist["couplers"]["stiffness_kN_per_m"], consist["couplers"]["draft_gear_travel_m"] = 10488, 0.2
    write_yaml(tmp_path / "long.yaml", consist)
    assert CascadePlant(load_consist(tmp_path / "long.yaml"), segment).travel == 0.2


def closed(run):
    """How far runs.csv's ``reason`` says the most compressed coupling closed [m], checking it names
    the coupling as the ``compression_*`` columns do."""
    found = re.search(rf"coupler {run['compression_coupler']} \({run['compression_position_m']:.0f} m behind the head\) "
                      r"closed ([0-9.]+) m at", run["reason"])
    assert found, run["reason"]
    return float(found.group(1))


def test_a_very_long_consist_at_f_1_is_refused_with_its_estimate_before_any_design_model_is_built(tmp_path):
    """20 + 5000 + 20 cars (61 km) at f = 1 on the 5 km line: the size estimate refuses it from the
    consist alone. Counting its locomotive groups through the fence's design model (the zero-order
    hold of a 15 119 x 15 119 matrix) took most of an hour before the estimate, deaf to Ctrl-C; the
    refusal comes in a few seconds (a test that hangs here has regressed)."""
    consist = load_yaml(PAPER)
    consist["vehicles"] = [{"type": "locomotive", "count": 20}, *[{"type": "wagon", "count": 1000}] * 5,
                           {"type": "locomotive", "count": 20}]  # a group holds at most 1000
    consist["couplers"]["force_limit_kN"] = 1e5
    write_yaml(tmp_path / "long.yaml", consist)
    line = load_yaml(short_line(tmp_path))
    line["length_m"] = 70000  # no shorter than the train
    write_yaml(tmp_path / "long_line.yaml", line)
    path = study(tmp_path, consist=str(tmp_path / "long.yaml"), track=str(tmp_path / "long_line.yaml"),
                 brake_penalty=[1], fence=[1])
    refused(invoke(path, tmp_path / "out"), "horizons", "Kb=1 f=1 Np=4 Nc=2: 10,080 QP inputs",
            "an estimated", "give --force")


@pytest.mark.parametrize("vehicles", [[("locomotive", 2), ("wagon", 200), ("locomotive", 2)],
                                      [("locomotive", 3), ("wagon", 25), ("locomotive", 1), ("wagon", 7)]])
@pytest.mark.parametrize("f", [1, 2, 10])
def test_the_locomotive_groups_counted_from_the_kinds_are_the_fences(tmp_path, vehicles, f):
    """What the study counts before its size estimate is what the fence's design model has."""
    doc = load_yaml(PAPER)
    doc["vehicles"] = [{"type": kind, "count": count} for kind, count in vehicles]
    consist = load_consist(write_yaml(tmp_path / "consist.yaml", doc))
    expected = sum(-(-count // f) for kind, count in vehicles if kind == "locomotive")
    assert locomotive_groups(consist.kinds, f) == len(fence(consist, f, 20.0).locomotives) == expected


@pytest.mark.parametrize("end, side", [(4999, "before"), (5001, "beyond")])
def test_a_reference_table_ending_off_the_stop_by_more_than_the_stop_tolerance_is_refused(tmp_path, end, side):
    """The train follows a table to its end and stands within about 0.1 m of it: a table ending a
    metre off the 5000 m stop with a 0.1 m stop tolerance left every run off its stop, computed and
    flagged for nothing. Refused before computing, the table's last row named."""
    rows = [(0, 0), (500, 30), (4800, 30), (end, 0)]
    path = study(tmp_path, reference=reference_table(tmp_path, rows), brake_penalty=[60], stop_tolerance_m=0.1)
    refused(invoke(path, tmp_path / "out"), "ref.csv: distance_m, row 5", f"1 m {side} the stop at 5000 m",
            "stop_tolerance_m (0.1 m)")


def test_the_stop_error_is_measured_from_the_stop_not_from_the_reference_tables_end(tmp_path):
    """A table may end within the stop tolerance of the stop; the train follows it to its end. A train
    standing near the table's end at 4999.5 m is half a metre short of the stop: its stop error the
    head's from 5000 m (0.03 m when measured from the table's end), within the 1 m tolerance."""
    rows = [(0, 0), (500, 30), (4800, 30), (4999.5, 0)]
    path = study(tmp_path, reference=reference_table(tmp_path, rows), brake_penalty=[60], adhesion=True)
    invoke(path, tmp_path / "out")
    run = pd.read_csv(tmp_path / "out" / "runs.csv").iloc[0]
    assert abs(run["stop_error_m"] + 0.5) < 0.2 and run["ended"] == "at the stop" and run["arrived"], run.to_dict()


def test_fields_a_study_gives_and_its_runs_do_not_read_are_warned_of(tmp_path):
    """observer_q and observer_r with the observer off, a reference table's points and
    limit_lead_samples (the single-mass optimum's): one warning each group, naming the file and the
    fields; the same fields where they are read, none."""
    noises = study(tmp_path, observer_q=5, observer_r=7)
    with pytest.warns(EcostudyWarning) as caught:
        expand(noises, tmp_path / "out")
    assert [str(w.message) for w in caught] == [f"{noises}: observer_q, observer_r: not used: the observer is off "
                                                "(the controller reads the plant's true state)"]
    table = {**reference_table(tmp_path, [(0, 0), (500, 30), (4800, 30), (5000, 0)]), "points": 2000,
             "limit_lead_samples": 7}
    with pytest.warns(EcostudyWarning) as caught:
        expand(study(tmp_path, reference=table), tmp_path / "out")
    assert [str(w.message) for w in caught] == [
        f"{tmp_path / 'hh.yaml'}: reference.points, reference.limit_lead_samples: not used: they shape ecostudy's "
        "single-mass optimum; a reference table is followed as given"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", EcostudyWarning)
        expand(study(tmp_path, observer=True, observer_q=5, reference={"supplement_percent": 10, "points": 100,
                                                                       "limit_lead_samples": 2}), tmp_path / "out")


def test_brake_penalties_that_print_alike_are_refused_and_keyed_apart(tmp_path):
    """A run is named (``Kb=60 f=10 ...``), drawn and was keyed by K_b to 6 significant digits: 60 and
    60.0000001 in one study stored one row for both runs; refused in one line. In two studies the
    exact value is in the key, so 60.0000004 does not re-use 60's stored run."""
    refused(invoke(study(tmp_path, brake_penalty=[60, 60.0000001]), tmp_path / "out"),
            "brake_penalty", "60.0 and 60.0000001 both read 60", "differ")
    table = reference_table(tmp_path, [(0, 0), (500, 30), (4800, 30), (5000, 0)])
    keys = [expand(study(tmp_path, brake_penalty=[kb], reference=table), tmp_path / "out")[3][0]["key"]
            for kb in (60, 60.0000004, 60)]
    assert keys[0] != keys[1] and keys[0] == keys[2]


def test_a_run_too_long_for_its_samples_names_sample_time_s(tmp_path):
    """0.01 s samples on the 5 km line: 70 863 samples, hours at the least a sample costs, whatever the
    horizons (a 44-input QP): refused naming sample_time_s, which makes it too long, not horizons."""
    refused(invoke(study(tmp_path, brake_penalty=[1], sample_time_s=0.01, max_samples=100000), tmp_path / "out"),
            "hh.yaml: sample_time_s: Kb=1 f=10 Np=4 Nc=2: 44 QP inputs", "70,863 samples of 0.01 s", "an estimated")
