"""Worker processes that never outlive the command that started them."""
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

from ecostudy.core.deadline import die_with_parent


def worker_pool(workers):
    """A forked process pool (workers inherit the loaded modules) whose workers die with the parent."""
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=die_with_parent)
