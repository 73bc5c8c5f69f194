"""BLAS threads for commands that solve many small problems (``ecostudy heavyhaul``): the condensed
QPs' matrix products are a few hundred rows, where OpenBLAS's threads cost more than they give and
fight the other worker for the cores (docs/heavyhaul.md, "BLAS threads").

numpy is imported before a command runs, so the environment variables alone come too late for this
process: the OpenBLAS libraries already loaded (numpy's and scipy's wheels each bundle one) are set
through their ``*_set_num_threads`` entry, as threadpoolctl does. Worker processes are forked and
inherit the setting; the variables cover processes started afresh.
"""
import ctypes
import os
from pathlib import Path

VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
ENTRIES = ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads", "openblas_set_num_threads64_",
           "openblas_set_num_threads")


def loaded_openblas():
    """Paths of the OpenBLAS libraries mapped into this process (Linux: /proc/self/maps)."""
    maps = Path("/proc/self/maps")
    if not maps.exists():
        return []
    paths = {line.split()[-1] for line in maps.read_text().splitlines() if "openblas" in line.lower() and "/" in line}
    return sorted(paths)


def limit_blas_threads(threads=1):
    """Set every loaded OpenBLAS to ``threads`` and the variables for new processes; returns the
    libraries set."""
    for name in VARIABLES:
        os.environ[name] = str(threads)
    done = []
    for path in loaded_openblas():
        library = ctypes.CDLL(path)
        for entry in ENTRIES:
            if hasattr(library, entry):
                getattr(library, entry)(ctypes.c_int(threads))
                done.append(path)
                break
    return done


def blas_threads():
    """Threads of every loaded OpenBLAS (by its ``*_get_num_threads`` entry), by library path."""
    out = {}
    for path in loaded_openblas():
        library = ctypes.CDLL(path)
        for entry in ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads", "openblas_get_num_threads"):
            if hasattr(library, entry):
                out[path] = int(getattr(library, entry)())
                break
    return out
