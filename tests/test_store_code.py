"""A study resumes only with results stored by the same code: the case key holds the code's fingerprint."""
import os
import shutil
import subprocess
import sys

from ecostudy import __version__
from ecostudy.studies.batch import run_study
from ecostudy.studies.cases import case_key, code_version, expand, source_fingerprint

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


def test_every_case_records_the_code_and_its_key_changes_with_it(tmp_path):
    _, _, cases = expand(one_case_study(tmp_path))
    assert code_version().startswith(__version__ + "+")
    assert code_version() == f"{__version__}+{source_fingerprint(ROOT / 'ecostudy')}"
    (case,) = cases
    assert case["version"] == code_version()
    assert case_key({**case, "version": __version__ + "+000000000000"}) != case["key"]


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
