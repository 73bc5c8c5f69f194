"""--quiet, --verbose and --log-file: messages through the standard ``logging`` module, progress on
stderr only (never with --quiet), results alone on stdout (piped: tests/test_cli_output.py)."""
import os
import pty
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import STUDIES, TRACKS, TRAINS

ECOSTUDY = str(Path(sys.executable).parent / "ecostudy")
SOLVE = ["solve", str(STUDIES / "default.yaml"), "--points", "100", "--no-plot"]


def test_log_file_gets_the_messages_and_the_errors(tmp_path):
    log = tmp_path / "run.log"
    r = CliRunner().invoke(app, ["--log-file", str(log), *SOLVE, "--out", str(tmp_path / "s")])
    assert r.exit_code == 0, r.output
    assert f"INFO ecostudy: solve: ok, written to {tmp_path / 's'}" in log.read_text()
    bad = CliRunner().invoke(app, ["--log-file", str(log), *SOLVE, "--points", "-3"])
    assert bad.exit_code == 2
    assert "ERROR ecostudy: command line: --points: must be at least 10" in log.read_text()


def test_verbose_logs_every_case_and_the_command_line(tmp_path):
    log = tmp_path / "run.log"
    study = tmp_path / "study.yaml"
    study.write_text(f"name: v\ntrack: {TRACKS / 'amsterdam_rokin_centraal.yaml'}\ntrain: "
                     f"{TRAINS / 'amsterdam_metro.yaml'}\npoints: 100\nsweep: {{running_time_s: [76, 80]}}\n")
    r = CliRunner().invoke(app, ["--verbose", "--log-file", str(log), "run", str(study), "--out", str(tmp_path / "r")])
    assert r.exit_code == 0, r.output
    text = log.read_text()
    assert "DEBUG ecostudy: cases: 2 of 2 done (0 failed)" in text and "DEBUG ecostudy: ecostudy " in text


def test_quiet_prints_the_results_and_nothing_else(tmp_path):
    quiet = CliRunner().invoke(app, ["--quiet", *SOLVE, "--out", str(tmp_path / "q")])
    assert quiet.exit_code == 0, quiet.output
    assert "written to" not in quiet.output  # information (and progress) off
    assert "traction energy" in quiet.output
    bad = CliRunner().invoke(app, ["--quiet", *SOLVE, "--points", "-3"])
    assert bad.exit_code == 2 and bad.output.startswith("error: command line: --points")  # errors stay


def test_the_help_says_quiet_keeps_the_results_on_stdout():
    """--help said `No progress, errors only.`, but `-q solve` prints its report on stdout (as the
    README says): the help says what -q quiets."""
    text = " ".join(CliRunner().invoke(app, ["--help"]).output.split())
    assert "-q, --quiet Quiet stderr: no progress bar and no messages but errors and the reason a result is not ok; " \
           "the results still print on stdout." in text, text


def test_a_front_reports_its_progress_point_by_point(tmp_path):
    from ecostudy import api
    calls = []
    api.pareto_folder(track=TRACKS / "amsterdam_rokin_centraal.yaml", train=TRAINS / "amsterdam_metro.yaml", count=3,
                      points=100, workers=2, out=tmp_path / "p", plot=False, progress=lambda *a: calls.append(a))
    assert calls[0] == (1, 0, 2, 3) and calls[-1] == (3, 0, 0, 3)  # the all-out run, then a chain per worker
    log = tmp_path / "run.log"
    r = CliRunner().invoke(app, ["--verbose", "--log-file", str(log), "pareto", "--track",
                                 str(TRACKS / "amsterdam_rokin_centraal.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--count", "3", "--points", "100", "--no-plot",
                                 "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    assert [line.split("ecostudy: ")[1] for line in log.read_text().splitlines() if "points:" in line] == [
        f"points: {n} of 3 done (0 failed)" for n in (1, 2, 3)]


def test_a_journey_reports_each_front_and_each_run(tmp_path):
    from ecostudy import api
    calls = []
    report = api.journey_folder(TRAINS / "amsterdam_metro.yaml", TRACKS / "metro_line_4stops.yaml",
                                stops="Noord,Station", supplement=10, points=100, out=tmp_path, plot=False,
                                progress=lambda *a: calls.append(a))
    assert len(report.table) == 4  # one segment, four splits
    assert calls == [(n, 0, 5 - n, 5) for n in range(1, 6)]  # the segment's front, then the four runs


def on_a_terminal(args, cwd):
    """(exit status, stdout, stderr) of the command run with its stderr on a terminal (a pty)."""
    master, slave = pty.openpty()
    proc = subprocess.Popen([ECOSTUDY, *map(str, args)], cwd=cwd, stdout=subprocess.PIPE, stderr=slave)
    os.close(slave)
    seen = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the command closed the terminal
            break
        if not data:
            break
        seen.append(data)
    out = proc.stdout.read()
    proc.wait(timeout=600)
    os.close(master)
    return proc.returncode, out.decode(), b"".join(seen).decode(errors="replace")


@pytest.mark.slow  # two commands started afresh: 25 s
def test_the_bar_is_drawn_on_a_terminal_and_never_with_quiet(tmp_path):
    study = tmp_path / "study.yaml"
    study.write_text(f"name: t\ntrack: {TRACKS / 'amsterdam_rokin_centraal.yaml'}\ntrain: "
                     f"{TRAINS / 'amsterdam_metro.yaml'}\npoints: 100\nsweep: {{running_time_s: [76, 80]}}\n")
    code, out, err = on_a_terminal(["run", study, "--out", "a"], tmp_path)
    assert code == 0 and "cases" in err and "━" in err and "2/2" in err, err  # the bar, on stderr
    assert "━" not in out and "\r" not in out
    code, out, err = on_a_terminal(["--quiet", "run", study, "--out", "b"], tmp_path)
    assert code == 0 and "━" not in err and "2/2" not in err and "written to" not in err, err
    assert "2 cases: 0 already stored, 2 computed now" in out


@pytest.mark.slow  # six strategies solved and simulated: 28 s on a busy machine
def test_compare_reports_each_strategy(tmp_path):
    from ecostudy import api
    calls = []
    report = api.compare_folder(track=TRACKS / "amsterdam_rokin_centraal.yaml", train=TRAINS / "amsterdam_metro.yaml",
                                time=80.0, points=100, out=tmp_path, plot=False, progress=lambda *a: calls.append(a))
    assert len(report.table) == 6 and calls == [(n, 0, 6 - n, 6) for n in range(1, 7)]


@pytest.mark.slow  # two trains, two strategies, legs solved and scored: seconds on a quiet machine
def test_a_network_study_reports_each_strategy(tmp_path):
    from ecostudy import api

    from .test_network import tiny_network_study
    study = tiny_network_study(tmp_path, ["independent", "triggering"])
    calls, lines = [], []
    api.network_folder(study, plot=False, workers=1, note=lines.append, progress=lambda *a: calls.append(a))
    assert calls == [(1, 0, 1, 2), (2, 0, 0, 2)]
    assert [line.split()[0] for line in lines[1:]] == ["independent", "triggering"]


def test_the_run_help_says_its_figure_options_draw_nothing_for_the_kind_run():
    """`run` takes --no-plot, --format and --dpi (for --kind pareto, compare, ...), but the kind run
    writes no figure: its help now says so."""
    text = " ".join(CliRunner().invoke(app, ["run", "--help"]).output.split())
    assert "--no-plot, --format and --dpi apply to the figures of --kind pareto, compare, network, heavyhaul and " \
           "simulate: the kind run draws none." in text, text
