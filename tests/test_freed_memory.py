"""``ocp.solver.configure`` tells glibc's allocator to keep freed memory: a large block freed and
allocated again (as MUMPS's workspace is at every factorization) comes back from the heap instead of
being mapped anew, each of its pages faulted in and zeroed by the kernel. A user's own allocator
settings are kept. Each case runs in a fresh process whose environment the test sets."""
import os
import subprocess
import sys

CHECK = r"""
import ctypes, resource, sys
from ecostudy.ocp import solver
if sys.argv[1] == "configure":
    solver.configure()
libc = ctypes.CDLL("libc.so.6")
libc.malloc.restype = ctypes.c_void_p
libc.free.argtypes = [ctypes.c_void_p]
size = 100 * 2 ** 20  # above glibc's largest automatic mmap threshold (32 MiB); C's malloc, as MUMPS's
block = libc.malloc(size)
ctypes.memset(block, 1, size)
libc.free(block)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
block = libc.malloc(size)
ctypes.memset(block, 1, size)
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def faults(step, **env):
    """Page faults of allocating and filling 100 MiB a second time, in a fresh process."""
    environ = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}
    done = subprocess.run([sys.executable, "-c", CHECK, step], env={**environ, **env}, capture_output=True,
                          text=True, timeout=300, check=True)
    return int(done.stdout.strip().splitlines()[-1])


def test_a_freed_block_is_reused_without_page_faults():
    fresh = 100 * 2 ** 20 // 4096 // 2  # half the block's 4 KiB pages
    assert faults("none") > fresh
    assert faults("configure") < fresh // 10


def test_a_users_own_allocator_setting_is_kept():
    assert faults("configure", MALLOC_MMAP_THRESHOLD_="131072") > 100 * 2 ** 20 // 4096 // 2
