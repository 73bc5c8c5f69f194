"""``ocp.solver.configure`` leaves every OpenBLAS of the process (numpy's and scipy's) at one thread:
the condensed SBPC program's SLSQP iterations spent most of their CPU time in threads waiting for
one another (docs/closed_loop.md). A user's own OPENBLAS_NUM_THREADS is kept. Each case runs in a
fresh process, whose environment the test sets (a test process may have set the variable already)."""
import json
import os
import subprocess
import sys

CHECK = r"""
import ctypes, json
import scipy.optimize  # scipy's own OpenBLAS loaded before ecostudy configures the process
from ecostudy.ocp import solver
solver.configure()
counts = {}
for path in solver._loaded("openblas"):
    library = ctypes.CDLL(path)
    getter = next(getattr(library, n) for n in ("openblas_get_num_threads", "scipy_openblas_get_num_threads",
                                                 "scipy_openblas_get_num_threads64_", "openblas_get_num_threads64_")
                  if hasattr(library, n))
    counts[path] = getter()
print(json.dumps(counts))
"""


def thread_counts(**env):
    environ = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    done = subprocess.run([sys.executable, "-c", CHECK], env={**environ, **env}, capture_output=True, text=True,
                          timeout=300, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_every_openblas_runs_one_thread():
    counts = thread_counts()
    assert len(counts) >= 2, counts  # numpy's and scipy's wheels each bring one
    assert set(counts.values()) == {1}, counts


def test_a_users_own_thread_count_is_kept():
    counts = thread_counts(OPENBLAS_NUM_THREADS="2")
    assert counts and set(counts.values()) == {2}, counts
