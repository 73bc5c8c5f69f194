"""A train file's warnings arise once, where the file is read, and name it: a study's base case is
read once by every command that runs it (solve, pareto, compare, run), a train given with --train
once, and a study's scenario that overrides train fields warns only of what its overrides change.
Real commands on small cases (typer's CliRunner, stderr apart from stdout)."""
import json

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import DATA, TRACKS, TRAINS, write_yaml

ADHESION, AMS = TRAINS / "amsterdam_metro_adhesion.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"
CAPS = ("traction envelope above adhesion (Curtius & Kniffler, 50 t adhesive) below 64 km/h: capped there",
        "regenerative braking above adhesion (Curtius & Kniffler, 50 t adhesive) from 8 to 64 km/h: capped there")
SMALL = {"solve": ["--no-plot"], "pareto": ["--count", "2", "--supplement-max", "10", "--workers", "1", "--no-plot"],
         "compare": ["--workers", "1", "--no-plot"], "run": ["--workers", "1", "--no-progress"]}


def warnings_of(args):
    """The warning lines a command writes on stderr (it must write its folder: exit status 0, or 1
    where a heuristic of ``compare`` stops off its mark on the coarse grid)."""
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0 or (result.exit_code == 1 and args[0] == "compare"), result.output
    return [line for line in result.stderr.splitlines() if line.startswith("warning:")]


def study(folder, **more):
    return write_yaml(folder / "s.yaml", {"name": "s", "track": str(AMS), "train": str(ADHESION),
                                          "supplement_percent": 10, "points": 60, **more})


@pytest.mark.parametrize("command", SMALL)
def test_a_study_train_warns_once_naming_its_file(tmp_path, command):
    """The adhesion train caps its traction envelope and its electric brake: two warnings, each once."""
    path = study(tmp_path)
    lines = warnings_of([command, str(path), "--out", str(tmp_path / "o"), *SMALL[command]])
    assert lines == [f"warning: {ADHESION}: adhesion: {cap}" for cap in CAPS]


@pytest.mark.parametrize("command", ["solve", "pareto", "compare"])
def test_a_train_given_on_the_command_line_warns_once(tmp_path, command):
    """A TTOBench train with a field ecostudy does not model, given with --train: one warning."""
    doc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    train = tmp_path / "train.json"
    train.write_text(json.dumps({**doc, "bogie count": {"unit": "-", "value": 2}}))
    timing = [] if command == "pareto" else ["--supplement", "10"]
    lines = warnings_of([command, "--track", str(DATA / "ttobench_track.json"), "--train", str(train), "--points", "60",
                         "--out", str(tmp_path / "o"), *timing, *SMALL[command]])
    assert len(lines) == 1 and lines[0].startswith(f"warning: {train}: bogie count: "), lines


def test_a_scenario_warns_only_of_what_its_train_overrides_change(tmp_path):
    """A scenario without overrides and one whose override leaves the caps as they are warn of
    nothing; one with less adhesive mass warns of its own caps, naming the scenario."""
    path = study(tmp_path, scenarios=[{"name": "same"}, {"name": "heavier", "train_overrides": {"mass_t": 140}},
                                      {"name": "less grip", "train_overrides": {"adhesion": {"adhesive_mass_t": 40}}}])
    lines = warnings_of(["run", str(path), "--out", str(tmp_path / "o"), *SMALL["run"]])
    assert lines[:2] == [f"warning: {ADHESION}: adhesion: {cap}" for cap in CAPS]
    grip = f"warning: {path}: scenarios[2] (less grip): adhesion: "
    assert [line.startswith(grip) and "(Curtius & Kniffler, 40 t adhesive)" in line for line in lines[2:]] == [True] * 2, lines


def test_a_network_study_says_what_its_legs_leave_out_with_every_worker_count(tmp_path):
    """The legs' warning that they use the constant efficiencies, not the train's efficiency map, was
    raised where a leg was built: in a worker process with more than one worker, so the default command
    said nothing (9.903 kWh, the constant-efficiency number, as if the map counted). Said once, where
    the study is read."""
    from .conftest import load_yaml
    train = load_yaml(TRAINS / "amsterdam_metro.yaml")
    train["traction_efficiency_map"] = {"speed_kmh": [0, 40, 80], "force_kN": [0, 100, 200],
                                        "efficiency": [[0.5] * 3] * 3}
    doc = {"name": "net", "track": str(TRACKS / "metro_line_4stops.yaml"),
           "train": str(write_yaml(tmp_path / "train.yaml", train)), "stops": ["Noord", "Station"],
           "supplement_percent": 10, "dwell_s": 20, "time_step_s": 1.0, "points": 100,
           "trains": [{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": 120}],
           "substation": {"position_m": 300}, "strategies": ["independent"], "buffer_m": 100}
    study = write_yaml(tmp_path / "net.yaml", doc)
    said = "the time-domain legs does not model efficiency maps: it uses the constant efficiencies (0.85, 0.8)"
    for workers in ("1", "2"):
        lines = warnings_of(["network", str(study), "--no-plot", "--workers", workers, "--out", str(tmp_path / workers)])
        assert [line for line in lines if said in line] == [f"warning: {said}"], (workers, lines)
