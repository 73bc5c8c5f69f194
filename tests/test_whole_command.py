"""A command on a study folder writes it alone from its store's opening to its report.html: a second
command on the same folder is refused in one line (exit 2), never the cause of the first's failure."""
import json
import subprocess
import sys
import time

from .conftest import ROOT, TRACKS, TRAINS

REFUSED = "another ecostudy run is writing this store: wait for it to finish, or give another --out"
# the command line's own entry point, started when told, its modules loaded beforehand: what it does
# then takes 0.1 s to its store, not the seconds of a start-up under load
GATED = """import sys
from ecostudy.cli import main
import ecostudy.api.fronts, ecostudy.report.html, ecostudy.report.studyfiles, matplotlib.pyplot, pyomo.environ
print("ready", flush=True)
sys.stdin.readline()
sys.argv = ["ecostudy", *sys.argv[1:]]
main()
"""


def front(out):
    return ["pareto", "--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"), "--train",
            str(TRAINS / "amsterdam_metro.yaml"), "--count", "8", "-K", "120", "--workers", "1", "--dpi", "600", "--out", str(out)]


def gated(script, out):
    proc = subprocess.Popen([sys.executable, str(script), *front(out)], cwd=ROOT, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline() == "ready\n", proc.communicate()
    return proc


def writing(folder):
    """Whether a figure is being written into ``folder`` (its temporary file begun)."""
    for path in folder.glob(".pareto*.png*.tmp"):
        try:
            if path.stat().st_size:
                return True
        except FileNotFoundError:
            pass
    return False


def go(proc):
    proc.stdin.write("go\n")
    proc.stdin.flush()


def test_a_second_command_on_a_folder_whose_points_are_all_stored_is_refused_not_the_first_broken(tmp_path):
    out, script = tmp_path / "front", tmp_path / "gated.py"
    script.write_text(GATED)
    first = subprocess.run([sys.executable, "-m", "ecostudy", *front(out)], cwd=ROOT, capture_output=True, text=True,
                           timeout=600)
    assert first.returncode == 0, first.stderr
    # every point stored: a command only writes its tables and figures; the second starts while the
    # first writes a figure (at 600 dpi: for about 0.5 s), 0.1 s from its store (once it deleted the
    # first's temporary file as its store opened: the first's internal error, exit 3)
    refused = 0
    for _ in range(3):
        a, b = gated(script, out), gated(script, out)
        go(a)
        deadline = time.monotonic() + 120
        while not writing(out) and a.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
        go(b)
        ended = [(p.returncode, err) for p in (a, b) for _, err in [p.communicate(timeout=600)]]
        assert ended[0][0] == 0, ended[0][1]
        assert ended[1][0] == 0 or ended[1] == (2, f"error: {out / 'results.sqlite'}: {REFUSED}\n"), ended[1][1]
        assert json.loads((out / "summary.json").read_text())["status"] == "ok"
        assert not list(out.glob(".*.tmp")) and not list(out.glob("*.lock"))
        refused += ended[1][0] == 2
    assert refused  # the first still wrote its figures when the second's store opened


def test_a_command_without_a_store_is_refused_while_a_study_writes_the_folder(tmp_path):
    """solve and journey keep no store: they took a folder a running study was writing (exit 0), and
    the study's clean-up removed their files when it finished. The study's lock held by this process
    (a store open), each is refused in one line before computing; the lock let go, solve writes."""
    from ecostudy.io.store import Store

    out = tmp_path / "busy"
    solve = [sys.executable, "-m", "ecostudy", "solve", "--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"),
             "--train", str(TRAINS / "amsterdam_metro.yaml"), "--supplement", "10", "-K", "60", "--no-plot", "--out",
             str(out)]
    journey = [sys.executable, "-m", "ecostudy", "journey", "--track", str(TRACKS / "metro_line_4stops.yaml"),
               "--train", str(TRAINS / "amsterdam_metro.yaml"), "--supplement", "10", "--points", "60", "--no-plot",
               "--out", str(out)]
    store = Store(out / "results.sqlite")
    try:
        for args in (solve, journey):
            ran = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=300)
            assert ran.returncode == 2 and ran.stderr.strip() == (f"error: {out}: --out: another ecostudy command is "
                                                                  "writing this folder: wait for it to finish, or give "
                                                                  "another --out"), ran.stderr
            assert not (out / "profile.csv").exists() and not (out / "journey.csv").exists()
    finally:
        store.close()
    ran = subprocess.run(solve, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert ran.returncode == 0 and (out / "profile.csv").is_file(), ran.stderr
