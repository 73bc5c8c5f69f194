"""Refusals that named no file or field, or gave a false reason, and a documented timetable form that
was refused: each now one line naming where the request came from (exit status 2)."""
from .conftest import TRACKS, TRAINS, write_yaml
from .test_bad_input_studies import refused, run

METRO, AMS, LINE4 = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml", TRACKS / "metro_line_4stops.yaml"
JOURNEY = ["journey", "--track", LINE4, "--train", METRO, "--points", 100, "--no-plot"]


def test_a_journey_total_time_no_run_keeps_names_the_option(tmp_path):
    refused(run(*JOURNEY, "--time", 100, "--out", tmp_path / "o"), "command line: --time: infeasible: the total time")
    refused(run(*JOURNEY, "--time", 1e9, "--out", tmp_path / "o"), "command line: --time:", "would crawl")


def test_a_timetable_of_one_supplement_is_the_journey_s_supplement(tmp_path):
    """It was refused as 'a timetable with stop times replaces --stops, --time and --supplement'."""
    timetable = write_yaml(tmp_path / "tt.yaml", {"name": "ten", "supplement_percent": 10})
    result = run(*JOURNEY, "--timetable", timetable, "--out", tmp_path / "a")
    assert result.exit_code == 0, result.output
    given = run(*JOURNEY, "--supplement", 10, "--out", tmp_path / "b")
    assert (tmp_path / "a" / "journey_totals.csv").read_text() == (tmp_path / "b" / "journey_totals.csv").read_text()
    refused(run(*JOURNEY, "--timetable", timetable, "--supplement", 5, "--out", tmp_path / "c"),
            "--timetable", "gives the supplement (10 %): no --time or --supplement beside it")


def test_windows_a_coarse_grid_cannot_keep_name_the_field_and_the_grid(tmp_path):
    """'no run keeps the timing windows' named no file, and a finer grid keeps them."""
    study = write_yaml(tmp_path / "w.yaml", {"name": "w", "track": str(AMS), "train": str(METRO), "points": 50,
                                            "running_time_s": 80, "output": str(tmp_path / "out"),
                                            "windows": [{"position_m": 600, "latest_s": 39.5, "max_speed_kmh": 70}]})
    refused(run("solve", study, "--no-plot"), f"{study}: windows: infeasible on this grid of 50 nodes",
            "the fastest envelope does: try more points")
    assert run("solve", study, "--no-plot", "-K", 200).exit_code == 0


def test_compare_refuses_a_running_time_under_the_fastest_envelope_before_computing(tmp_path):
    refused(run("compare", "--track", AMS, "--train", METRO, "--time", 30, "-K", 100, "--workers", 1,
                "--out", tmp_path / "out"), "command line: --time: infeasible: the fastest possible run takes about")
    assert not (tmp_path / "out").exists()


def test_a_compared_strategy_short_of_its_stop_reads_no_arrival_saving_or_gap(tmp_path):
    """A 3 km/h metre at 500 m: the rules of thumb stall about 600 m short. They read '97.8 % saving',
    'arrived 120.85 s early', and the folder's status joined their reasons naming none of them."""
    import json

    import pandas as pd
    track = tmp_path / "blip.yaml"
    track.write_text(AMS.read_text().replace("  - {position_m: 950, speed_kmh: 60}",
                                             "  - {position_m: 500, speed_kmh: 3}\n  - {position_m: 501, speed_kmh: 80}\n"
                                             "  - {position_m: 950, speed_kmh: 60}"))
    result = run("compare", "--track", track, "--train", METRO, "--supplement", 10, "-K", 300, "--workers", 1,
                 "--no-plot", "--out", tmp_path / "out")
    assert result.exit_code == 1, result.output
    table = pd.read_csv(tmp_path / "out" / "compare.csv")
    short = table[table["stop_error_m"] < -1.0]
    assert len(short) >= 1, table.to_string()
    assert short[["arrival_error_s", "saving_vs_all_out_pct", "gap_to_optimum_pct"]].isna().all().all()
    assert not short["status"].str.contains("early|late").any(), table.to_string()
    status = json.loads((tmp_path / "out" / "summary.json").read_text())["status"]
    for name in short["strategy"]:
        assert f"{name}: stopped" in status, status


def test_a_time_a_hair_under_coasting_s_fastest_reads_with_the_digits_that_tell_them_apart():
    """'eco-drive coasting cannot meet 71.8 s' for 71.75 s asked, while the run without coasting is faster."""
    import pytest

    from ecostudy.core import kinematics
    from ecostudy.core.errors import InfeasibleError
    from ecostudy.core.units import apart
    from ecostudy.heuristics.ecodrive import drive, eco_coasting
    from ecostudy.io.loaders import load_track, load_train
    from ecostudy.ocp.problem import prepare
    case = prepare(load_track(AMS), load_train(METRO), "Rokin", "Centraal", 100)
    last = len(case.nodes) - 1
    fastest = drive(case, kinematics.coasting_profile(case.segment, case.train, case.nodes, case.limits,
                                                      case.envelope, last))[1].arrival_time
    asked = fastest - 0.04
    with pytest.raises(InfeasibleError) as caught:
        eco_coasting(case, asked)
    message, (a, b) = str(caught.value), apart(asked, fastest)
    assert a != b and f"cannot meet {a} s: without coasting it arrives at {b} s" in message, message


def test_compare_refuses_a_study_whose_base_case_has_no_running_time_or_supplement(tmp_path):
    """objective 'time' (or a sweep of supplements) left the base case without a time: compare drove
    the strategies to the energy optimum's own 22-million-second crawl and printed the all-out row ok
    beside an arrival error of -22025546.969 s (exit 1)."""
    base = {"name": "cb", "track": str(AMS), "train": str(METRO), "from": "Rokin", "to": "Centraal", "points": 150,
            "output": str(tmp_path / "out")}
    for name, extra in (("objtime", {"objective": "time"}), ("sweep", {"sweep": {"supplement_percent": [5, 10]}})):
        study = write_yaml(tmp_path / f"{name}.yaml", {**base, **extra})
        for args in (("compare", study, "--workers", 1, "--no-plot"), ("run", study, "--kind", "compare", "--no-plot")):
            refused(run(*args), f"{study}: running_time_s: compare needs a running time or a supplement for its "
                                "base case")
    assert not (tmp_path / "out_compare").exists()


def test_compare_names_its_stop_options_as_the_command_line_spells_them(tmp_path):
    """It read 'command line: from: unknown stop' (the study file's field) for the option --from."""
    refused(run("compare", "--track", AMS, "--train", METRO, "--from", "Foo", "--time", 80, "--out", tmp_path / "o"),
            "command line: --from: unknown stop 'Foo'")
    refused(run("compare", "--track", AMS, "--train", METRO, "--to", "Rokin", "--time", 80, "--out", tmp_path / "o"),
            "command line: --to: must differ from '--from'")


def test_the_crawl_guard_names_the_time_it_is_measured_against(tmp_path):
    """At K = 100 --time 1e308 said 'the fastest possible run's 71.6 s' and --time 10 'the fastest
    possible run takes 71.7 s': the kinematic envelope's time (no NLP) and the all-out NLP's. The
    first is named as the envelope's, in one wording with the journey's (ocp.problem.crawling)."""
    solve = ("solve", "--track", AMS, "--train", METRO, "-K", 100, "--no-plot", "--out", tmp_path / "o")
    refused(run(*solve, "--time", 1e308), "command line: --time: 1e+308 s is over 5 times the fastest possible run's "
            "71.6 s (kinematic envelope): the train would crawl")
    refused(run(*solve, "--time", 10), "command line: --time: infeasible: the fastest possible run takes 71.7 s")
