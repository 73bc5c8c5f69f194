"""The Dask route of `ecostudy run`, against the serial table.

This file runs last on purpose: a Dask LocalCluster leaves threads in the test process, and the
other tests fork worker processes, which must not inherit threads that may hold locks.
"""
import pytest

from ecostudy.studies.batch import run_study

from .test_batch import reference, same_results, study_file  # noqa: F401,F811  (reference is a fixture)
from .test_study_shape import (COMPARE_NUMBERS, METRO, NETWORK_NUMBERS, compared, networked,  # noqa: F401,F811
                               same_table)  # (compared, networked: fixtures)


@pytest.mark.slow
def test_dask_local_cluster_gives_identical_table(reference, tmp_path):
    distributed = pytest.importorskip("distributed", reason="Dask is in the test extra; installed by make test")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        table, counts, _ = run_study(study_file(tmp_path, tmp_path / "out"), dask=cluster.scheduler_address)
    assert counts["computed"] == 6
    assert same_results(table, reference[0])


@pytest.mark.slow
def test_compare_and_network_on_a_dask_cluster_give_the_serial_tables(compared, networked, tmp_path):
    """Each strategy of `ecostudy compare` and `ecostudy network --dask` a Dask task: the tables of a
    serial run (tests/test_study_shape.py)."""
    distributed = pytest.importorskip("distributed", reason="Dask is in the test extra; installed by make test")
    from ecostudy import api
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        cmp = api.compare_folder(**METRO, time=80.0, points=100, out=tmp_path / "c", plot=False,
                                 dask=cluster.scheduler_address)
        net = api.network_folder(networked[1], out=tmp_path / "n", plot=False, dask=cluster.scheduler_address,
                                 note=lambda line: None)
    assert "6 computed now" in cmp.text and same_table(cmp.table, compared[0].table, COMPARE_NUMBERS)
    assert "2 computed now" in net.text
    assert same_table(net.table.drop(columns=["wall_s"]), networked[0].table.drop(columns=["wall_s"]), NETWORK_NUMBERS)
