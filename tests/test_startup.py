"""A command loads what it runs and leaves quickly once everything is finished.

``ecostudy.api`` imports each command's module when it is first used, so ``ecostudy solve`` never
loads the closed-loop, heavy-haul or network code, nor matplotlib without plots; the ``ecostudy``
command skips the interpreter's teardown (``report.console.leave``) only after the exit handlers
ran: log files complete, temporary files removed, stores unlocked, exit codes kept.
"""
import json
import os
import subprocess
import sys

import pytest

from .conftest import ROOT, TRACKS, TRAINS

FEATURES = ("ecostudy.control", "ecostudy.heavyhaul", "ecostudy.network", "ecostudy.calibration", "matplotlib",
            "pyomo.environ")  # Pyomo's plugins: a solve registers the NL writer only (ocp.solver.prepare)


def loaded_after(code, tmp_path):
    """The ecostudy and plotting modules in ``sys.modules`` after running ``code`` in a fresh process."""
    probe = code + "\nimport sys, json\nprint(json.dumps(sorted(m for m in sys.modules if m.startswith(('ecostudy', 'matplotlib', 'pyomo.environ')))))"
    done = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return set(json.loads(done.stdout.strip().splitlines()[-1]))


def test_a_solve_without_plots_loads_no_feature_package_and_no_matplotlib(tmp_path):
    modules = loaded_after(f"from ecostudy import api\napi.solve_folder({str(ROOT / 'studies' / 'default.yaml')!r}, "
                           f"points=120, out='s', plot=False)", tmp_path)
    assert "ecostudy.api.single" in modules and "ecostudy.ocp.session" in modules  # it did solve
    assert not {m for m in modules if m.startswith(FEATURES)}, sorted(m for m in modules if m.startswith(FEATURES))
    assert json.loads((tmp_path / "s" / "summary.json").read_text())["status"] == "ok"


NL_PROBE = """
import hashlib, sys
{first}
from ecostudy.ocp.solver import NL_OPTIONS, configure
configure()
from pyomo.opt import WriterFactory
from ecostudy.ocp import problem, session
from ecostudy.studies.cases import load_checked_study
st = load_checked_study({study!r})
case = problem.prepare(st.track, st.train, st.from_stop, st.to_stop, 200, {{}}, ())
m = problem.build(case, problem.capped_guess(case, 76.0), "energy", {{}}, running_time=76.0)
session.repeatable()  # the solver chain prepared as before a solve: the NL writer registered
WriterFactory("nl")(m, "m.nl", lambda x: True, NL_OPTIONS)  # what PyomoNLP writes
print("pyomo.environ" in sys.modules, hashlib.sha256(open("m.nl", "rb").read()).hexdigest())
"""


def test_the_nl_file_written_with_pyomo_core_only_is_the_one_written_with_every_pyomo_plugin(tmp_path):
    def written(first):
        code = NL_PROBE.format(first=first, study=str(ROOT / "studies" / "default.yaml"))
        done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        return done.stdout.split()[-2:]

    lean, full = written(""), written("import pyomo.environ")
    assert lean[0] == "False" and full[0] == "True"  # the lean process never loaded Pyomo's plugins
    assert lean[1] == full[1]


def test_every_api_name_resolves_and_unknown_names_are_an_attribute_error():
    from ecostudy import api
    for name in api.__all__:
        assert getattr(api, name) is not None, name
    assert set(api.__all__) <= set(dir(api))
    with pytest.raises(AttributeError, match="no attribute 'solve_foldr'"):
        api.solve_foldr  # noqa: B018


def command(*args, cwd, env=None):
    return subprocess.run([sys.executable, "-m", "ecostudy", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=900, env=env)


def test_the_quick_exit_keeps_exit_codes_log_files_and_leaves_no_temporary_files(tmp_path):
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    env = dict(os.environ, TMPDIR=str(scratch))
    done = command("--log-file", "log.txt", "solve", ROOT / "studies" / "default.yaml", "--points", 150,
                   "--no-plot", "--out", "s", cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    assert "verification" in done.stdout  # stdout flushed before the exit
    assert (tmp_path / "log.txt").read_text().rstrip().endswith(f"solve: ok, written to {tmp_path / 's'}")
    assert list(scratch.iterdir()) == []  # the NL files' temporary folder is gone
    bad = command("solve", ROOT / "studies" / "default.yaml", "--points", -5, cwd=tmp_path, env=env)
    assert bad.returncode == 2 and "--points" in bad.stderr
    flagged = command("solve", "--track", TRACKS / "amsterdam_rokin_centraal.yaml", "--train",
                      TRAINS / "amsterdam_metro.yaml", "--time", 76, "--points", 12, "--no-plot", "--out", "f",
                      cwd=tmp_path, env=env)
    status = json.loads((tmp_path / "f" / "summary.json").read_text())["status"]
    assert flagged.returncode == (0 if status == "ok" else 1), (status, flagged.stderr)


def test_a_study_with_two_workers_exits_with_its_store_unlocked_and_every_case_stored(tmp_path):
    study = tmp_path / "sweep.yaml"
    study.write_text(f"""name: sweep
track: {TRACKS / 'amsterdam_rokin_centraal.yaml'}
train: {TRAINS / 'amsterdam_metro.yaml'}
from: Rokin
to: Centraal
points: 120
output: out
sweep:
  supplement_percent: [2, 6, 10, 14]
""")
    done = command("run", study, "--workers", 2, "--no-progress", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert not list((tmp_path / "out").glob("*.lock"))
    again = command("run", study, "--workers", 2, "--no-progress", cwd=tmp_path)  # all stored: nothing re-run
    assert again.returncode == 0, again.stderr
    assert "4 cases: 0 already stored, 4 computed now" in done.stdout, done.stdout
    assert "4 cases: 4 already stored, 0 computed now" in again.stdout, again.stdout


def test_the_api_lists_every_name_it_serves():
    from ecostudy import api
    assert sorted(api.__all__) == sorted(api.WHERE)
