"""The Pareto front on the one study shape (``studies.front``, the ``pareto`` kind): each point a
case stored in ``results.sqlite`` as it finishes, a rerun computes none, a store with points
missing computes only those, two workers and a kill -9 give the same front; every point solved
cold stays within 0.1 % of the warm-started chain of ``studies.pareto.sweep``."""
import pytest

from ecostudy import api
from ecostudy.io.loaders import load_track, load_train
from ecostudy.studies import batch
from ecostudy.studies.pareto import sweep

from .conftest import assert_folder, killed_part_way
from .test_study_shape import METRO, forget, same_table, stored

NUMBERS = ["running_time_s", "supplement_pct", "traction_energy_kWh", "net_energy_kWh", "saving_vs_all_out_pct",
           "marginal_saving_kWh_per_s", "top_speed_kmh", "coasting_share_pct"]
POINTS = ["all-out", "+5 %", "+10 %", "+40 %"]


def front_at(out, workers=1, **options):
    return api.pareto_folder(**METRO, count=4, points=100, out=out, plot=False, workers=workers, **options)


def as_new_process():
    """Forget what this process kept (the all-out time, the written models), as a fresh worker has."""
    batch._ALL_OUT.clear()
    batch._WRITTEN.models.clear()


@pytest.fixture(scope="module")
def fronted(tmp_path_factory):
    out = tmp_path_factory.mktemp("pareto")
    as_new_process()
    return front_at(out), out


def test_a_front_stores_each_point_and_a_rerun_computes_none(fronted):
    report, out = fronted
    assert "4 points: 0 already stored, 4 computed now" in report.text
    assert stored(out / "results.sqlite") == 4
    folder = assert_folder(out, "pareto", ["pareto"], rows=4, status=report.status.kind)
    assert folder.summary["monotone"] and folder.summary["all_verified"] and folder.summary["count"] == 4
    assert list(folder.table["supplement_pct"].round(6)) == [0.0, 5.0, 10.0, 40.0]
    assert (out / "pareto.json").is_file()
    again = front_at(out)
    assert "4 points: 4 already stored, 0 computed now" in again.text
    assert again.table.equals(report.table)


def test_an_interrupted_front_computes_only_the_rest(fronted, tmp_path):
    report, out = fronted
    (tmp_path / "results.sqlite").write_bytes((out / "results.sqlite").read_bytes())
    forget(tmp_path / "results.sqlite", ["+10 %", "+40 %"])
    as_new_process()
    resumed = front_at(tmp_path)
    assert "4 points: 2 already stored, 2 computed now" in resumed.text
    assert same_table(resumed.table, report.table, NUMBERS)


def test_cold_points_stay_within_a_tenth_of_a_percent_of_the_warm_chain(fronted):
    report, _ = fronted
    chained, _ = sweep(load_track(METRO["track"]), load_train(METRO["train"]), "Rokin", "Centraal", count=4,
                       supplement_max=0.4, points=100)
    # the report's table is pareto.csv read back: six significant digits
    assert report.table["running_time_s"].to_numpy() == pytest.approx(chained["running_time_s"].to_numpy(), rel=1e-5)
    assert report.table["traction_energy_kWh"].to_numpy() == pytest.approx(
        chained["traction_energy_kWh"].to_numpy(), rel=1e-3)


def test_a_front_with_driver_advice_stores_it_with_each_point(tmp_path):
    report = front_at(tmp_path, das="round")
    table = report.table
    assert table["das_traction_energy_kWh"].notna().all() and report.summary["das"]["solved"] == 4
    assert "DAS round: 4 of 4 points" in report.text


@pytest.mark.slow
def test_a_killed_front_resumes_and_workers_agree(fronted, tmp_path):
    """kill -9 part-way through `ecostudy pareto`: a rerun computes only the points not stored and
    gives the front of an uninterrupted run; so do two worker processes."""
    report, _ = fronted
    done = killed_part_way(["pareto", "--track", METRO["track"], "--train", METRO["train"], "--count", 4, "--points",
                            100, "--no-plot", "--workers", 1, "--out", tmp_path / "k"], tmp_path / "k" / "results.sqlite",
                           timeout=300)
    assert 2 <= done < 4, "the front should have been killed part-way"
    as_new_process()
    resumed = front_at(tmp_path / "k")
    before = int(resumed.summary["stored_before"])
    assert before >= 2 and resumed.summary["computed_now"] == 4 - before
    assert same_table(resumed.table, report.table, NUMBERS)
    assert same_table(front_at(tmp_path / "w", workers=2).table, report.table, NUMBERS)


def test_a_study_file_runs_as_a_front(tmp_path):
    """`ecostudy run STUDY --kind pareto`: the study's base case as a front on the same store, its
    own 80 s one more point."""
    from .conftest import write_yaml
    study = write_yaml(tmp_path / "s.yaml", {"name": "s", "track": str(METRO["track"]), "train": str(METRO["train"]),
                                             "from": "Rokin", "to": "Centraal", "running_time_s": 80, "points": 60,
                                             "output": str(tmp_path / "out")})
    report = api.run_folder(study, workers=1, kind="pareto")
    assert "21 cases: 0 already stored, 21 computed now" in report.text
    folder = assert_folder(tmp_path / "out_pareto", "pareto", ["pareto"], rows=21, status=report.status.kind)
    assert folder.summary["monotone"]
