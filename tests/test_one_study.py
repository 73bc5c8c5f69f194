"""One study per output folder: `run`, `compare` and `pareto` refuse an --out whose store holds
another study's cases (its table and summary.json would be written over that study's), in one
line naming the folder, the study it holds and this one, exit 2, before computing, the folder
unchanged; a study built from --track and --train is named by its files and stops, so another
segment is another study; the same study again resumes."""
import pytest

from ecostudy.io.store import Store

from .conftest import TRACKS, TRAINS
from .test_bad_input_studies import hostile, refused, run

AMS = ["--track", TRACKS / "amsterdam_rokin_centraal.yaml", "--train", TRAINS / "amsterdam_metro.yaml"]
REGIONAL = ["--track", TRACKS / "regional_808m.yaml", "--train", TRAINS / "regional_alstom.yaml"]
OPTIONS = {"run": ["--no-progress"], "compare": ["--supplement", 10, "--points", 30, "--no-plot"],
           "pareto": ["--count", 3, "--points", 30, "--no-plot"]}


def contents(folder):
    """Every file of a folder with its bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def holding_another_study(folder):
    store = Store(folder / "results.sqlite")
    store.put({"key": "k", "study": "someone_else", "scenario": "s", "labels": {}}, {"status": "ok", "summary": {}})
    store.close()
    return contents(folder)


@pytest.mark.parametrize("command", ["run", "compare", "pareto"])
def test_a_study_file_into_a_folder_holding_another_study_is_refused(tmp_path, command):
    other = tmp_path / "other"
    before = holding_another_study(other)
    study = hostile(tmp_path, "default.yaml", points=30)
    refused(run(command, study, *OPTIONS[command], "--workers", 1, "--out", other), str(other),
            "--out: holds the results of another study ('someone_else'), not of 'default'")
    assert contents(other) == before  # no table, no summary.json, no -wal or -shm file of the check


@pytest.mark.parametrize("command", ["compare", "pareto"])
def test_a_study_of_another_segment_built_from_flags_is_refused_and_the_same_one_resumes(tmp_path, command):
    out = tmp_path / "out"
    first = run(command, *AMS, *OPTIONS[command], "--workers", 1, "--out", out)
    assert first.exit_code in (0, 1), first.output
    again = run(command, *AMS, *OPTIONS[command], "--workers", 1, "--out", out)
    assert again.exit_code == first.exit_code, again.output
    assert "already stored, 0 computed now" in again.output
    before = contents(out)
    held = (f"{command} of {(TRAINS / 'amsterdam_metro.yaml').resolve()} on "
            f"{(TRACKS / 'amsterdam_rokin_centraal.yaml').resolve()}, Rokin to Centraal")
    line = refused(run(command, *REGIONAL, *OPTIONS[command], "--workers", 1, "--out", out), str(out),
                   f"--out: holds the results of another study ('{held}'), not of '{command} of "
                   f"{(TRAINS / 'regional_alstom.yaml').resolve()} on {(TRACKS / 'regional_808m.yaml').resolve()}")
    assert "give another --out" in line
    assert contents(out) == before


def test_two_study_files_of_other_names_do_not_share_a_folder(tmp_path):
    """`run` of a study, then of another study file into the same --out: refused; the first again resumes."""
    out = tmp_path / "out"
    first = hostile(tmp_path, "default.yaml", points=30, output=str(out))
    assert run("run", first, "--no-progress", "--workers", 1).exit_code == 0
    (tmp_path / "b").mkdir()
    second = hostile(tmp_path / "b", "default.yaml", name="another", points=30, output=str(out))
    before = contents(out)
    refused(run("run", second, "--no-progress", "--workers", 1), str(out),
            "holds the results of another study ('default'), not of 'another'")
    assert contents(out) == before
    assert "1 already stored, 0 computed now" in run("run", first, "--no-progress", "--workers", 1).output
