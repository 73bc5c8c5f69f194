"""Every command that writes an output folder writes its ``report.html``, and headless Chromium
renders it: every table with all its rows, every figure embedded (the checks of
``tests/test_html.py``, on a small real run of each command)."""
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.io.folder import load
from ecostudy.report.html import MAX_ROWS

from . import test_heavyhaul_study, test_network, test_simulate
from .conftest import ROOT, TRACKS, TRAINS, write_yaml
from .test_html import Page, check_page, chromium, needs_chromium

METRO = ["--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"), "--train", str(TRAINS / "amsterdam_metro.yaml")]


def run_study(folder):
    return write_yaml(folder / "sweep.yaml", {
        "name": "sweep", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
        "train": str(TRAINS / "amsterdam_metro.yaml"), "from": "Rokin", "to": "Centraal", "points": 150,
        "sweep": {"supplement_percent": [4, 12]}, "output": str(folder / "out")})


def example_logs(folder):
    subprocess.run([sys.executable, str(ROOT / "bench" / "bench_calibration.py"), "--example", str(folder)],
                   check=True, capture_output=True, timeout=600)
    return folder / "there.csv", folder / "back.csv"


def command(name, tmp_path):
    """The arguments of a small real run of command ``name`` writing into ``tmp_path / 'out'``."""
    out = ["--out", str(tmp_path / "out")]
    if name == "compare":
        return ["compare", *METRO, "--time", "80", "--points", "150", *out]
    if name == "journey":
        return ["journey", "--track", str(TRACKS / "metro_line_4stops.yaml"), "--train", str(TRAINS / "amsterdam_metro.yaml"),
                "--supplement", "10", "--points", "120", *out]
    if name == "run":
        return ["run", str(run_study(tmp_path)), "--no-progress", *out]
    if name == "network":
        return ["network", str(test_network.tiny_network_study(tmp_path, ["independent", "receptivity"])), *out]
    if name == "simulate":
        return ["simulate", str(test_simulate.study(tmp_path)), "--no-progress", *out]
    if name == "heavyhaul":
        return ["heavyhaul", str(test_heavyhaul_study.study(tmp_path, brake_penalty=[60])), "--no-progress", *out]
    there, back = example_logs(tmp_path / "logs")
    if name == "calibrate":
        return ["calibrate", str(there), str(back), "--bootstrap", "5", *out]
    return ["validate", str(there), *out]


@pytest.mark.slow
@needs_chromium
@pytest.mark.parametrize("name", ["compare", "journey", "run", "network", "simulate", "heavyhaul", "calibrate",
                                  "validate"])
def test_every_commands_report_renders_in_chromium(name, tmp_path):
    done = CliRunner().invoke(app, command(name, tmp_path))
    assert done.exit_code in (0, 1), done.output  # written (1: a case flagged, as the report shows)
    path = tmp_path / "out" / "report.html"
    result = load(path.parent)
    assert result.kind == name
    pictures = [f for f in result.files if f.endswith(".png")]
    assert pictures or name == "run"  # a batch study's folder is its table; every other command draws
    if pictures:
        check_page(path)  # the file: tables, figures embedded whole, nothing from elsewhere
    dom = Page(chromium(path.as_uri(), tmp_path))  # the page as the browser built it, its script run
    assert result.tables
    for table, frame in result.tables.items():
        assert len(dom.table(frame.columns)) == min(len(frame), MAX_ROWS), table
    assert [i["alt"] for i in dom.images] == pictures
    assert all(i["src"].startswith("data:image/png;base64,") for i in dom.images)


def test_a_run_reports_its_track_train_stops_and_k_among_its_inputs(tmp_path):
    """A run study's report.html listed only its study file under Inputs: its track, train, stops and
    K are there now, as summary.json records them."""
    done = CliRunner().invoke(app, command("run", tmp_path))
    assert done.exit_code == 0, done.output
    summary = load(tmp_path / "out").summary
    assert {k: summary.get(k) for k in ("track", "train", "from", "to", "points")} == {
        "track": "Amsterdam metro Rokin - Centraal", "train": "Amsterdam metro (Alstom, Rokin-Centraal case)",
        "from": "Rokin", "to": "Centraal", "points": 150}
    page = (tmp_path / "out" / "report.html").read_text()
    inputs = page[page.index("<h2>Inputs</h2>"):page.index("<h2>Results</h2>")]
    for value in ("sweep.yaml", "Amsterdam metro Rokin - Centraal", "Rokin-Centraal case", "Centraal", "150"):
        assert value in inputs, (value, inputs)
