"""Batch studies: identical results serial / processes / Dask, resumable after kill -9, failures kept."""
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from contextlib import closing

import numpy as np
import pandas as pd
import pytest

from ecostudy.io.folder import COMMON
from ecostudy.io.store import Store
from ecostudy.studies.batch import execute, run_study
from ecostudy.studies.cases import expand

from .conftest import assert_folder, killed_part_way, ROOT, TRACKS, TRAINS, load_yaml, write_yaml

NUMERIC = ["running_time_s", "traction_energy_kWh", "net_energy_kWh", "top_speed_kmh"]


def study_file(folder, output, extra_scenarios=()):
    return write_yaml(folder / "study.yaml", {
        "name": "batch_test", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
        "train": str(TRAINS / "amsterdam_metro.yaml"), "from": "Rokin", "to": "Centraal",
        "supplement_percent": 10, "points": 200,
        "scenarios": [{"name": "loaded", "train_overrides": {"mass_t": 156.4, "effective_mass_t": 167.4}},
                      *extra_scenarios],
        "sweep": {"supplement_percent": [2, 6, 12]}, "output": str(output)})


def comparable(table):
    return table[["scenario", "supplement_pct", "key", "status"] + NUMERIC].reset_index(drop=True)


def same_results(table, other):
    """The same cases, statuses and numbers. Numbers to 1e-9, not bit for bit: a worker re-solves
    the NLP written for an earlier case of the same scenario (``ocp.problem.Written``), whose time
    scale came from that case's start, and which cases share a worker depends on the pool."""
    a, b = comparable(table), comparable(other)
    keys = ["scenario", "supplement_pct", "key", "status"]
    return a[keys].equals(b[keys]) and np.allclose(a[NUMERIC].to_numpy(float), b[NUMERIC].to_numpy(float),
                                                   rtol=1e-9, atol=0.0)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("serial")
    table, counts, _ = run_study(study_file(d, d / "out"))
    return table, counts, d


def test_cases_are_keyed_by_their_inputs(tmp_path):
    _, _, cases = expand(study_file(tmp_path, tmp_path / "out"))
    assert len(cases) == 6 and len({c["key"] for c in cases}) == 6
    _, _, again = expand(study_file(tmp_path, tmp_path / "out"))
    assert [c["key"] for c in again] == [c["key"] for c in cases]


def test_serial_run_completes_and_rerun_computes_nothing(reference):
    table, counts, folder = reference
    assert counts["computed"] == 6 and counts["failed"] == 0
    assert (table["status"] == "ok").all() and table["verified"].all()
    again, counts, _ = run_study(folder / "study.yaml")
    assert counts["stored_before"] == 6 and counts["computed"] == 0
    assert comparable(again).equals(comparable(table))


def test_two_workers_give_identical_table(reference, tmp_path):
    table, counts, _ = run_study(study_file(tmp_path, tmp_path / "out"), workers=2)
    assert counts["computed"] == 6
    assert same_results(table, reference[0])


@pytest.mark.slow
def test_killed_study_resumes_with_the_remaining_cases(reference, tmp_path):
    path = study_file(tmp_path, tmp_path / "out")
    db = tmp_path / "out" / "results.sqlite"
    stored = killed_part_way(["run", path, "--no-progress"], db)
    assert 2 <= stored < 6, "the study should have been killed part-way"
    table, counts, _ = run_study(path)
    assert counts["stored_before"] >= 2
    assert counts["computed"] == 6 - counts["stored_before"]
    assert same_results(table, reference[0])


def test_a_run_stopped_while_writing_its_files_leaves_no_earlier_summary_saying_ok(tmp_path):
    """The cases all computed, the run stops while its table is written (a folder in the way of
    results.csv: the writer fails as a full disk or a signal would stop it): summary.json is not the
    earlier run's 'ok' beside a table it did not describe; it says the run stopped while writing."""
    path = study_file(tmp_path, tmp_path / "out")
    data = load_yaml(path)
    write_yaml(path, {**data, "sweep": {"supplement_percent": [6]}})
    run_study(path)
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["status"] == "ok"
    write_yaml(path, {**data, "sweep": {"supplement_percent": [6, 12]}})

    def in_the_way(done, failed, remaining, total):  # after the last case: the table cannot be written
        if remaining == 0:
            (tmp_path / "out" / "results.csv").unlink()
            (tmp_path / "out" / "results.csv").mkdir()
    with pytest.raises(OSError):
        run_study(path, progress=in_the_way)
    stopped = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert stopped["status"].startswith("failed: stopped while its files were written"), stopped["status"]
    assert not (tmp_path / "out" / "report.html").exists()


def stopped_after_one_case(path, folder):
    """The summary.json of the study ``path`` run into ``folder`` and stopped (KeyboardInterrupt, as
    SIGINT raises it) after its first case; it says so."""
    def stop(*counts):
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        run_study(path, progress=stop)
    stopped = json.loads((folder / "summary.json").read_text())
    assert stopped["status"].startswith("failed: stopped before every case was computed"), stopped["status"]
    return stopped


def test_an_interrupted_run_leaves_no_earlier_summary_saying_ok(tmp_path):
    """A finished study, then its sweep extended and the run stopped after one new case: the
    folder's summary.json was the finished run's (ok, 2 cases) for a study of 4 not finished. It
    now says failed (stopped), keeps listing the earlier run's files, and report.html is gone."""
    path = study_file(tmp_path, tmp_path / "out")
    data = load_yaml(path)
    write_yaml(path, {**data, "sweep": {"supplement_percent": [6]}})
    run_study(path)
    assert (tmp_path / "out" / "summary.json").is_file()
    write_yaml(path, {**data, "sweep": {"supplement_percent": [6, 12]}})

    stopped = stopped_after_one_case(path, tmp_path / "out")
    assert "results.csv" in stopped["files"] and not (tmp_path / "out" / "report.html").exists()
    assert "report.html" not in stopped["files"]  # removed, not listed
    # the stopped study's cases, by what is stored (3 of 4): the finished run's "2 cases: 2 ok" is gone
    assert stopped["cases"] == {"total": 4, "ok": 3, "flagged": 0, "failed": 0} and stopped["not_ok"] == []
    table, counts, _ = run_study(path)
    assert counts["stored_before"] == 3 and (table["status"] == "ok").all()
    assert (tmp_path / "out" / "summary.json").is_file()


def test_a_stopped_rerun_from_another_study_file_writes_a_summary_of_its_own(tmp_path):
    """A finished study, then the same study (its name) from another file with one more sweep value,
    stopped after its first new case: summary.json speaks for the stopped run alone, its study file
    and counts, none of the finished run's fields."""
    path = study_file(tmp_path, tmp_path / "out")
    data = load_yaml(path)
    write_yaml(path, {**data, "sweep": {"supplement_percent": [6]}})
    run_study(path)
    finished = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert finished["study"] == str(path) and finished["computed_now"] == 2
    other = write_yaml(tmp_path / "extended.yaml", {**data, "sweep": {"supplement_percent": [6, 12]}})

    stopped = stopped_after_one_case(other, tmp_path / "out")
    assert (stopped["study"], stopped["computed_now"], stopped["stored_before"]) == (str(other), 1, 2)
    assert stopped["cases"] == {"total": 4, "ok": 3, "flagged": 0, "failed": 0} and stopped["tables"] == {}
    assert set(stopped) == set(COMMON) | {"study", "computed_now", "stored_before"}
    assert stopped["kind"] == "run" and "results.csv" in stopped["files"]  # removed by the next run that ends


def test_failures_are_recorded_and_do_not_stop_the_study(tmp_path):
    path = study_file(tmp_path, tmp_path / "out", [{"name": "too_fast", "running_time_s": 50.0}])
    # the sweep overrides the scenario's timing; keep this scenario's 50 s by sweeping points instead
    data = __import__("yaml").safe_load(path.read_text())
    data["sweep"] = {"points": [200]}
    write_yaml(path, data)
    table, counts, _ = run_study(path)
    bad = table[table["scenario"] == "too_fast"]
    # one vocabulary: results.csv said `infeasible` where summary.json said `failed: infeasible: ...`;
    # the store keeps `infeasible` (as stores written before do), the table the kind and its reason
    written = pd.read_csv(tmp_path / "out" / "results.csv")
    for t in (table, written):
        assert set(t["status"]) == {"ok", "failed"}, t["status"].tolist()
        assert list(t[t["scenario"] == "too_fast"]["status"]) == ["failed"]
    assert bad["reason"].iloc[0].startswith("infeasible: the fastest possible run takes"), bad["reason"].iloc[0]
    assert (table[table["scenario"] != "too_fast"]["status"] == "ok").all()
    assert counts["not_ok"] == 1
    # the command says which case is not ok, in the status vocabulary, and exits 1 (all stored now)
    from typer.testing import CliRunner

    from ecostudy.cli import app
    r = CliRunner().invoke(app, ["run", str(path), "--no-progress"])
    assert r.exit_code == 1, r.output
    line = next(x for x in r.output.splitlines() if x.startswith("failed: "))
    assert "scenario=too_fast" in line and "infeasible" in line and "fastest possible run takes" in line
    # the reason once, on its case's line; the status line last, the kind of status only
    assert r.stderr.count("fastest possible run takes") == 1, r.stderr
    assert r.stderr.rstrip().splitlines()[-1] == f"run: failed, written to {(tmp_path / 'out').resolve()}", r.stderr
    folder = assert_folder(tmp_path / "out", "run", ["results"], status="failed")
    assert folder.cases.failed == 1 and folder.cases.ok == len(table) - 1


def test_case_equals_a_direct_solve(reference):
    """The all-out time is memoised per scenario; the case must still equal `ecostudy solve --supplement`."""
    from ecostudy.core.types import Timing
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.analysis.single import solve_run
    table = reference[0]
    row = table[(table["scenario"] == "base") & (table["supplement_pct"] == 6)].iloc[0]
    direct = solve_run(load_track(TRACKS / "amsterdam_rokin_centraal.yaml"), load_train(TRAINS / "amsterdam_metro.yaml"),
                       "Rokin", "Centraal", Timing(supplement=0.06), points=200)
    assert row["traction_energy_kWh"] == pytest.approx(direct.summary["traction_energy_kWh"], rel=1e-9)
    assert row["all_out_time_s"] == pytest.approx(direct.summary["all_out_time_s"], rel=1e-12)


@pytest.mark.slow
def test_ctrl_c_says_how_to_continue(tmp_path):
    # K = 1000: the cases after the first re-use its written NLP (ocp.problem.Written) and at
    # K = 200 the rest of the study finished before the signal arrived
    path = study_file(tmp_path, tmp_path / "out")
    write_yaml(path, {**load_yaml(path), "points": 1000})
    db = tmp_path / "out" / "results.sqlite"
    # SIGINT as a terminal gives it: a runner started in the background ignores SIGINT, and so did
    # the study it started (four clean-clone runs of .ci/run started with & failed so)
    proc = subprocess.Popen([sys.executable, "-m", "ecostudy", "run", str(path), "--no-progress"], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        # read-only, and only once the store is in WAL mode: a read-write connect here created the
        # file before the study did, and could hold the lock the study needs to switch it to WAL
        if db.with_name(db.name + "-wal").exists():
            try:
                with closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True)) as conn:
                    if conn.execute("SELECT count(*) FROM cases").fetchone()[0] >= 1:
                        break
            except sqlite3.OperationalError:  # busy
                pass
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.fail("the study finished before it could be interrupted")
    assert proc.returncode == 130
    assert "run the same command again to continue" in err
    _, counts, _ = run_study(path)
    assert counts["stored_before"] >= 1 and counts["computed"] == 6 - counts["stored_before"]


def test_das_columns_in_a_study(tmp_path):
    """`das: phases` in a study adds das_ columns; a scenario may choose another method; a case
    without das keeps the key it had before the field existed."""
    path = write_yaml(tmp_path / "study.yaml", {
        "name": "das_study", "track": str(TRACKS / "regional_808m.yaml"), "train": str(TRAINS / "regional_alstom.yaml"),
        "supplement_percent": 10, "points": 200, "das": "phases",
        "scenarios": [{"name": "rounded", "das": "round"}], "output": str(tmp_path / "out")})
    table, counts, _ = run_study(path)
    assert counts["failed"] == 0
    rows = table.set_index("scenario")
    assert rows.loc["base", "das_method"] == "phases" and rows.loc["rounded", "das_method"] == "round"
    assert rows.loc["base", "das_solver"].startswith("optimal") and rows.loc["base", "das_status"] == "ok"
    assert abs(rows.loc["base", "das_gap_to_ato_on_time_pct"]) < 0.5
    plain = write_yaml(tmp_path / "plain.yaml", {
        "name": "das_study", "track": str(TRACKS / "regional_808m.yaml"), "train": str(TRAINS / "regional_alstom.yaml"),
        "supplement_percent": 10, "points": 200, "output": str(tmp_path / "out")})
    key = expand(plain)[2][0]["key"]
    assert key != rows.loc["base", "key"] and "das" not in expand(plain)[2][0]


def test_a_library_study_runs_every_segment_of_every_fitting_pair(tmp_path):
    """A study naming a TTOBench checkout (`library:`): every consecutive pair of stops of every
    track with every train that fits the line, one resumable batch; a pair left out is listed with
    its reason in skipped.csv. The checkout here is built from the test data (two tracks, two
    trains; the 80 km/h train does not fit a 200 km/h line at the default 60 % share)."""
    import json
    import shutil

    import pandas as pd
    from typer.testing import CliRunner

    from ecostudy.cli import app
    from .conftest import DATA
    lib = tmp_path / "ttobench"
    (lib / "tracks").mkdir(parents=True)
    (lib / "trains").mkdir()
    shutil.copy(DATA / "ttobench_track.json", lib / "tracks" / "T1.json")
    fast = json.loads((DATA / "ttobench_track.json").read_text())
    fast["speed limits"]["values"] = [[0.0, 200]]
    (lib / "tracks" / "T2.json").write_text(json.dumps(fast))
    shutil.copy(DATA / "ttobench_subway_train.json", lib / "trains" / "subway.json")
    study = tmp_path / "lib.yaml"
    study.write_text(f"name: lib\nlibrary: {{path: ttobench}}\nsupplement_percent: 10\npoints: 150\n"
                     f"output: {tmp_path / 'out'}\n")
    r = CliRunner().invoke(app, ["run", str(study), "--no-progress"])
    assert r.exit_code == 0, r.output
    table = pd.read_csv(tmp_path / "out" / "results.csv")
    assert list(zip(table["track"], table["from"], table["to"])) == [("T1", "S0", "S1"), ("T1", "S1", "S2")]
    assert (table["status"] == "ok").all() and table["verified"].all()
    assert_folder(tmp_path / "out", "run", ["results", "skipped"], rows=2)
    skipped = pd.read_csv(tmp_path / "out" / "skipped.csv")
    assert skipped.to_dict("records") == [{"track": "T2", "train": "subway",
                                          "reason": "top speed 80 km/h below 60% of the line's 200 km/h"}]
    r = CliRunner().invoke(app, ["run", str(study), "--no-progress"])  # resumable: nothing computed again
    assert "0 computed now" in r.output.replace("2 already stored, ", "")


def test_workers_die_with_their_parent(tmp_path):
    """`run --workers 2` killed with -9: its worker processes end too (prctl PR_SET_PDEATHSIG)
    instead of computing on, orphaned."""
    path = study_file(tmp_path, tmp_path / "out")
    proc = subprocess.Popen([sys.executable, "-m", "ecostudy", "run", str(path), "--workers", "2", "--no-progress"],
                            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def children():
        out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(proc.pid)], capture_output=True, text=True).stdout
        return [int(p) for p in out.split()]

    deadline, workers = time.time() + 60, []
    while time.time() < deadline and len(workers) < 2:
        workers = children()
        time.sleep(0.1)
    assert len(workers) >= 2, "the workers never started"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.time() + 20
    while time.time() < deadline and any(os.path.exists(f"/proc/{p}") and
                                         "Z" not in open(f"/proc/{p}/stat").read().split()[2] for p in workers):
        time.sleep(0.1)
    alive = [p for p in workers if os.path.exists(f"/proc/{p}") and "Z" not in open(f"/proc/{p}/stat").read().split()[2]]
    assert not alive, f"workers {alive} outlived their parent"


def test_a_case_whose_advice_misses_the_stop_is_flagged(tmp_path):
    """`das: round` at K = 200: the case's ATO optimum is verified, its rounded advice as driven
    stops about 1.9 m short: the case is flagged naming the advice (as `compare` flags that run)."""
    path = write_yaml(tmp_path / "study.yaml", {
        "name": "das_flag", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
        "train": str(TRAINS / "amsterdam_metro.yaml"), "running_time_s": 76, "points": 200, "das": "round",
        "output": str(tmp_path / "out")})
    table, counts, _ = run_study(path)
    row = table.iloc[0]
    assert row["verified"] and row["solver_status"] == "optimal"
    assert abs(row["das_stop_error_m"]) > 1.0 and row["das_status"].startswith("flagged: stopped")
    assert row["status"] == "flagged", row
    assert str(row["reason"]).startswith("driver advice round: stopped"), row["reason"]
    assert counts["not_ok"] == 1


def test_a_supplement_over_an_all_out_run_not_proven_optimal_is_flagged(tmp_path, monkeypatch):
    """A case's running time is a supplement over its scenario's all-out run, solved once per
    process. Solved with a tolerance Ipopt cannot reach (tol 1e-20 on every space NLP) it ends
    ``acceptable``: the case says so beside its own NLP's end."""
    from ecostudy.ocp.problem import Written
    from ecostudy.ocp.solver import IPOPT
    from ecostudy.studies import batch
    case = expand(study_file(tmp_path, tmp_path / "out"))[2][0]
    monkeypatch.setattr(batch, "_ALL_OUT", {})  # solved here, as a fresh worker does, and forgotten after
    monkeypatch.setattr(batch, "_WRITTEN", Written())
    monkeypatch.setitem(IPOPT["space"], "tol", 1e-20)
    row = batch.run_case(case)
    assert row["status"] == "flagged", row
    assert row["error"] == "Ipopt ended acceptable, not optimal; the all-out run: Ipopt ended acceptable, not optimal"
    assert row["summary"]["all_out_solver_status"] == "acceptable"


def _dies_on_x(case):
    """A case task whose worker process dies (SIGKILL, as the kernel's out-of-memory killer sends) on
    the case 'x'; the others take 0.2 s each."""
    if case["key"] == "x":
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.2)
    return {"key": case["key"], "status": "ok", "error": None, "summary": {"pid": os.getpid()}, "seconds": 0.2}


def test_a_worker_process_that_dies_fails_its_own_case_and_the_study_goes_on(tmp_path):
    """A worker killed in a case broke the whole pool: the command ended with an internal error
    (BrokenProcessPool, exit 3), nothing written. Now the cases not finished run again in a new pool,
    then each alone; the one that kills its own worker is stored failed with the reason, every other
    case is stored ok."""
    cases = [{"key": k, "study": "deaths", "scenario": "base", "labels": {"case": k}} for k in "abxcde"]
    with closing(Store(tmp_path / "results.sqlite")) as store:
        counts = execute(cases, store, task=_dies_on_x, workers=2)
        rows = store.get([c["key"] for c in cases])
    assert counts["computed"] == 6 and counts["failed"] == 1, counts
    assert rows["x"]["status"] == "failed" and "worker process died" in rows["x"]["error"], rows["x"]
    assert all(rows[k]["status"] == "ok" for k in "abcde"), rows
