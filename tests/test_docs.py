"""The guide builds: `mkdocs build --strict` over docs/ and mkdocs.yml (what `make docs` and CI run).

Strict mode turns every warning into a failure: a nav entry whose page is missing, a link to a
page or anchor that does not exist, an API reference (`::: ecostudy.api`) that does not resolve.
"""
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_the_guide_builds_with_no_warning(tmp_path):
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1", PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "WARNING" not in done.stderr, done.stderr
    assert (tmp_path / "site" / "index.html").is_file()
    assert "ecostudy.api.solve" in (tmp_path / "site" / "api" / "index.html").read_text()
