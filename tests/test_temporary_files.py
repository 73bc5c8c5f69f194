"""Every file a command writes goes to a hidden temporary name beside it first (``.NAME<random>.tmp``)
and is renamed into place: a stop signal at any moment of a write leaves no temporary file, and one
that a killed command left (SIGKILL, a power cut) is removed by the next command that writes the
folder; no other file is touched."""
import inspect
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.errors import InputError
from ecostudy.core.interrupt import RECEIVED
from ecostudy.io.store import Store
from ecostudy.io.writers import atomic_write, check_output_dir

from .conftest import ROOT, TRACKS, TRAINS

# what atomic_write and the output folder's write test leave when killed, in the folder and in steps/
LEFT = [".profile.csvab12cd34.tmp", ".summary.json_x9y8z7w.tmp", ".write-testabcdefgh.tmp",
        "steps/.convex_draw0.csvq1w2e3r4.tmp"]
# a user's files that look alike: no leading dot, no 8 random characters, no .tmp, or a folder
OTHERS = [".notes.tmp", "notes.csvab12cd34.tmp", ".hidden", "mine.csv", ".profile.csvab12cd34.tmp.bak",
          "steps/.notes.tmp", "steps/mine.csv"]


def leftovers(folder):
    for name in (*LEFT, *OTHERS):
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text("x")
    (folder / ".table.csvfolder12.tmp").mkdir()


def remaining(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.name.startswith(".") or
                  p.name in ("mine.csv", "notes.csvab12cd34.tmp"))


def test_a_stop_signal_at_any_moment_of_a_write_leaves_no_temporary_file(tmp_path):
    """SIGINT raised at every point where Python runs a signal's handler (a function's start, the
    return of a function of C) during a write, one point per write: each write stopped so leaves the
    earlier file or the new one, whole, and no temporary file (2 of 160 such stops left it before:
    those between creating the temporary file and noting its name)."""
    target = tmp_path / "table.csv"
    atomic_write(target, lambda tmp: Path(tmp).write_text("earlier\n"))  # tempfile's names are set up
    received = len(RECEIVED)
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    stops, n = 0, 0
    try:
        while True:
            n += 1
            points = [0]

            def profile(frame, event, arg):
                if event in ("call", "c_return") and not frame.f_code.co_flags & inspect.CO_GENERATOR:
                    points[0] += 1
                    if points[0] == n:
                        signal.raise_signal(signal.SIGINT)
            sys.setprofile(profile)
            try:
                atomic_write(target, lambda tmp: Path(tmp).write_text(f"write {n}\n"))
            except KeyboardInterrupt:
                stops += 1
            finally:
                sys.setprofile(None)
            assert [p.name for p in tmp_path.iterdir()] == ["table.csv"], n
            assert target.read_text() in ("earlier\n", f"write {n}\n"), n
            if points[0] < n:  # the write ended before the n-th point
                break
            target.write_text("earlier\n")
    finally:
        signal.signal(signal.SIGINT, inherited)
        del RECEIVED[received:]
    assert stops == n - 1 > 50


@pytest.mark.skipif(shutil.which("strace") is None, reason="strace stops the write (apt-get install strace)")
def test_sigterm_while_a_file_is_renamed_into_place_leaves_no_temporary_file(tmp_path):
    """SIGTERM that arrives while the first file's rename fails (strace makes it fail and sends the
    signal): the command stops with 143 and the folder holds nothing (it kept ``.inputs.json...tmp``:
    the signal was raised on the way to its removal)."""
    out = tmp_path / "o"
    r = subprocess.run(["strace", "-f", "-o", "/dev/null", "-e", "trace=rename", "-e",
                        "inject=rename:error=EIO:signal=SIGTERM:when=1", sys.executable, "-m", "ecostudy", "solve",
                        "--track", TRACKS / "amsterdam_rokin_centraal.yaml", "--train", TRAINS / "amsterdam_metro.yaml",
                        "--time", "80", "--points", "50", "--out", out, "--no-plot"], cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    if "ptrace" in r.stderr and r.returncode != 143:
        pytest.skip(f"strace cannot trace here: {r.stderr.strip()}")
    assert r.returncode == 143 and "interrupted by SIGTERM" in r.stderr, r.stderr
    assert sorted(p.name for p in out.iterdir()) == []


def test_a_command_removes_the_temporary_files_a_killed_one_left(tmp_path):
    out = tmp_path / "o"
    leftovers(out)
    r = CliRunner().invoke(app, ["solve", "--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--time", "80", "--points", "50", "--out",
                                 str(out), "--no-plot"])
    assert r.exit_code == 0, r.output
    assert remaining(out) == sorted([*OTHERS, ".table.csvfolder12.tmp"]), r.output
    assert (out / "profile.csv").is_file()


def test_a_study_removes_them_once_it_holds_the_folder(tmp_path):
    """A study's folder is cleaned by the run that takes its store's lock (its steps/ too); while a
    study holds it, another command's check of the folder refuses it and removes nothing of the study's."""
    leftovers(tmp_path)
    store = Store(tmp_path / "results.sqlite")
    try:
        assert remaining(tmp_path) == sorted([*OTHERS, ".table.csvfolder12.tmp"])
        (tmp_path / LEFT[0]).write_text("being written by the study")
        with pytest.raises(InputError, match="another ecostudy command is writing this folder"):
            check_output_dir(tmp_path, ("profile.csv",))
        assert (tmp_path / LEFT[0]).is_file()
    finally:
        store.close()
