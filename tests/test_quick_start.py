"""The command line's start with the collector paused (``core.startup``): on again, with what the
command loaded frozen, once ``ecostudy.api`` has loaded the command's module; a process that did
not pause it (the Python API, a notebook) keeps its collector as it was."""
import json
import subprocess
import sys

from .conftest import ROOT

PROBE = """
import gc, json
from ecostudy.core import startup
{pause}
from ecostudy import api
during = gc.isenabled()
api.solve_folder({study!r}, points=120, out="s", plot=False)
print(json.dumps({{"during_import": during, "after": gc.isenabled(), "frozen": gc.get_freeze_count()}}))
"""


def state(tmp_path, pause):
    code = PROBE.format(pause="startup.pause()" if pause else "", study=str(ROOT / "studies" / "default.yaml"))
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_collector_paused_at_the_start_is_on_again_with_the_imports_frozen(tmp_path):
    seen = state(tmp_path, pause=True)
    assert seen["during_import"] is False and seen["after"] is True
    assert seen["frozen"] > 50_000  # Pyomo, SciPy, pandas and the schemas: never scanned again
    assert json.loads((tmp_path / "s" / "summary.json").read_text())["status"] == "ok"


def test_a_process_that_did_not_pause_it_keeps_its_collector_as_it_was(tmp_path):
    seen = state(tmp_path, pause=False)
    assert seen == {"during_import": True, "after": True, "frozen": 0}
