"""Calibrate's and validate's rules on what the logs alone show: identifiability judged from the logs
(not from the train file's value), a log's first run kept when it has no speed column, a misnamed
column refused, a run ending between stations flagged, a log ending at rest while braking ending at
a stand, an empty --fit refused."""
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from ecostudy.calibration.estimate import calibrate_logs
from ecostudy.calibration.fit import DEFAULT_FIT
from ecostudy.calibration.generate import LogNoise, generate_log, true_train
from ecostudy.calibration.replay import prepare
from ecostudy.calibration.validate import validate_log
from ecostudy.cli import app
from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.logfile import parse_log

from .conftest import TRACKS, TRAINS

TRAIN, TRACK = TRAINS / "regional_alstom.yaml", TRACKS / "calibration_line.yaml"
THERE = ["West", "Middle", "East"]


def as_log(frame, name="log"):
    text = f"---\ntrack: {TRACK}\ntrain: {TRAIN}\n---\n" + frame.to_csv(index=False, float_format="%.6f")
    return parse_log(text, f"{name}.csv", name)


@pytest.fixture(scope="module")
def inputs():
    return load_track(TRACK), load_train(TRAIN)


def test_identifiability_does_not_depend_on_the_train_files_value(inputs):
    """Two 1 Hz logs of a train whose Davis terms differ from its file's. Against the file's B
    (119.5 N s/m) B's 95 % half-width was 66 % of it, B held and the calibration flagged; against a
    file with B ten times larger the same logs gave 7 %, B identifiable and the calibration ok. The
    logs alone judge it now: the same verdicts, estimates and intervals under both files, and no
    interval of a parameter called identifiable reaches below 0."""
    track, train = inputs
    truth = true_train(train, mass=1.04, davis=(1.1, 0.9, 1.05), efficiency=0.98)
    logs = [as_log(generate_log(track, truth, stops, truth, seed=seed, noise=LogNoise(rate=1.0))[0], f"log{seed}")
            for seed, stops in ((1, THERE), (2, THERE[::-1]))]
    tables = []
    for b in (train.davis[1], 10 * train.davis[1]):
        prior = replace(train, davis=(train.davis[0], b, train.davis[2]))
        result = calibrate_logs(logs, track, prior, DEFAULT_FIT, draws=0)
        table = result.table.set_index("name")
        assert (table.loc[table["identifiable"], "low"] >= 0).all(), table
        tables.append(table)
    assert (tables[0]["identifiable"] == tables[1]["identifiable"]).all(), tables
    for column in ("estimate", "low", "high"):
        assert np.allclose(tables[0][column], tables[1][column], rtol=1e-5, equal_nan=True), (column, tables)


def test_a_one_hertz_log_without_speeds_keeps_its_first_run(inputs):
    """Speeds from the positions: a first-order difference read 0.53 m/s at the first row of a
    train starting from rest at 1 Hz, above the rest speed, and the first run was dropped with a
    warning. A second-order one reads 0 there: both runs are replayed, and no warning."""
    track, train = inputs
    frame, _ = generate_log(track, train, THERE, train, seed=3, noise=LogNoise(rate=1.0))
    runs = prepare(as_log(frame.drop(columns=["speed_mps"]), "nospeed"), track, train)
    assert len(runs) == 2, [(r.x[0], r.x[-1]) for r in runs]
    assert abs(runs[0].x[0] - frame["position_m"].iloc[0]) < 1.0


def test_a_column_named_like_a_known_one_is_refused_naming_it(inputs):
    """Speed_MPS was left out with a warning (not modelled) and the speeds then taken from the
    positions; a near miss of a known column is refused, naming the file, the column and the name
    meant. A column that is no near miss is still left out with a warning."""
    frame, _ = generate_log(inputs[0], inputs[1], THERE, inputs[1], seed=3, noise=LogNoise(rate=1.0))
    with pytest.raises(InputError, match=r"^case.csv: Speed_MPS: unknown column; did you mean speed_mps\?"):
        as_log(frame.rename(columns={"speed_mps": "Speed_MPS"}), "case")
    frame["power_aux_kW"] = 1.0
    with pytest.warns(EcostudyWarning, match="power_aux_kW not modelled by ecostudy: left out"):
        as_log(frame, "aux")


def test_a_run_ending_between_stations_is_flagged_naming_the_nearest_stop(inputs):
    """A log that stands 20 s at 2500 m, between West (300 m) and Middle (5400 m), at a signal:
    validate reported both runs ok. The run that ends there is flagged, naming where it ended and
    the nearest stop; the run from there to Middle is not."""
    track, train = inputs
    signalled = replace(track, stops={"West": 300.0, "Signal": 2500.0, "Middle": 5400.0, "East": 10600.0})
    frame, _ = generate_log(signalled, train, ["West", "Signal", "Middle"], train, seed=5)
    table = validate_log(as_log(frame, "signal"), track, train)
    assert list(table["status"]) == ["flagged", "ok"], table.to_string()
    assert table["reason"].iloc[0].startswith("the run ends at 2500 m, 2200 m from the nearest stop (West at 300 m, "
                                              "tolerance 100 m)"), table["reason"].iloc[0]


def test_a_log_ending_at_rest_while_braking_ends_at_a_stand(inputs):
    """A log whose last row reads the train at rest (speed noise about 0) while the brake still
    holds: it was flagged as ending while the train moves ("-0.0 m/s") and its running time left out.
    At rest at its last row without traction, it ends at a stand: the run is compared and ok."""
    track, train = inputs
    frame, record = generate_log(track, train, THERE, train, seed=6)
    moving = np.nonzero(record["v"] > 0)[0]
    last = moving[-1] + 1  # the first row at rest after the last run's braking
    cut = frame.iloc[:last + 1].copy()
    cut.loc[cut.index[-1], "force_kN"] = -200.0  # the brake still applied at the stand
    table = validate_log(as_log(cut, "braking"), track, train)
    assert list(table["status"]) == ["ok", "ok"], table.to_string()
    assert np.isfinite(table["time_difference_pct"]).all(), table.to_string()


@pytest.mark.parametrize("fit", ["", ",", " , "])
def test_an_empty_fit_is_refused(tmp_path, fit):
    """--fit '' ran the default set silently (--fit , was refused): both say no parameter is named."""
    result = CliRunner().invoke(app, ["calibrate", str(tmp_path / "none.csv"), "--fit", fit, "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "--fit: no parameter named" in result.output, result.output
