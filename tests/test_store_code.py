"""A study resumes only with results stored by the same code: the case key holds the code's fingerprint."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from ecostudy import __version__
from ecostudy.studies.batch import run_study
from ecostudy.studies.cases import code_version, expand, source_fingerprint
from ecostudy.studies.kinds import STUDY_KINDS

from .conftest import ROOT, TRACKS, TRAINS, write_yaml


def one_case_study(folder):
    return write_yaml(folder / "study.yaml", {
        "name": "code_test", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
        "train": str(TRAINS / "amsterdam_metro.yaml"), "from": "Rokin", "to": "Centraal",
        "supplement_percent": 10, "points": 120, "output": str(folder / "out")})


def test_the_fingerprint_follows_every_source_file(tmp_path):
    shutil.copytree(ROOT / "ecostudy", tmp_path / "ecostudy", ignore=shutil.ignore_patterns("__pycache__"))
    before = source_fingerprint(tmp_path / "ecostudy")
    assert before == source_fingerprint(tmp_path / "ecostudy")
    with open(tmp_path / "ecostudy" / "core" / "status.py", "a") as f:
        f.write("# one more line\n")
    assert source_fingerprint(tmp_path / "ecostudy") != before
    (tmp_path / "ecostudy" / "core" / "status.py").rename(tmp_path / "ecostudy" / "core" / "status2.py")
    assert source_fingerprint(tmp_path / "ecostudy") != before


KEYS = ("import json, sys; from pathlib import Path; import ecostudy; from ecostudy.studies.kinds import STUDY_KINDS; "
        "print(json.dumps([ecostudy.__file__, {k: [c['key'] for c in STUDY_KINDS.get(k).expand(Path(sys.argv[1])).cases] "
        "for k in ('run', 'compare', 'pareto')}]))")


def keys_of(code, study):
    """The case keys of ``study`` in the kinds run, compare and pareto, as the package at ``code`` expands it."""
    done = subprocess.run([sys.executable, "-c", KEYS, str(study)], cwd=code, env={**os.environ, "PYTHONPATH": str(code)},
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    where, keys = json.loads(done.stdout)
    assert Path(where).is_relative_to(code), where  # that copy of the package, not another
    return keys


def test_every_case_key_holds_the_code(tmp_path):
    """The key of every kind's case is made with the code that computes it (``cases.case_key``): an
    identical copy of the package gives the same keys, a copy that differs by one comment others."""
    assert code_version().startswith(__version__ + "+")
    assert code_version() == f"{__version__}+{source_fingerprint(ROOT / 'ecostudy')}"
    study = one_case_study(tmp_path)
    same, other = tmp_path / "same", tmp_path / "other"
    for code in (same, other):
        shutil.copytree(ROOT / "ecostudy", code / "ecostudy", ignore=shutil.ignore_patterns("__pycache__"))
        (code / ".pyomo").symlink_to(ROOT / ".pyomo")
    with open(other / "ecostudy" / "core" / "status.py", "a") as f:
        f.write("# other code\n")
    here = {"run": [c["key"] for c in expand(study)[2]],
            **{k: [c["key"] for c in STUDY_KINDS.get(k).expand(study).cases] for k in ("compare", "pareto")}}
    assert keys_of(same, study) == here
    there = keys_of(other, study)
    assert {k: len(v) for k, v in there.items()} == {"run": 1, "compare": 6, "pareto": 20}
    assert not set(sum(there.values(), [])) & set(sum(here.values(), []))


def test_results_stored_by_other_code_are_computed_again(tmp_path):
    """The study run first by a copy of the package that differs by one comment, then by this code:
    nothing of the copy's is reused; run again, everything is."""
    code = tmp_path / "other"
    shutil.copytree(ROOT / "ecostudy", code / "ecostudy", ignore=shutil.ignore_patterns("__pycache__"))
    with open(code / "ecostudy" / "core" / "status.py", "a") as f:
        f.write("# other code\n")
    (code / ".pyomo").symlink_to(ROOT / ".pyomo")  # the PyNumero library the install built
    study = one_case_study(tmp_path)
    env = {**os.environ, "PYTHONPATH": str(code)}
    done = subprocess.run([sys.executable, "-m", "ecostudy", "run", str(study), "--no-progress"],
                          cwd=code, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "results.sqlite").exists()
    _, counts, _ = run_study(study)
    assert counts["stored_before"] == 0 and counts["computed"] == 1 and counts["stored_other"] == 1
    _, counts, _ = run_study(study)
    assert counts["stored_before"] == 1 and counts["computed"] == 0 and counts["stored_other"] == 1
    again = subprocess.run([sys.executable, "-m", "ecostudy", "run", str(study), "--no-progress"], cwd=ROOT,
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert "1 already stored, 0 computed now" in again.stdout
    assert "1 result in the store not reused (stored for other inputs or by other code)" in again.stdout
