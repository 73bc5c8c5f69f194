"""Hostile copies of the shipped study files of ``network``, ``simulate`` and ``heavyhaul``, through
the command line: one line naming the file and the field, exit status 2, before anything is
computed (no output folder, no store)."""
import shutil

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"


def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def refused(result, *fragments):
    """Exit 2, exactly one error line holding every fragment, no traceback."""
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def hostile(tmp_path, shipped, **changes):
    """A copy of ``studies/<shipped>`` with ``changes`` (None: the field removed), its files absolute,
    its output in ``tmp_path/out``."""
    doc = load_yaml(STUDIES / shipped)
    for key in ("track", "train", "consist"):
        if key in doc:
            doc[key] = str((STUDIES / doc[key]).resolve())
    if isinstance(doc.get("reference"), dict) and "table" in doc["reference"]:
        shutil.copy(STUDIES / doc["reference"]["table"], tmp_path)
    doc["output"] = str(tmp_path / "out")
    for key, value in changes.items():
        if value is None:
            doc.pop(key, None)
        else:
            doc[key] = value
    return write_yaml(tmp_path / f"hostile_{shipped}", doc)


def nothing_written(tmp_path):
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------------- the file itself
@pytest.mark.parametrize("command", ["network", "simulate", "heavyhaul"])
def test_a_folder_given_as_the_study_file_is_named_a_folder(tmp_path, command):
    refused(run(command, tmp_path, "--workers", 1), str(tmp_path), "a folder, not a file")


# ----------------------------------------------------------------------------------- checks across fields
@pytest.mark.parametrize("shipped, changes, fragment", [
    ("metro_monte_carlo.yaml", {"controllers": [{"name": "a", "kind": "ato"}, {"name": "a", "kind": "ato"}]},
     "controllers: names must be unique ('a' given twice)"),
    ("metro_monte_carlo.yaml", {"window_s": [76, 0]}, "window_s: must be [earliest, latest]"),
    ("metro_monte_carlo.yaml", {"window_s": [0, 5], "controllers": [{"name": "s", "kind": "sbpc", "sample_time_s": 6}]},
     "controllers[0].sample_time_s: must be shorter than the latest arrival"),
    ("network_metro_2trains.yaml", {"trains": [{"name": "T1", "offset_s": 0}, {"name": "T1", "offset_s": 120}]},
     "trains: names must be unique ('T1' given twice)"),
    ("network_metro_2trains.yaml", {"buffer_m": None}, "buffer_m: the following strategy needs it"),
    ("heavyhaul_fence.yaml", {"brake_penalty": [40, -1]}, "brake_penalty[1]: Input should be greater than or equal to 0"),
    ("heavyhaul_fence.yaml", {"fence": [10, 0]}, "fence[1]: Input should be greater than or equal to 1"),
    ("network_metro_2trains.yaml", {"strategies": ["independent", "joint", "independent"]},
     "strategies: names must be unique ('independent' given twice)"),
    ("metro_monte_carlo.yaml", {"controllers": [{"name": "s", "kind": "sbpc", "delay_samples": 3}]},
     "controllers[0]: delay_samples: the driver's reaction delay acts on the DAS levels only"),
])
def test_a_check_across_fields_names_its_field(tmp_path, shipped, changes, fragment):
    command = {"metro": "simulate", "netwo": "network", "heavy": "heavyhaul"}[shipped[:5]]
    line = refused(run(command, hostile(tmp_path, shipped, **changes), "--workers", 1, "--no-plot"), fragment)
    assert "(top level)" not in line
    nothing_written(tmp_path)


# ----------------------------------------------------------------------------------- values out of range
@pytest.mark.parametrize("shipped, changes, fragment", [
    ("network_metro_2trains.yaml", {"dwell_s": 1e9}, "dwell_s: Input should be less than or equal to 86400"),
    ("network_metro_2trains.yaml", {"supplement_percent": None, "running_times_s": [-80, 90, 90]},
     "running_times_s[0]: Input should be greater than 0"),
    ("network_metro_2trains.yaml", {"train": ""}, "train: an empty name"),
    ("heavyhaul_brake_penalty_rolling.yaml", {"consist": " "}, "consist: an empty name"),
    ("heavyhaul_fence.yaml", {"brake_penalty": [1e300]}, "brake_penalty[0]: Input should be less than or equal to 10000"),
    ("heavyhaul_fence.yaml", {"weights": {"speed": 1e300}}, "weights.speed: Input should be less than or equal to 10000"),
    ("network_metro_2trains.yaml", {"substation": {"position_m": 1e9}}, "substation.position_m: 1e+09 m is off the line"),
    ("metro_monte_carlo.yaml", {"deviations": {"mass": {"low": 0.9, "high": 1e6}}},
     "deviations.mass.high: Input should be less than or equal to 10"),
    ("metro_monte_carlo.yaml", {"controllers": [{"name": "s", "kind": "sbpc", "block": 10**9, "sample_time_s": 0.38}]},
     "controllers[0].block: 1000000000 samples a move is more than the run's 200"),
])
def test_values_no_run_can_use_are_refused_before_computing(tmp_path, shipped, changes, fragment):
    command = {"metro": "simulate", "netwo": "network", "heavy": "heavyhaul"}[shipped[:5]]
    refused(run(command, hostile(tmp_path, shipped, **changes), "--workers", 1, "--no-plot"), fragment)
    nothing_written(tmp_path)
