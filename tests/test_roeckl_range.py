"""Roeckl's curve resistance only where it holds. ms-eetc (TTOBench's reference implementation)
refuses a track with a radius below 150 m (``mseetc/track.py``: ``CURVATURE_THRESHOLD = 1/150``,
"Issue with track curvatures!"); below 55 m the fit ms-eetc uses there, 0.65 / (r - 55), has no
value. ecostudy capped that fit below 60 m and ran ``ok`` on a made-up force: a 40 m curve cost
22.8 kWh against 9.9 kWh at 150 m, its 233 kN above the FLIRT's 200 kN of traction. Now a TTOBench
track with such a radius is refused, as ms-eetc refuses it, and a Roeckl train on any track with
one, naming the track's file and field. Edits of the published track and train of tests/data/ttobench."""
import json

import pytest
import yaml
from typer.testing import CliRunner

from ecostudy.analysis.single import solve_run
from ecostudy.cli import app
from ecostudy.core.errors import InputError
from ecostudy.core.physics import roeckl_force
from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train, track_from_dict

from .conftest import DATA
from .test_published_fields import edited

TRACK = json.loads((DATA / "ttobench" / "00_var_speed_limit_100.json").read_text())
TRAIN = DATA / "ttobench" / "NL_Intercity_VIRM6.json"


def curved(radius):
    """The published track with one curve of ``radius`` [m] from 20 to 21 km."""
    return lambda d: d.update({"curvatures": {"units": {"position": "m", "radius at start": "m", "radius at end": "m"},
                                              "values": [[0.0, "infinity", "infinity"], [20000.0, radius, radius],
                                                         [21000.0, "infinity", "infinity"]]}})


def error_line(tmp_path, track):
    result = CliRunner().invoke(app, ["solve", "--track", str(track), "--train", str(TRAIN), "--supplement", "10",
                                      "-K", "50", "--no-plot", "--out", str(tmp_path / "o")])
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and len(lines) == 1 and "Traceback" not in result.output, result.output
    assert not (tmp_path / "o").exists()
    return lines[0]


@pytest.mark.parametrize("radius", [40, -100, 149])
def test_a_ttobench_curve_below_150_m_is_refused_as_ms_eetc_refuses_it(tmp_path, radius):
    path = edited(tmp_path, curved(radius), TRACK, "track.json")
    assert error_line(tmp_path, path) == (
        f"error: {path}: curvatures.values[1]: a radius of {abs(radius)} m, below 150 m: ms-eetc refuses the track "
        "(its curvature limit), and Roeckl's formula of curve resistance is not used below it")


def test_a_clothoid_ending_below_150_m_is_refused_and_150_m_is_read(tmp_path):
    path = edited(tmp_path, lambda d: (curved(150)(d), d["curvatures"]["values"][1].__setitem__(2, 120)), TRACK, "t.json")
    with pytest.raises(InputError, match=r"curvatures\.values\[1\]: a radius of 120 m, below 150 m"):
        load_track(path)
    track = load_track(edited(tmp_path, curved(150), TRACK, "t150.json"))
    assert abs(track.curvatures).max() == pytest.approx(1 / 150)


YAML_TRACK = """name: tight
source: test
length_m: 3000
stops: [{name: A, position_m: 0}, {name: B, position_m: 3000}]
gradients: [{position_m: 0, gradient_permille: 0}]
curves: [{position_m: 0, radius_m: null}, {position_m: 1000, radius_m: 100}, {position_m: 1200, radius_m: null}]
speed_limits: [{position_m: 0, speed_kmh: 80}]
"""


def test_a_roeckl_train_on_a_yaml_track_with_a_tight_curve_is_refused_naming_the_track(tmp_path):
    """A 100 m curve on a line of ecostudy's own format, a TTOBench train (Roeckl's formula): the run
    was ok on 0.65 / (100 - 55) of the train's weight, a fit ms-eetc never uses there."""
    path = tmp_path / "tight.yaml"
    path.write_text(YAML_TRACK)
    assert error_line(tmp_path, path) == (
        f"error: {path}: curves: the curve at 1000 m has a radius of 100 m, below the 150 m from which Roeckl's "
        "formula (train 'NL_Intercity_VIRM6''s curve resistance, as ms-eetc uses it) is used: ms-eetc refuses such a "
        "track, and below 55 m the formula has no value")


def test_in_code_the_track_is_named_and_the_formula_refuses_a_radius_it_does_not_hold_for(tmp_path):
    track = track_from_dict(yaml.safe_load(YAML_TRACK))
    with pytest.raises(InputError, match=r"^track 'tight': curves: the curve at 1000 m has a radius of 100 m"):
        solve_run(track, load_train(TRAIN), "A", "B", Timing(supplement=0.1), points=50)
    with pytest.raises(ValueError, match="Roeckl's formula at a radius of 60 m, below 150 m"):
        roeckl_force(1000.0, [0.0, 1 / 60])
    assert roeckl_force(1000.0, 1 / 150) == pytest.approx(1000.0 * 9.80665 * 0.65 / 95)
