"""An output folder is checked, before anything is computed, for the figures a command will write
in the format ``--format`` names (the study engine's commands too: the files of their ``draw``): a
folder in the place of ``speed.svg`` refuses ``--format svg`` in one line (exit 2, nothing
written), as one in the place of ``speed.png`` refuses png. A folder named as the same figure in
another format is no figure of an earlier run: it stays, and the run goes on (calibrate and
validate: tests/test_calibration.py)."""
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import STUDIES, TRACKS, TRAINS

METRO, AMS, LINE4 = (TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml",
                     TRACKS / "metro_line_4stops.yaml")

COMMANDS = {  # each command, and the figures it draws by stem
    "solve": (["solve", STUDIES / "default.yaml", "--points", 50], ("speed", "energy")),
    "pareto": (["pareto", "--track", AMS, "--train", METRO, "--count", 2, "--points", 50, "--workers", 1],
               ("pareto", "pareto_profiles")),
    "journey": (["journey", "--track", LINE4, "--train", METRO, "--supplement", 10, "--points", 50], ("journey",)),
    "compare": (["compare", STUDIES / "default.yaml", "--points", 50, "--workers", 1], ("compare",)),
    "network": (["network", STUDIES / "network_metro_2trains.yaml", "--workers", 1], ("network", "network_supply")),
    "simulate": (["simulate", STUDIES / "yazhemsky2017_closed_loop.yaml", "--workers", 1], ("solve_times",)),
    "run --kind simulate": (["run", STUDIES / "yazhemsky2017_closed_loop.yaml", "--kind", "simulate", "--workers", 1],
                            ("bands",)),
    "run --kind pareto": (["run", STUDIES / "default.yaml", "--kind", "pareto", "--workers", 1], ("pareto",)),
    "heavyhaul": (["heavyhaul", STUDIES / "heavyhaul_fence.yaml", "--workers", 1], ("tracking",)),
}



def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def refused_naming(result, path):
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert lines == [f"error: {path}: is a folder where an output file goes"], result.output
    assert "Traceback" not in result.output


@pytest.mark.parametrize("fmt", ["svg", "pdf"])
@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_folder_where_a_figure_of_the_format_goes_is_refused_before_computing(tmp_path, command, fmt):
    args, stems = COMMANDS[command]
    for stem in stems:
        out = tmp_path / stem
        (out / f"{stem}.{fmt}").mkdir(parents=True)
        refused_naming(run(*args, "--format", fmt, "--out", out, "--no-progress"), out / f"{stem}.{fmt}")
        assert sorted(p.name for p in out.iterdir()) == [f"{stem}.{fmt}"]  # nothing computed, nothing written


def test_a_folder_named_as_a_figure_in_another_format_stays_and_the_run_goes_on(tmp_path):
    out = tmp_path / "o"
    (out / "speed.svg").mkdir(parents=True)
    r = run(*COMMANDS["solve"][0], "--out", out)  # png
    assert r.exit_code == 0, r.output
    assert (out / "speed.png").is_file() and (out / "speed.svg").is_dir()
    r = run(*COMMANDS["solve"][0], "--out", out, "--format", "pdf", "--no-plot")
    assert r.exit_code == 0, r.output  # --no-plot: no figure goes there, the earlier png removed
    assert not (out / "speed.png").exists() and (out / "speed.svg").is_dir()


@pytest.mark.parametrize("command", ["solve", "compare", "journey"])
def test_a_folder_where_the_report_goes_is_refused_before_computing(tmp_path, command):
    """``report.html`` and ``summary.json``, written into every output folder, are checked with the
    command's own files."""
    for name in ("report.html", "summary.json"):
        out = tmp_path / name.split(".")[0]
        (out / name).mkdir(parents=True)
        refused_naming(run(*COMMANDS[command][0], "--out", out, "--no-progress"), out / name)


def test_solve_with_driver_advice_checks_where_its_advice_goes(tmp_path):
    (tmp_path / "advice.csv").mkdir()
    refused_naming(run(*COMMANDS["solve"][0], "--das", "round", "--out", tmp_path), tmp_path / "advice.csv")
