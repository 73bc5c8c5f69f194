"""The Dask route of `ecostudy run`, against the serial table.

This file runs last on purpose: a Dask LocalCluster leaves threads in the test process, and the
other tests fork worker processes, which must not inherit threads that may hold locks.
"""
import pytest

from ecostudy.studies.batch import run_study

from .test_batch import reference, same_results, study_file  # noqa: F401,F811  (reference is a fixture)


@pytest.mark.slow
def test_dask_local_cluster_gives_identical_table(reference, tmp_path):
    distributed = pytest.importorskip("distributed", reason="Dask is in the test extra; installed by make test")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        table, counts, _ = run_study(study_file(tmp_path, tmp_path / "out"), dask=cluster.scheduler_address)
    assert counts["computed"] == 6
    assert same_results(table, reference[0])
