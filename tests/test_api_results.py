"""The Python API from a notebook: results that say what they are in a line and whether they can be
trusted (``status``, ``reason``), and bad arguments refused by name before anything is solved."""
import html
import inspect
import re
from pathlib import Path

import pytest

from ecostudy import api

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def case():
    return (api.load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
            api.load_train(ROOT / "trains/amsterdam_metro.yaml"))


def test_a_run_is_one_line_with_its_status(case, tmp_path):
    run = api.solve(*case, running_time=80.0, points=40)
    text = repr(run)
    assert "\n" not in text and len(text) < 300, text
    assert text.startswith("Solution(Rokin -> Centraal, 1106 m, K = 40, energy: 80.00 s, traction ")
    assert text.endswith("; ok)") and run.status.ok and run.ok and run.reason == ""
    assert repr(run.run) == f"RunResult({text[len('Solution('):]}"  # the run inside says the same
    run.save(tmp_path / "run", plot=False)
    folder = api.load(tmp_path / "run")
    assert repr(folder) == (f"Report(solve folder {tmp_path / 'run'}, tables: profile (40 rows); "
                            "1 case: 1 ok, 0 flagged, 0 failed; ok)")
    assert folder.reason == "" and str(folder.cases) == "1 case: 1 ok, 0 flagged, 0 failed"
    api.solve_folder(track=ROOT / "tracks/amsterdam_rokin_centraal.yaml", train=ROOT / "trains/amsterdam_metro.yaml",
                     time=80.0, points=40, out=tmp_path / "solved", plot=False)
    note = api.export_folder(tmp_path / "solved", "1s")  # its data is the whole table: the repr is what it printed
    assert repr(note) == f"Note(ok)\n{note.text}" and note.text.endswith("the run exported: ok")
    assert note.status == api.Status("ok") and note.ok and note.reason == ""
    table = run.every(time_step_s=1.0)  # the same table without a folder
    assert list(table) == list(note.data) and len(table) == len(note.data) == 81
    assert table.drop(columns="handle").to_numpy() == pytest.approx(note.data.drop(columns="handle").to_numpy(), rel=1e-5, abs=1e-3)
    assert run.every(distance_step_m=100.0)["position_m"].tolist()[-2:] == [1100.0, 1106.0]
    for bad, line in (({}, "time_step_s/distance_step_m: give one of them"),
                      ({"time_step_s": 0}, "time_step_s: must be a number of at least 8e-05 (at most 1,000,000 rows), "
                                           "not 0")):
        with pytest.raises(api.InputError, match=f"^arguments: {re.escape(line)}$"):
            run.every(**bad)


@pytest.mark.flagged_on_purpose
def test_a_flagged_run_says_so_and_why(case, tmp_path):
    run = api.solve(*case, running_time=80.0, points=10)  # too coarse a grid: the re-simulation disagrees
    assert run.status.kind == "flagged" and run.reason.startswith("re-simulation outside tolerance (arrival ")
    assert repr(run).endswith(f"; flagged: {run.reason})") and not run.ok
    run.save(tmp_path / "coarse", plot=False)
    folder = api.load(tmp_path / "coarse")
    assert folder.reason == run.reason
    assert repr(folder).endswith(f", tables: profile (10 rows); 1 case: 0 ok, 1 flagged, 0 failed; flagged: {run.reason})")
    for shown in (run._repr_html_(), folder._repr_html_()):  # a notebook cell: the status and its reason
        assert f"<b>flagged</b>: {html.escape(run.reason)}</p>" in shown
    assert "<th>traction_<wbr>energy_<wbr>kWh</th>" in run._repr_html_()  # the summary's values
    assert "<td>Rokin-Centraal</td><td class=\"s-flagged long\">flagged: re-simulation" in folder._repr_html_()


@pytest.mark.flagged_on_purpose  # the 20 % point of this coarse front is flagged
def test_a_front_is_a_short_table_with_its_status(case):
    front = api.pareto(*case, count=3, supplement_max_percent=20, points=40)
    lines = repr(front).splitlines()
    assert len(lines) == 5, lines  # the head, the column names, three points
    assert lines[0].startswith("Front(3 points, Rokin -> Centraal; ") and lines[0].endswith(f"{front.status})")
    assert lines[1].split() == ["running_time_s", "supplement_pct", "traction_energy_kWh", "net_energy_kWh", "status"]
    assert [line.split()[-1] for line in lines[2:]] == [str(s).split(":")[0] for s in front.table["status"]]
    kinds = {str(s).split(":")[0] for s in front.table["status"]}
    assert front.status.kind == ("failed" if "failed" in kinds else "flagged" if "flagged" in kinds else "ok")
    assert front.reason == "; ".join(f"point {i + 1} ({t:.2f} s): {str(s).split(': ', 1)[1]}" for i, (t, s)  # whose each is
                                     in enumerate(zip(front.table["running_time_s"], front.table["status"]))
                                     if str(s).startswith(front.status.kind))
    assert all(isinstance(r, api.Solution) and "\n" not in repr(r) for r in front.runs)
    shown = front._repr_html_()
    assert shown.startswith(f"<div><p><code>Front({html.escape(front.head())})</code>: <b>{front.status.kind}</b>") and shown.count("<tr>") == 1 + len(front.table)


BAD = [  # (arguments of api.solve, what the one line says)
    ({"running_time": -5.0}, "arguments: running_time: must be more than 0.0, not -5.0"),
    ({"running_time": float("nan")}, "arguments: running_time: must be a finite number, not nan"),
    ({"running_time": "80"}, "arguments: running_time: must be a number, not '80'"),
    ({"supplement_percent": -5}, "arguments: supplement_percent: must be at least 0.0 and at most 200.0, not -5"),
    ({"running_time": 80.0, "points": 0}, "arguments: points: must be at least 10 and at most 100000, not 0"),
    ({"running_time": 80.0, "points": 80.5}, "arguments: points: must be a whole number, not 80.5"),
    ({"window": (90, 80)}, "arguments: window: must be 'earliest,latest' with 0 <= earliest <= latest, not '90,80'"),
    ({"running_time": 80.0, "objective": "fast"},
     "arguments: objective: expected one of energy, net_energy, time, mixed, not 'fast'"),
    ({"running_time": 80.0, "supplement_percent": 5.0},
     "arguments: running_time/supplement_percent/window: give one of them"),
    ({}, "arguments: running_time: give running_time, supplement_percent or window (or objective='time' for the "
         "all-out run)"),
    ({"objective": "time", "running_time": 80.0},
     "arguments: objective: 'time' finds the fastest run: it takes no running_time, supplement_percent or window"),
]


@pytest.mark.parametrize("kwargs, line", BAD, ids=[str(k) for k, _ in BAD])
def test_a_bad_argument_is_one_line_naming_it(case, kwargs, line):
    with pytest.raises(api.InputError) as caught:
        api.solve(*case, **kwargs)
    assert str(caught.value) == line


def test_front_and_replanner_arguments_are_refused_by_name(case):
    with pytest.raises(api.InputError, match=r"^arguments: count: must be at least 2 and at most 10000, not 1$"):
        api.pareto(*case, count=1, points=40)
    with pytest.raises(api.InputError, match=r"^arguments: supplement_max_percent: must be more than 0.0"):
        api.pareto(*case, count=3, supplement_max_percent=-10, points=40)
    with pytest.raises(api.InputError, match=r"^arguments: points: must be at least 10"):
        api.replanner(*case, running_time=80.0, points=0)
    with pytest.raises(api.InputError, match=r"^arguments: running_time: must be more than 0.0, not -80$"):
        api.replanner(*case, running_time=-80)


def test_a_running_time_below_the_fastest_run_names_the_argument(case):
    """An InfeasibleError (api.InfeasibleError, an InputError: docs/api.md catches it by that name)."""
    for make in (lambda: api.solve(*case, running_time=50.0, points=40),
                 lambda: api.replanner(*case, running_time=50.0, points=40)):
        with pytest.raises(api.InfeasibleError, match=r"^arguments: running_time: infeasible: the fastest possible run "
                                                 r"takes 7\d\.\d s \(asked for 50\.0 s\)$"):
            make()


def test_bad_inputs_are_the_same_exception_naming_file_and_field(tmp_path):
    with pytest.raises(api.InputError, match=r"^.*nope\.yaml: file not found$"):
        api.load_train(tmp_path / "nope.yaml")
    with pytest.raises(api.InputError, match=r"track \(in code\): speed_limits\[0\]\.speed_mps: unknown field"):
        api.track_from_dict({"name": "f", "source": "a test", "length_m": 1000,
                             "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1000}],
                             "gradients": [{"position_m": 0, "gradient_permille": 0}],
                             "speed_limits": [{"position_m": 0, "speed_mps": 20}]})
    with pytest.raises(api.InputError, match=r"summary\.json: not an ecostudy output folder"):
        api.load(tmp_path)


def test_a_replanner_and_its_plans_are_one_line_with_their_status(case):
    from IPython.lib.pretty import pretty  # what a notebook cell shows of an object without _repr_html_

    planner = api.replanner(*case, running_time=80.0, points=40)
    assert repr(planner) == "Replanner(Rokin -> Centraal, 1106 m, K = 40, energy, arrival at 80.00 s; no plan yet)"
    plan = planner.solve(api.State(position=400.0, speed=15.0, time=30.0))
    text = repr(plan)
    assert pretty(plan) == text and "\n" not in text and len(text) < 200, text
    assert re.fullmatch(r"Plan\(Rokin -> Centraal, from 400\.0 m at 15\.00 m/s, clock 30\.00 s: arrival at 1106 m, "
                        r"0\.00 m/s, clock 80\.00 s, traction still to do (\d\.\d{3}) kWh; ok\)", text), text
    assert plan.start == api.State(400.0, 15.0, 30.0) and plan.ok and plan.reason == ""
    assert f"{plan.traction_energy / 3.6e6:.3f} kWh" in text
    late = planner.solve(api.State(position=400.0, speed=15.0, time=30.0), arrival=35.0, options={"max_iter": 5})
    assert late.status.kind == "flagged" and late.reason == "Ipopt ended max_iterations, not optimal"
    assert repr(late).endswith("; flagged: Ipopt ended max_iterations, not optimal)") and not late.ok
    assert repr(planner) == ("Replanner(Rokin -> Centraal, 1106 m, K = 40, energy, arrival at 80.00 s; 2 plans, the "
                             "last flagged: Ipopt ended max_iterations, not optimal)")
    assert repr(api.replanner(*case, window=(70.0, 90.0), points=40)).startswith(
        "Replanner(Rokin -> Centraal, 1106 m, K = 40, energy, arrival in [70.00, 90.00] s; ")


TRACK, TRAIN = ROOT / "tracks/amsterdam_rokin_centraal.yaml", ROOT / "trains/amsterdam_metro.yaml"
FOLDER_BAD = [  # (a command function, its arguments, what it says called from Python, from the command line)
    (api.solve_folder, {"time": -5}, "arguments: time: must be more than 0.0, not -5",
     "command line: --time: must be more than 0.0, not -5"),
    (api.solve_folder, {"track": TRACK, "train": TRAIN, "time": 80.0, "supplement": 5.0},
     "arguments: time/supplement: give only one: each sets the running time",
     "command line: --time/--supplement: give only one: each sets the running time"),
    (api.solve_folder, {"track": TRACK, "train": TRAIN},
     "arguments: time: give time, supplement or window (or objective time for the all-out run)",
     "command line: --time: give --time, --supplement or --window (or --objective time for the all-out run)"),
    (api.solve_folder, {"track": TRACK, "train": TRAIN, "objective": "time", "time": 80.0},
     "arguments: objective='time': finds the fastest run: it takes no time, supplement or window",
     "command line: --objective time: finds the fastest run: it takes no --time, --supplement or --window"),
    (api.solve_folder, {"track": TRACK, "train": TRAIN, "time": 80.0, "to_stop": "Nowhere"},
     "arguments: to_stop: unknown stop 'Nowhere' (track 'Amsterdam metro Rokin - Centraal' has: Rokin, Centraal)",
     "command line: --to: unknown stop 'Nowhere' (track 'Amsterdam metro Rokin - Centraal' has: Rokin, Centraal)"),
    (api.solve_folder, {"track": TRACK, "train": TRAIN, "time": 80.0, "fig_format": "gif"},
     "arguments: fig_format: 'gif' is not a figure format; use one of png, svg, pdf",
     "command line: --format: 'gif' is not a figure format; use one of png, svg, pdf"),
    (api.solve_folder, {"train": TRAIN, "time": 80.0}, "arguments: track/train: give a study file, or both track "
     "and train", "command line: --track/--train: give a study file, or both --track and --train"),
    (api.pareto_folder, {"count": 1}, "arguments: count: must be at least 2 and at most 10000, not 1",
     "command line: --count: must be at least 2 and at most 10000, not 1"),
    (api.pareto_folder, {"track": TRACK, "train": TRAIN, "dask": "nope"},
     "arguments: dask: expected a scheduler address tcp://host:port, got 'nope'",
     "command line: --dask: expected a scheduler address tcp://host:port, got 'nope'"),
    (api.compare_folder, {"supplement": -5}, "arguments: supplement: must be at least 0.0 and at most 200.0, not -5",
     "command line: --supplement: must be at least 0.0 and at most 200.0, not -5"),
    (api.journey_folder, {"train": TRAIN, "track": TRACK, "time": 80.0, "stops": "Rokin,Nope"},
     "arguments: stops[1]: unknown stop 'Nope' (track 'Amsterdam metro Rokin - Centraal' has: Rokin, Centraal)",
     "command line: --stops[1]: unknown stop 'Nope' (track 'Amsterdam metro Rokin - Centraal' has: Rokin, Centraal)"),
    (api.check_folder, {"result_dir": "nowhere", "time": -1}, "arguments: time: must be more than 0.0, not -1",
     "command line: --time: must be more than 0.0, not -1"),
    (api.export_folder, {"result_dir": "nowhere", "every": "2x"},
     "arguments: every: expected a step such as '1s' (seconds) or '10m' (metres), not '2x'",
     "command line: --every: expected a step such as '1s' (seconds) or '10m' (metres), not '2x'"),
    (api.run_folder, {"study": ROOT / "studies/default.yaml", "workers": 0},
     "arguments: workers: must be at least 1 and at most 256, not 0",
     "command line: --workers: must be at least 1 and at most 256, not 0"),
]


@pytest.mark.parametrize("function, kwargs, python, command_line", FOLDER_BAD,
                         ids=[f"{f.__name__}-{'-'.join(k)}" for f, k, _, _ in FOLDER_BAD])
def test_a_command_function_names_the_argument_as_python_spells_it(function, kwargs, python, command_line, tmp_path):
    if "out" in inspect.signature(function).parameters:  # a folder made before a refusal is made here
        kwargs = {**kwargs, "out": tmp_path / "out"}
    with pytest.raises(api.InputError) as caught:
        function(**kwargs)
    assert str(caught.value) == python
    with api.command_line(), pytest.raises(api.InputError) as caught:  # as ecostudy calls it: its options
        function(**kwargs)
    assert str(caught.value) == command_line


def test_the_stops_are_named_as_the_arguments(case):
    for make in (lambda: api.solve(*case, running_time=80.0, to_stop="Nowhere"),
                 lambda: api.pareto(*case, from_stop="Nowhere", count=3),
                 lambda: api.replanner(*case, running_time=80.0, from_stop="Nowhere")):
        with pytest.raises(api.InputError, match=r"^arguments: (from|to)_stop: unknown stop 'Nowhere' \(track "):
            make()
    assert api.solve_folder.__name__ == "solve_folder" and "time" in inspect.signature(api.solve_folder).parameters


@pytest.mark.flagged_on_purpose  # K = 10: the run misses its stop when re-simulated
def test_a_solve_folder_that_check_found_not_ok_loads_as_not_ok(tmp_path):
    """`api.load` read summary.json alone: a K = 10 run 3 m short of its stop whose summary.json was
    rewritten to ok (its verification too, consistent with itself, as a careful edit by hand would)
    loaded as ok beside the check.json whose re-simulation flags it. The folder's check now counts;
    check itself refuses the edited verification (not its re-simulation's numbers), and api.load a
    summary whose counts still say the run is flagged."""
    import json

    folder = tmp_path / "run"
    from .conftest import STUDIES
    report = api.solve_folder(STUDIES / "default.yaml", points=10, plot=False, out=folder)
    assert not report.status.ok
    checked = api.check_folder(folder)
    assert not checked.ok and json.loads((folder / "check.json").read_text())["run_status"].startswith("flagged")
    summary = json.loads((folder / "summary.json").read_text())
    zero = {k: 0.0 for k in ("arrival_time_error_s", "stop_error_m", "energy_error_pct", "net_energy_error_pct")}
    summary.update(status="ok", not_ok=[], verification={**summary["verification"], **zero, "passed": True,
                                                          "simulated_running_time_s": summary["running_time_s"]})
    (folder / "summary.json").write_text(json.dumps(summary))  # its counts left saying 1 flagged, as a hasty edit would
    with pytest.raises(api.InputError, match=r"summary.json: cases: \{'total': 1, 'ok': 0, 'flagged': 1, 'failed': 0\}, "
                                             "but the run's status is ok: an edited file"):
        api.load(folder)  # the counts contradict the status
    summary["cases"] = {"total": 1, "ok": 1, "flagged": 0, "failed": 0}
    (folder / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(api.InputError, match="summary.json: verification.arrival_time_error_s: 0.0, but the saved "
                                             "profile re-simulated gives 0.4"):
        api.check_folder(folder)
    loaded = api.load(folder)
    assert loaded.status.kind == "flagged" and str(loaded.cases) == "1 case: 0 ok, 1 flagged, 0 failed", loaded
    assert loaded.not_ok[-1].case == "the run, re-judged by check.json"
