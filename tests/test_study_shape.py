"""Commands on the one study shape (``studies.batch.run_expanded``): each case stored in
``results.sqlite`` as it finishes, a rerun computes only what is not stored, the same table serially,
in worker processes and after a kill -9; ``summary.json`` read back by ``api.load``."""
import json
import sqlite3
from contextlib import closing

import numpy as np
import pandas as pd
import pytest

from ecostudy import api
from ecostudy.studies import compare, network

from .conftest import TRACKS, TRAINS, assert_folder, killed_part_way, load_yaml, write_yaml

METRO = {"track": TRACKS / "amsterdam_rokin_centraal.yaml", "train": TRAINS / "amsterdam_metro.yaml"}
COMPARE_NUMBERS = ["running_time_s", "arrival_error_s", "traction_energy_kWh", "net_energy_kWh",
                   "saving_vs_all_out_pct", "gap_to_optimum_pct", "stop_error_m"]


def compare_at(out, points=100, workers=1):
    return api.compare_folder(**METRO, time=80.0, points=points, out=out, plot=False, workers=workers)


def stored(db):
    with closing(sqlite3.connect(db)) as conn:
        return conn.execute("SELECT count(*) FROM cases").fetchone()[0]


def forget(db, strategies):
    """Take strategies out of the store, as a command killed before they finished leaves it."""
    with closing(sqlite3.connect(db)) as conn, conn:
        conn.executemany("DELETE FROM cases WHERE scenario = ?", [(s,) for s in strategies])


def same_table(a, b, numbers):
    return (a.drop(columns=numbers).equals(b.drop(columns=numbers))
            and np.allclose(a[numbers].to_numpy(float), b[numbers].to_numpy(float), rtol=1e-9, atol=1e-12,
                            equal_nan=True))  # a column left empty (a strategy short of its stop) alike


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    out = tmp_path_factory.mktemp("compare")
    return compare_at(out), out


def test_a_comparison_stores_each_strategy_and_a_rerun_computes_none(compared):
    report, out = compared
    assert "6 strategies: 0 already stored, 6 computed now" in report.text
    assert stored(out / "results.sqlite") == 6
    folder = assert_folder(out, "compare", ["compare"], rows=6, status=report.status.kind)
    assert folder.summary["target_running_time_s"] == pytest.approx(80.0, abs=1e-6)
    again = compare_at(out)
    assert "6 strategies: 6 already stored, 0 computed now" in again.text
    assert again.table.equals(report.table)


def test_an_interrupted_comparison_computes_only_the_rest(compared, tmp_path):
    report, out = compared
    (tmp_path / "results.sqlite").write_bytes((out / "results.sqlite").read_bytes())
    forget(tmp_path / "results.sqlite", ["MARECO-style", "DAS round (nearest level)", "DAS phases"])
    compare._ATO.clear()  # as in a new process: the ATO optimum solved again, to the same optimum
    resumed = compare_at(tmp_path)
    assert "6 strategies: 3 already stored, 3 computed now" in resumed.text
    assert same_table(resumed.table, report.table, COMPARE_NUMBERS)


@pytest.mark.slow
def test_a_killed_comparison_resumes_and_workers_agree(compared, tmp_path):
    """kill -9 part-way through `ecostudy compare`: a rerun computes only the strategies not stored,
    and gives the table of a serial run; so do two worker processes."""
    report, _ = compared
    done = killed_part_way(["compare", "--track", METRO["track"], "--train", METRO["train"], "--time", 80, "--points",
                            100, "--no-plot", "--workers", 1, "--out", tmp_path / "k"], tmp_path / "k" / "results.sqlite",
                           timeout=300)
    assert 2 <= done < 6, "the comparison should have been killed part-way"
    compare._ATO.clear()  # as in a new process
    resumed = compare_at(tmp_path / "k")
    before = int(resumed.summary["stored_before"])
    assert before >= 2 and resumed.summary["computed_now"] == 6 - before
    assert same_table(resumed.table, report.table, COMPARE_NUMBERS)
    compare._ATO.clear()  # each worker solves the ATO optimum itself
    assert same_table(compare_at(tmp_path / "w", workers=2).table, report.table, COMPARE_NUMBERS)


NETWORK_NUMBERS = ["substation_kWh", "saving_vs_independent_pct", "traction_input_kWh", "regen_used_kWh",
                   "regen_lost_kWh", "line_losses_kWh", "unserved_kWh", "balance_error_pct", "separation_min_m"]


def network_table(report):
    return report.table.drop(columns=["wall_s"])  # measured, not computed


def network_study(folder, strategies):
    """The tiny two-train study of tests/test_network.py, trains kept 50 m apart when following."""
    from .test_network import tiny_network_study
    path = tiny_network_study(folder, strategies)
    return write_yaml(path, {**load_yaml(path), "buffer_m": 50.0})


@pytest.fixture(scope="module")
def networked(tmp_path_factory):
    folder = tmp_path_factory.mktemp("network")
    study = network_study(folder, ["independent", "following"])
    return api.network_folder(study, plot=False, workers=1, note=lambda line: None), study, folder / "out"


def test_a_network_study_stores_each_strategy_and_resumes(networked, tmp_path):
    report, study, out = networked
    assert "2 strategies: 0 already stored, 2 computed now" in report.text and stored(out / "results.sqlite") == 2
    assert_folder(out, "network", ["substation", "trains"], rows=2, status=report.status.kind)
    again = api.network_folder(study, plot=False, workers=1, note=lambda line: None)
    assert "2 strategies: 2 already stored, 0 computed now" in again.text
    assert again.table.equals(report.table)
    (tmp_path / "results.sqlite").write_bytes((out / "results.sqlite").read_bytes())
    forget(tmp_path / "results.sqlite", ["following"])  # as a network study killed before it finished leaves it
    network._INDEPENDENT.clear()  # as in a new process: the independent runs solved again, to the same runs
    resumed = api.network_folder(study, out=tmp_path, plot=False, workers=1, note=lambda line: None)
    assert "2 strategies: 1 already stored, 1 computed now" in resumed.text
    assert same_table(network_table(resumed), network_table(report), NETWORK_NUMBERS)


@pytest.mark.slow
def test_a_network_summary_names_the_strategy_of_least_substation_energy(networked):
    """summary.json (and the report's results) say which verified strategy drew least from the
    substation, how much, and its saving against independent driving, as the table has them."""
    _, _, out = networked
    summary = json.loads((out / "summary.json").read_text())
    table = pd.read_csv(out / "network_substation.csv")
    ok = table[table["status"] == "ok"].set_index("strategy")  # a flagged strategy is no headline
    named = ok.loc[summary["least_substation_strategy"]]  # the least, or tied with it to the table's digits
    assert named["substation_kWh"] == pytest.approx(ok["substation_kWh"].min(), rel=1e-5)
    assert summary["least_substation_kWh"] == pytest.approx(named["substation_kWh"], rel=1e-5)
    assert summary["least_saving_vs_independent_pct"] == pytest.approx(named["saving_vs_independent_pct"], abs=1e-3)
    base = table.loc[table["strategy"] == "independent", "substation_kWh"].iloc[0]
    assert summary["independent_substation_kWh"] == pytest.approx(base, rel=1e-5)


def test_a_flagged_strategy_is_never_the_network_headline(tmp_path):
    """Two trains 45 s apart with 500 m of buffer: independent driving verifies but comes within
    195 m (flagged), following cannot depart (failed). No strategy is ok, so summary.json names
    none as the one of least substation energy (a run that breaks the buffer is no saving)."""
    from .test_network import tiny_network_study
    path = tiny_network_study(tmp_path, ["independent", "following"])
    write_yaml(path, {**load_yaml(path), "buffer_m": 500.0})
    report = api.network_folder(path, plot=False, workers=1, note=lambda line: None)
    table = report.table.set_index("strategy")
    assert table.loc["independent", "all_verified"] and table.loc["independent", "status"].startswith("flagged")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert not {k for k in summary if k.startswith("least_")}, summary


def test_a_network_study_whose_every_strategy_failed_writes_its_tables_and_no_figure(tmp_path):
    """Following cannot keep 500 m behind a train 45 s ahead: the study's only strategy fails, and
    the folder says so (tables, summary.json, exit status 1) with no figure of no run, rather than
    the figure's drawing raising."""
    from .test_network import tiny_network_study
    path = tiny_network_study(tmp_path, ["following"])
    write_yaml(path, {**load_yaml(path), "buffer_m": 500.0})
    report = api.network_folder(path, workers=1, note=lambda line: None)
    assert report.status.kind == "failed" and "cannot keep buffer_m 500 m" in report.status.reason
    files = api.load(tmp_path / "out").files
    assert "network_trains.csv" in files and not any(name.endswith(".png") for name in files), files


@pytest.mark.slow
def test_a_killed_network_study_resumes_and_workers_agree(networked, tmp_path):
    report, _, _ = networked
    study = network_study(tmp_path, ["independent", "following", "triggering"])
    done = killed_part_way(["network", study, "--no-plot", "--workers", 1], tmp_path / "out" / "results.sqlite",
                           at_least=1, timeout=300)
    assert 1 <= done < 3, "the network study should have been killed part-way"
    network._INDEPENDENT.clear()  # as in a new process
    resumed = api.network_folder(study, plot=False, workers=1, note=lambda line: None)
    assert resumed.summary["computed_now"] == 3 - int(resumed.summary["stored_before"])
    first_two = resumed.table.iloc[:2].drop(columns=["wall_s"]).reset_index(drop=True)
    assert same_table(first_two, network_table(report), NETWORK_NUMBERS)
    network._INDEPENDENT.clear()  # each worker solves the independent runs itself
    pooled = api.network_folder(study, out=tmp_path / "w", plot=False, workers=2, note=lambda line: None)
    assert same_table(network_table(pooled), resumed.table.drop(columns=["wall_s"]), NETWORK_NUMBERS)
