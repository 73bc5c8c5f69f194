"""A command of the tool in one process, every NLP solve's Ipopt iterations and CPU counted.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_iterations.py network studies/network_metro_3trains.yaml \
        --no-plot --workers 1 --out DIR

prints on standard error, when the command ends: the solves (``ocp.session.Session.solve``), their
Ipopt iterations, their CPU seconds and the process's. With ``--workers 1`` a network study solves
every leg in this process (the same runs as with any number of workers): iterations and energies
are exact, seconds depend on the machine.
"""
import atexit
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from ecostudy.ocp import session  # noqa: E402

COUNT = {"solves": 0, "iterations": 0, "cpu": 0.0}
PLAIN = session.Session.solve


def counted(self, *args, **kwargs):
    """``Session.solve``, counted."""
    t0 = time.process_time()
    out = PLAIN(self, *args, **kwargs)
    COUNT["cpu"] += time.process_time() - t0
    COUNT["solves"] += 1
    COUNT["iterations"] += int(out.iterations or 0)
    return out


def report():
    print(f"solves {COUNT['solves']}, Ipopt iterations {COUNT['iterations']}, solve CPU {COUNT['cpu']:.1f} s, "
          f"process CPU {time.process_time():.1f} s", file=sys.stderr)


if __name__ == "__main__":
    session.Session.solve = counted
    atexit.register(report)
    from ecostudy.cli import app
    sys.argv = ["ecostudy", *sys.argv[1:]]
    app()
