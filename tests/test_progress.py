"""Progress of the long single commands (solve with driver advice, calibrate, validate): the stages
and steps they tell a watcher (:mod:`ecostudy.core.progress`), and the bar on stderr when stderr
is a terminal (a pty), never on stdout, never with --quiet or when stderr is piped."""
import re
import subprocess

import pytest

from ecostudy import api
from ecostudy.calibration.generate import generate_log, true_train
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.logfile import write_log

from .conftest import STUDIES, TRACKS, TRAINS
from .test_cli_logging import ECOSTUDY, on_a_terminal

TRAIN, TRACK = TRAINS / "regional_alstom.yaml", TRACKS / "calibration_line.yaml"
SOLVE = ["solve", STUDIES / "default.yaml", "--points", "100", "--no-plot"]


class Recorder:
    """A watcher that keeps what it is told."""

    def __init__(self):
        self.events = []

    def stage(self, name, total=None, unit=""):
        self.events.append(("stage", name, total, unit))

    def step(self, done, note=""):
        self.events.append(("step", done, note))

    def stages(self):
        return [e[1] for e in self.events if e[0] == "stage"]

    def steps(self, name):
        """(done, note) of the steps told during the stage ``name``."""
        at = [i for i, e in enumerate(self.events) if e[:2] == ("stage", name)][0]
        following = self.events[at + 1:]
        end = next((i for i, e in enumerate(following) if e[0] == "stage"), len(following))
        return [e[1:] for e in following[:end]]


@pytest.fixture(scope="module")
def log_files(tmp_path_factory):
    """Two logged runs there and back of a train 3 % heavier than its file says."""
    folder = tmp_path_factory.mktemp("logs")
    track, train = load_track(TRACK), load_train(TRAIN)
    truth = true_train(train, mass=1.03, davis=(1.1, 0.9, 1.05), efficiency=0.98)
    header = {"track": str(TRACK), "train": str(TRAIN), "source": "generated"}
    for seed, name, stops in ((1, "there", ["West", "Middle", "East"]), (2, "back", ["East", "Middle", "West"])):
        write_log(folder / f"{name}.csv", header, generate_log(track, truth, stops, truth, seed=seed)[0])
    return folder / "there.csv", folder / "back.csv"


def test_solve_with_driver_advice_tells_each_stage(tmp_path):
    seen = Recorder()
    report = api.solve_folder(STUDIES / "default.yaml", points=100, out=tmp_path, plot=False, das="phases",
                              progress=seen)
    assert report.status.kind == "ok"
    assert seen.stages() == ["energy optimum, verified", "DAS phases NLP (every mode)", "DAS phases NLP (modes driven)",
                             "DAS phases advice re-simulated", "figures and files"]
    assert all(e[2] is None for e in seen.events if e[0] == "stage")  # one solver call each: not counted


def test_the_minlp_search_counts_the_seconds_of_its_time_limit(tmp_path):
    seen = Recorder()
    api.solve_folder(STUDIES / "default.yaml", points=100, out=tmp_path, plot=False, das="minlp", das_time_limit=3,
                     progress=seen)
    assert ("stage", "MINLP search", 3.0, "s") in seen.events
    ticks = seen.steps("MINLP search")
    seconds = [done for done, _ in ticks]
    assert len(ticks) >= 2 and seconds == sorted(seconds) and 0 <= seconds[0] and seconds[-1] <= 3.0
    # what the search has found, then how many OA master problems it solved ("no pattern yet, OA iteration 1")
    assert all(re.fullmatch(r"(no pattern yet|best \d+\.\d{3} kWh)(, OA iteration \d+)?", note) for _, note in ticks)
    assert seen.stages()[-2:] == ["DAS minlp advice re-simulated", "figures and files"]


@pytest.fixture(scope="module")
def five_log_files(tmp_path_factory, log_files):
    """The two logs and three more of the same train: the fewest a bootstrap over logs runs on."""
    folder = log_files[0].parent
    track, train = load_track(TRACK), load_train(TRAIN)
    truth = true_train(train, mass=1.03, davis=(1.1, 0.9, 1.05), efficiency=0.98)
    header = {"track": str(TRACK), "train": str(TRAIN), "source": "generated"}
    for seed, name, stops in ((3, "there3", ["West", "Middle", "East"]), (4, "back4", ["East", "Middle", "West"]),
                              (5, "there5", ["West", "Middle", "East"])):
        write_log(folder / f"{name}.csv", header, generate_log(track, truth, stops, truth, seed=seed)[0])
    return [*log_files, folder / "there3.csv", folder / "back4.csv", folder / "there5.csv"]


def test_calibrate_tells_each_bootstrap_draw(tmp_path, five_log_files):
    seen = Recorder()
    api.calibrate_folder(five_log_files, out=tmp_path, bootstrap=4, plot=False, progress=seen)
    assert seen.stages() == ["least-squares fit, identifiability", "bootstrap over logs", "figures and report"]
    assert ("stage", "bootstrap over logs", 4, "draws") in seen.events
    assert seen.steps("bootstrap over logs") == [(n, "") for n in (1, 2, 3, 4)]


def test_calibrate_on_two_logs_runs_no_bootstrap(tmp_path, log_files):
    """Two logs give no bootstrap interval (MIN_BOOTSTRAP_LOGS): the draws are not run, not shown."""
    seen = Recorder()
    api.calibrate_folder(list(log_files), out=tmp_path, bootstrap=4, plot=False, progress=seen)
    assert seen.stages() == ["least-squares fit, identifiability", "figures and report"]


@pytest.mark.slow  # eight optimal runs of 500 points
def test_calibrate_tells_each_optimal_run_of_the_savings(tmp_path, log_files):
    seen = Recorder()
    api.calibrate_folder(list(log_files), out=tmp_path, bootstrap=0, savings=1, plot=False, progress=seen)
    assert seen.stages() == ["least-squares fit, identifiability", "savings there", "savings back",
                             "figures and report"]
    # two runs per log, each: the optimum of the calibrated train, then one parameter draw's
    assert seen.steps("savings there") == [(0, "run 0"), (1, "run 0"), (2, "run 0"),
                                           (2, "run 1"), (3, "run 1"), (4, "run 1")]


def test_validate_tells_each_run(tmp_path, log_files):
    seen = Recorder()
    api.validate_folder(log_files[0], out=tmp_path, plot=False, progress=seen)
    assert ("stage", "replaying there", 2, "runs") in seen.events
    assert seen.steps("replaying there") == [(0, "run 0"), (1, "run 1"), (2, "")]


def piped(args, cwd):
    """(exit status, stdout, stderr) with both piped (no terminal)."""
    done = subprocess.run([ECOSTUDY, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=600)
    return done.returncode, done.stdout, done.stderr


def bar_only_on_a_terminal(args, cwd, shown):
    """The command's bar on a terminal shows each of ``shown`` on stderr and nothing on stdout;
    with --quiet, and with stderr piped, there is no bar."""
    code, out, err = on_a_terminal([*args, "--out", "a"], cwd)
    assert code in (0, 1) and "━" in err and all(text in err for text in shown), err
    assert "━" not in out and "\r" not in out
    code, out, err = on_a_terminal(["--quiet", *args, "--out", "b"], cwd)
    assert code in (0, 1) and "━" not in err and not any(text in err for text in shown), err
    assert "outputs" in out
    code, out, err = piped([*args, "--out", "c"], cwd)
    assert code in (0, 1) and "━" not in err + out and "\r" not in err + out and "written to" in err, err


@pytest.mark.slow  # three solves with driver advice, each a fresh process: minutes at load 14
def test_solve_shows_its_stages_on_a_terminal(tmp_path):
    bar_only_on_a_terminal([*SOLVE, "--das", "phases"], tmp_path, ["solve: DAS phases NLP", "solve: figures"])


@pytest.mark.slow  # three fresh processes, each a MINLP search of 3 s with the phases NLPs around it
def test_the_minlp_search_shows_its_time_limit_on_a_terminal(tmp_path):
    bar_only_on_a_terminal([*SOLVE, "--das", "minlp", "--das-time-limit", "3"], tmp_path,
                           ["solve: MINLP search", "/3 s"])


@pytest.mark.slow  # three calibrations in fresh processes: 124 s at load 14
def test_calibrate_shows_its_draws_on_a_terminal(tmp_path, five_log_files):
    bar_only_on_a_terminal(["calibrate", *five_log_files, "--bootstrap", "5", "--no-plot"], tmp_path,
                           ["calibrate: bootstrap over logs", "5/5 draws"])


@pytest.mark.slow  # three validations in fresh processes: 150 s at load 14
def test_validate_shows_its_runs_on_a_terminal(tmp_path, log_files):
    bar_only_on_a_terminal(["validate", log_files[0], "--no-plot"], tmp_path, ["validate: replaying there", "2/2 runs"])


@pytest.mark.parametrize("command", ["solve", "pareto", "compare", "journey", "run", "network", "simulate", "heavyhaul",
                                     "calibrate", "validate"])
def test_every_command_with_a_progress_bar_takes_no_progress(command):
    code, out, _ = piped([command, "--help"], ".")
    assert code == 0 and "--no-progress" in out, out


def test_no_progress_keeps_the_bar_off_a_terminal(tmp_path, log_files):
    """validate's bar shows its runs on a terminal (above); with --no-progress it does not, and the
    command's own lines still do."""
    code, out, err = on_a_terminal(["validate", log_files[0], "--no-plot", "--no-progress", "--out", "a"], tmp_path)
    assert code in (0, 1) and "━" not in err and "2/2 runs" not in err and "written to" in err, err
    assert "outputs" in out


def test_validate_and_calibrate_write_their_figure_in_the_format_asked(tmp_path, log_files):
    api.validate_folder(log_files[0], out=tmp_path / "v", fig_format="svg", dpi=50)
    assert (tmp_path / "v" / "validate.svg").read_bytes().startswith(b"<?xml")
    assert "validate.svg" in api.load(tmp_path / "v").summary["files"]
    api.validate_folder(log_files[0], out=tmp_path / "v", dpi=50)  # again as png: the svg is the earlier run's
    assert (tmp_path / "v" / "validate.png").is_file() and not (tmp_path / "v" / "validate.svg").exists()
    api.calibrate_folder(list(log_files), out=tmp_path / "c", bootstrap=0, fig_format="pdf")
    assert (tmp_path / "c" / "residuals.pdf").read_bytes().startswith(b"%PDF")
