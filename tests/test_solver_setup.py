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
