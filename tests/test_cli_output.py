"""What a user sees on stdout: results only, no progress bar or carriage return when piped; --version."""
import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from ecostudy import __version__
from ecostudy.cli import app

from .conftest import ROOT, TRACKS, TRAINS

ECOSTUDY = [str(Path(sys.executable).parent / "ecostudy")]


def piped(*args, tmp_path):
    """The command as `ecostudy ... | cat` runs it: stdout a pipe, stderr a pipe too."""
    return subprocess.run([*ECOSTUDY, *map(str, args)], cwd=tmp_path, capture_output=True, text=True, timeout=600)


def test_version():
    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.output.strip() == f"ecostudy {__version__}"


def test_help_lists_every_command_without_cutting_lines():
    out = CliRunner().invoke(app, ["--help"]).output
    commands = out.split("Commands:")[1]
    assert "..." not in commands, commands
    for name in ("solve", "pareto", "compare", "journey", "run", "network", "simulate", "heavyhaul", "check"):
        assert f"  {name} " in commands


def test_piped_solve_and_pareto_print_no_progress_on_stdout(tmp_path):
    solve = piped("solve", ROOT / "studies" / "default.yaml", "--points", 200, "--no-plot", "--out", "s",
                  tmp_path=tmp_path)
    assert solve.returncode == 0, solve.stderr
    pareto = piped("pareto", "--track", TRACKS / "amsterdam_rokin_centraal.yaml", "--train",
                   TRAINS / "amsterdam_metro.yaml", "--count", 3, "--points", 200, "--no-plot", "--out", "p",
                   tmp_path=tmp_path)
    assert pareto.returncode == 0, pareto.stderr
    for result, kind, folder in ((solve, "solve", "s"), (pareto, "pareto", "p")):
        assert result.stdout.strip(), "the results are printed on stdout"
        # the folder, resolved against the working directory, printed last on stderr
        assert result.stderr.strip().splitlines()[-1] == f"{kind}: ok, written to {tmp_path / folder}"
        assert "\r" not in result.stdout and "\x1b[" not in result.stdout, result.stdout
        assert "━" not in result.stdout  # rich's bar
