"""What check_folder and export_folder return says whether it can be trusted as every API result
does (``status``, ``reason``; a bare ``Note(ok=False)`` said neither); the export CSV alone carries
the run's status; a value that is no path is refused naming its argument (``api.load(None)`` raised
TypeError); ``api.load`` refuses a profile ``check`` refuses (text in a number column read as
ok); a solve folder loaded carries its inputs.json and reads the track and train it was solved with
(``api.load`` read no train file), refusing one changed since. A real K = 10 solve, flagged on purpose."""
import shutil

import pandas as pd
import pytest

from ecostudy import api

from .conftest import TRACKS, TRAINS

TRACK, TRAIN = TRACKS / "amsterdam_rokin_centraal.yaml", TRAINS / "amsterdam_metro.yaml"


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    """A K = 10 run: solved, but its re-simulation disagrees (flagged)."""
    out = tmp_path_factory.mktemp("coarse") / "run"
    api.solve_folder(track=TRACK, train=TRAIN, time=80.0, points=10, out=out, plot=False)
    return out


@pytest.mark.flagged_on_purpose
def test_check_and_export_say_their_status_and_why(coarse):
    checked = api.check_folder(coarse)
    assert checked.status.kind == "flagged" and not checked.ok
    assert checked.reason == checked.data["status"].split(": ", 1)[1] and checked.reason
    assert repr(checked).startswith(f"Note({checked.status})\n")
    exported = api.export_folder(coarse, "1s")  # the run's status, judged again from its files
    assert exported.status.kind == "flagged" and exported.reason.startswith("re-simulation outside tolerance")
    assert exported.text.endswith(f"the run exported: {exported.status}")
    table = pd.read_csv(coarse / "profile_every_1s.csv")  # the CSV alone says it: a status column, read as it is
    assert list(table["status"].unique()) == [str(exported.status)]
    assert list(table.columns[:-1]) == list(exported.data.columns)


@pytest.mark.flagged_on_purpose
def test_load_refuses_a_profile_check_refuses(coarse, tmp_path):
    edited = tmp_path / "edited"
    shutil.copytree(coarse, edited)
    lines = (edited / "profile.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[4].split(",")
    cells[header.index("speed_kmh")] = "abc"
    lines[4] = ",".join(cells)
    (edited / "profile.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(api.InputError, match=r"profile\.csv: speed_kmh, row 5: 'abc' is not a finite number$"):
        api.load(edited)
    with pytest.raises(api.InputError, match=r"profile\.csv: speed_kmh, row 5: 'abc' is not a finite number$"):
        api.check_folder(edited)


@pytest.mark.parametrize("call, line", [
    (lambda: api.load(None), "arguments: folder: a path (str or pathlib.Path), not NoneType None"),
    (lambda: api.check_folder(5), "arguments: result_dir: a path (str or pathlib.Path), not int 5"),
    (lambda: api.export_folder(None), "arguments: result_dir: a path (str or pathlib.Path), not NoneType None"),
    (lambda: api.solve_folder(track=TRACK, train=TRAIN, time=80.0, out=5), "arguments: out: a path (str or "
                                                                            "pathlib.Path), not int 5"),
    (lambda: api.run_folder(None), "arguments: study: a path to a study file, not NoneType None"),
    (lambda: api.calibrate_folder([TRACK, 3]), "arguments: logs: a path (str or pathlib.Path), not list "),
    (lambda: api.load_track(5), "arguments: path: a path to a track file, not int 5"),
    (lambda: api.pareto(api.load_track(TRACK), api.load_train(TRAIN), count=3, workers=None),
     "arguments: workers: must be a number, not None"),
])
def test_a_value_of_the_wrong_type_is_refused_naming_the_argument(call, line):
    with pytest.raises(api.InputError) as refused:
        call()
    assert str(refused.value).startswith(line), str(refused.value)


@pytest.mark.flagged_on_purpose
def test_a_loaded_solve_folder_gives_the_files_it_was_solved_with(tmp_path):
    train_file = tmp_path / "metro.yaml"
    shutil.copy(TRAIN, train_file)
    out = tmp_path / "run"
    api.solve_folder(track=TRACK, train=train_file, time=80.0, points=10, out=out, plot=False)
    folder = api.load(out)
    assert folder.inputs["train"] == str(train_file) and folder.inputs["points"] == 10
    assert folder.inputs["timing"]["running_time_s"] == 80.0
    train, track = folder.train(), folder.track()
    assert train.mass == api.load_train(TRAIN).mass and track.stops == api.load_track(TRACK).stops
    train_file.write_text(train_file.read_text() + "\n# edited\n")
    with pytest.raises(api.InputError, match=r"metro\.yaml: the train file changed since this result was solved"):
        folder.train()
    assert folder.track().stops == track.stops  # the track did not change
    assert api.load(out).inputs == folder.inputs  # the folder is still read: only the changed file is refused
