"""The project speaks of itself only: no tracked file names a work session or an issue by number
(history lives in git), and what users read cites the sources by author, not by file number."""
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SKIPPED_DIRS = {".git", ".venv", ".pyomo", "site", "out", "__pycache__", ".pytest_cache", ".mypy_cache"}


def tracked(*patterns):
    """The files git tracks (matching ``patterns``); outside a git checkout (a source archive) every
    file of the tree but the installed and generated folders."""
    try:
        out = subprocess.run(["git", "ls-files", *patterns], cwd=ROOT, capture_output=True, text=True, check=True)
        return [ROOT / name for name in out.stdout.splitlines() if (ROOT / name).is_file()]
    except (OSError, subprocess.CalledProcessError):
        files = [p for p in ROOT.rglob("*") if p.is_file() and not SKIPPED_DIRS & set(p.relative_to(ROOT).parts)]
        return [p for p in files if not patterns or any(p.relative_to(ROOT).match(pat) for pat in patterns)]


def hits(files, pattern):
    found = []
    for path in files:
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if pattern.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}")
    return found


def test_no_session_or_issue_numbers_in_tracked_files():
    assert not hits(tracked(), re.compile(r"(session|issue) [0-9]+", re.I))


def test_what_users_read_cites_the_sources_by_author():
    files = tracked("README.md", "docs/*.md", "ecostudy/cli/*.py")
    assert not hits(files, re.compile(r"\b(thesis|paper|note) 00[0-3]\b"))
