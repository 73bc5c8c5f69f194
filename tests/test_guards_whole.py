"""Whole-command estimates of ``journey`` and ``compare`` (``studies/sizes.check_journey``,
``check_compare``): refused before computing above the 2 h one command may take or half the
memory, with the estimate in one line, unless ``--force``."""
import pytest

from ecostudy.core.budget import forced, machine_memory
from ecostudy.core.errors import InputError
from ecostudy.studies.sizes import check_compare, check_journey

from .conftest import DATA, TRACKS, TRAINS, write_yaml
from .test_bad_input import one_line, run

METRO, LINE = TRAINS / "amsterdam_metro.yaml", TRACKS / "metro_line_4stops.yaml"


def test_a_journey_too_big_for_one_command_is_refused_with_its_estimate(tmp_path):
    """Three segments at K = 100 000: 45 front runs, the whole-journey NLP of 300 000 nodes and
    12 split runs, one worker."""
    r = run("journey", "--train", METRO, "--track", LINE, "--supplement", 10, "--points", 100000, "--workers", 1,
            "--out", tmp_path / "out", "--no-plot")
    one_line(r, "command line: study: a journey of 3 segments at K = 100000: 58 runs, an estimated",
             "h of computing", "above the 2 h one command may take", "--force")
    assert not (tmp_path / "out").exists()


def test_a_journey_within_the_budget_passes():
    check_journey("command line", [500] * 19, workers=1)  # the 20-stop regional line at the default K
    check_journey("timetable.json", [2000] * 3, workers=2, splits=6, whole=2)  # a windowed timetable


def test_a_comparison_too_big_is_refused_and_passes_when_forced():
    """The command's --points stops at 100 000 (refused in one line before this check); beyond it
    a comparison's five NLPs are estimated above the 2 h."""
    with pytest.raises(InputError, match=r"a comparison at K = 1000000: 3 runs, an estimated .* h of computing .*"
                                         r"above the 2 h one command may take; give --force"):
        check_compare("command line", 1000000)
    with forced():
        check_compare("command line", 1000000)


def test_a_comparison_within_the_budget_passes():
    check_compare("command line", 1000)
    check_compare("command line", 100000)  # the largest --points: about an hour


TTO = DATA / "ttobench"


@pytest.mark.parametrize("command", ["solve", "run", "pareto", "compare", "journey"])
def test_run_and_pareto_count_the_trains_tables_as_solve_does(tmp_path, command):
    """The VIRM6 train (force tables) on a TTOBench track at K = 60 000: `solve` refused it at 24.2 GB,
    while `run`, `pareto`, `compare` and `journey` left the tables out (4.5 GB) and computed. One
    estimate now: all refuse."""
    if (machine_memory() or 0) > 48e9:
        pytest.skip("this machine has more than 48 GB: a run at K = 60 000 (about 24.2 GB) fits in half of it, so "
                    "it is not refused here")
    track, train = TTO / "00_var_speed_limit_100.json", TTO / "NL_Intercity_VIRM6.json"
    study = write_yaml(tmp_path / "virm.yaml", {"name": "virm", "track": str(track), "train": str(train),
                                               "supplement_percent": 10, "points": 60000, "output": str(tmp_path / "out")})
    args = {"solve": ["solve", study, "--out", tmp_path / "out"], "run": ["run", study, "--workers", 1],
            "pareto": ["pareto", "--track", track, "--train", train, "-K", 60000, "--count", 4, "--workers", 1,
                       "--out", tmp_path / "out"],
            "compare": ["compare", "--track", track, "--train", train, "--supplement", 10, "-K", 60000, "--workers", 1,
                        "--out", tmp_path / "out"],
            "journey": ["journey", "--train", train, "--track", track, "--supplement", 10, "--points", 60000,
                        "--out", tmp_path / "out"]}[command]
    # a journey's 20 runs with the tables are refused for their time first (2.3 h), as they would be on any machine
    one_line(run(*args), "h of computing" if command == "journey" else "GB of memory, above half of this machine's",
             "--force")
    assert not (tmp_path / "out" / "results.sqlite").exists()


def test_a_closed_loop_study_counts_the_trains_tables_as_solve_does(tmp_path):
    """Two draws of the VIRM6 train at K = 20 000 (the most a closed-loop study takes), two workers:
    each run's process as solve's, 8.1 GB with the train's tables, so 16.9 GB in all, refused before
    the study's set-up solves anything; without the tables (1.5 GB a run) it computed."""
    if (machine_memory() or 0) > 33e9:
        pytest.skip("this machine has more than 33 GB: two runs at K = 20 000 (about 16.9 GB) fit in half of it")
    study = write_yaml(tmp_path / "loop.yaml", {
        "name": "loop_virm", "track": str(TTO / "00_var_speed_limit_100.json"),
        "train": str(TTO / "NL_Intercity_VIRM6.json"), "window_s": [0, 600], "points": 20000, "sample_time_s": 1,
        "controllers": [{"name": "plan_replayed", "kind": "open_loop", "settings": {"time": 1, "energy": 1}}],
        "draws": 2, "output": str(tmp_path / "out")})
    one_line(run("simulate", study, "--workers", 2, "--no-progress", "--no-plot"), "2 runs",
             "with 2 workers an estimated", "GB of memory, above half of this machine's", "--force")
    assert not (tmp_path / "out").exists()
