"""One rule for output folders: a relative folder, from ``--out`` or from a study file's ``output``,
is relative to the working directory in every command (never to the study file's folder), and the
folder is printed at the end."""
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.io.loaders import load_network_study
from ecostudy.studies import cases, closedloop, heavyhaul
from ecostudy.studies.cases import load_checked_study

from .conftest import ROOT, STUDIES

# each kind of study file and what reads its output folder (the commands that use it)
READERS = {
    "default.yaml": lambda p: load_checked_study(p).output,  # solve, pareto, compare
    "metro_supplements.yaml": lambda p: cases.expand(p)[1],  # run
    "network_metro_2trains.yaml": lambda p: load_network_study(p).output,  # network
    "yazhemsky2017_closed_loop.yaml": lambda p: closedloop.expand(p)[1],  # simulate
    "heavyhaul_fence.yaml": lambda p: heavyhaul.expand(p)[1],  # heavyhaul
}


@pytest.fixture
def layout(tmp_path, monkeypatch):
    """The shipped studies copied to ``tmp/studies`` (their ``../tracks`` and ``../trains`` linked)
    and a working directory ``tmp/work`` elsewhere."""
    for folder in ("tracks", "trains"):
        (tmp_path / folder).symlink_to(ROOT / folder)
    (tmp_path / "studies").mkdir()
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    return tmp_path


def copied(layout, name, output):
    doc = yaml.safe_load((STUDIES / name).read_text())
    doc["output"] = output
    path = layout / "studies" / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n.startswith("heavyhaul") else n
                                  for n in sorted(READERS)])  # heavy haul: its reference run is solved (40 s)
def test_a_study_files_relative_output_is_relative_to_the_working_directory(layout, name):
    folder = READERS[name](copied(layout, name, "results/here"))
    assert Path(folder).resolve() == layout / "work" / "results" / "here"


def test_solve_writes_where_the_study_says_from_the_working_directory_and_prints_it(layout):
    study = copied(layout, "default.yaml", "results/solved")
    r = CliRunner().invoke(app, ["solve", str(study), "--points", "100", "--no-plot"])
    assert r.exit_code == 0, r.output
    folder = layout / "work" / "results" / "solved"
    assert (folder / "summary.json").is_file() and not (layout / "studies" / "results").exists()
    assert r.output.rstrip().splitlines()[-1] == f"solve: ok, written to {folder}"  # the folder, last


def test_pareto_and_compare_put_their_folder_beside_the_studys_in_the_working_directory(layout):
    from ecostudy.api.fronts import beside
    st = load_checked_study(copied(layout, "default.yaml", "results/d"))
    for suffix in ("_pareto", "_compare"):
        assert beside(st, suffix, "x").resolve() == layout / "work" / "results" / f"d{suffix}"


@pytest.mark.parametrize("command, default", [
    ("solve", "default: the study's 'output', else out/TRACK_FROM_TO)"),
    ("pareto", "default: the study's 'output' with '_pareto' added, else out/pareto)"),
    ("compare", "default: the study's 'output' with '_compare' added, else out/compare)"),
    ("journey", "default: out/journey)"),
    ("run", "default: the study's 'output', '_pareto' or '_compare' added for those kinds)"),
    ("network", "default: the study's 'output', else out/NAME"),
    ("simulate", "default: the study's 'output', else out/NAME"),
    ("heavyhaul", "default: the study's 'output', else out/NAME"),
])
def test_each_commands_out_help_says_its_own_default(command, default):
    text = " ".join(CliRunner().invoke(app, [command, "--help"]).output.split())
    assert f"--out <path> Output folder (relative: to the working directory; {default}" in text, text


def test_solve_without_a_study_writes_to_out_track_from_to(layout):
    r = CliRunner().invoke(app, ["solve", "--track", str(ROOT / "tracks" / "amsterdam_rokin_centraal.yaml"), "--train",
                                 str(ROOT / "trains" / "amsterdam_metro.yaml"), "--time", "80", "--points", "100",
                                 "--no-plot"])
    assert r.exit_code == 0, r.output
    assert (layout / "work" / "out" / "amsterdam_rokin_centraal_Rokin_Centraal" / "summary.json").is_file()


def test_a_path_with_a_name_too_long_is_one_line_naming_it(tmp_path):
    """A name of 300 characters (the file system allows 255 bytes) was 'internal error: OSError:
    [Errno 36] File name too long', exit 3, from solve's --out, from export and check of that
    folder and from an input file: now one line, exit 2, the path shortened."""
    long = tmp_path / ("x" * 300)
    solve = ["solve", "--track", str(ROOT / "tracks/amsterdam_rokin_centraal.yaml"), "--train",
             str(ROOT / "trains/amsterdam_metro.yaml"), "--time", "80", "--points", "50", "--no-plot"]
    for args, said in ((solve + ["--out", str(long)], "xxx: --out: File name too long: its longest name is 300 bytes"),
                       (["export", str(long)], "xxx: File name too long: its longest name is 300 bytes"),
                       (["check", str(long)], "xxx: File name too long: its longest name is 300 bytes"),
                       (["solve", f"{long}.yaml"], "xxx.yaml: File name too long: its longest name is 305 bytes")):
        r = CliRunner().invoke(app, args)
        assert r.exit_code == 2 and r.output.count("\n") == 1 and said in r.output, (args[0], r.output)
        assert "..." in r.output and len(r.output) < 300, r.output  # the path shortened
    assert not list(tmp_path.iterdir())  # nothing written
