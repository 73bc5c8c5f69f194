"""The closed-loop and heavy-haul studies as registered study kinds: ``ecostudy run FILE --kind
simulate|heavyhaul`` and ``ecostudy simulate|heavyhaul FILE`` run the same cases into the same
store, so either one resumes the other."""
import pytest

from ecostudy import api

from .conftest import assert_folder
from .test_heavyhaul_study import study as heavyhaul_study
from .test_simulate import study as loop_study


def test_run_kind_simulate_and_the_simulate_command_share_one_store(tmp_path):
    path, out = loop_study(tmp_path), tmp_path / "out"
    first = api.run_folder(path, workers=1, out=out, kind="simulate")
    assert "4 cases: 0 already stored, 4 computed now" in first.text
    folder = assert_folder(out, "simulate", ["runs", "aggregate"], rows=4, status="flagged")  # the replayed plan overruns
    again = api.simulate_folder(path, workers=1, out=out, plot=False)
    assert "4 already stored, 0 computed now" in again.text
    assert list(api.load(out).tables) == ["runs", "aggregate"] and api.load(out).summary["missing_runs"] == 0
    assert again.table.drop(columns=["wall_s"]).equals(folder.table.drop(columns=["wall_s"]))


@pytest.mark.slow  # a 5 km heavy-haul run (~20 s)
def test_run_kind_heavyhaul_and_the_heavyhaul_command_share_one_store(tmp_path):
    path, out = heavyhaul_study(tmp_path, brake_penalty=[60]), tmp_path / "out"
    first = api.run_folder(path, workers=1, out=out, kind="heavyhaul")
    assert "1 case: 0 already stored, 1 computed now" in first.text
    folder = assert_folder(out, "heavyhaul", ["runs"], rows=1, status="flagged")  # adhesion: the paper's plant
    again = api.heavyhaul_folder(path, workers=1, out=out, plot=False)
    assert "1 already stored, 0 computed now" in again.text
    assert again.table.drop(columns=["wall_s"]).equals(folder.table.drop(columns=["wall_s"]))
