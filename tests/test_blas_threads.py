"""``ocp.solver.configure`` leaves every OpenBLAS of the process (numpy's and scipy's) at one thread:
the condensed SBPC program's SLSQP iterations spent most of their CPU time in threads waiting for
one another (docs/closed_loop.md)."""
import ctypes

import pytest
import scipy.optimize  # noqa: F401  (scipy's own OpenBLAS loaded)

from ecostudy.ocp import solver


def test_every_openblas_runs_one_thread():
    solver.configure()
    if not solver._state.get("blas_threads"):
        pytest.skip("OPENBLAS_NUM_THREADS was set before ecostudy configured the process: the user's setting holds")
    paths = solver._loaded("openblas")
    assert paths, "numpy and scipy each load an OpenBLAS"
    solver.single_blas_thread()
    for path in paths:
        library = ctypes.CDLL(path)
        getter = next(getattr(library, n) for n in ("openblas_get_num_threads", "scipy_openblas_get_num_threads",
                                                     "scipy_openblas_get_num_threads64_", "openblas_get_num_threads64_")
                      if hasattr(library, n))
        assert getter() == 1, path
