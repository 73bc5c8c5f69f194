"""Setup is explicit: importing ecostudy changes nothing; the entry points configure the process."""
import os
import subprocess
import sys

CHECK = """
import os, sys
from pyomo.repn.plugins.nl_writer import NLWriter
default = NLWriter.CONFIG.export_defined_variables
import ecostudy, ecostudy.core.physics, ecostudy.ocp.session, ecostudy.analysis.single
assert "SCOTCH_PTHREAD_NUMBER" not in os.environ, "patched at import"
assert NLWriter.CONFIG.export_defined_variables == default, "patched at import"
from ecostudy.ocp import session, solver
solver.configure()
assert os.environ["SCOTCH_PTHREAD_NUMBER"] == "1"
session._imports()
assert NLWriter.CONFIG.export_defined_variables is False
print("ok")
"""


def test_import_patches_nothing_and_configure_sets_up():
    env = {k: v for k, v in os.environ.items() if k != "SCOTCH_PTHREAD_NUMBER"}
    r = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.strip() == "ok"


PROBES = """
import ctypes.util
asked = []
find = ctypes.util.find_library
ctypes.util.find_library = lambda name: asked.append(name) or find(name)
import pyomo.environ as pyo
from ecostudy.ocp import session, solver
solver.configure()
m = pyo.ConcreteModel()
m.x = pyo.Var(bounds=(0, 2), initialize=1.0)
m.c = pyo.Constraint(expr=m.x ** 2 >= 1.0)
m.o = pyo.Objective(expr=m.x)
outcome = session.solve(m)
assert outcome.optimal and abs(pyo.value(m.x) - 1.0) < 1e-6, outcome
print(sorted(set(asked)))
"""


def test_writing_an_nl_file_probes_no_windows_runtime():
    """Pyomo's CtypesEnviron, entered at every NL file load, looks for Windows' C runtimes with
    find_library (gcc and ld for each name) once per process unless ``solver.prepare`` has said
    they are absent: a real solve in a fresh process asks for none of them."""
    r = subprocess.run([sys.executable, "-c", PROBES], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    asked = eval(r.stdout.strip().splitlines()[-1])
    assert not [name for name in asked if name and ("msvcr" in name or "kernel32" in name or "api-ms-win" in name)], asked
