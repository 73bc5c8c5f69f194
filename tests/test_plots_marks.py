"""Figures of several runs say which are not ok: a journey's distributions, a network's
strategies (failed ones, which have no runs to draw, named), a comparison's failed strategies, a
front's driver advice (ringed apart from the runs) and its speed profiles; and pareto's terminal
table has a status column. Real solves, figures drawn by the tool's own plot functions."""
import re

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy import api
from ecostudy.analysis.single import solve_run
from ecostudy.cli import app
from ecostudy.core.simulate import Driven
from ecostudy.core.types import Supply, Timing, Window
from ecostudy.io.loaders import load_track, load_train, track_document, train_document
from ecostudy.network import fleet, strategies
from ecostudy.report import netplots, plots, style
from ecostudy.report.studyfiles import front_drawings, runs_ok
from ecostudy.studies.batch import Expanded, run_expanded
from ecostudy.studies.front import front_cases

from .conftest import TRACKS, TRAINS, write_yaml

ROKIN, METRO = TRACKS / "amsterdam_rokin_centraal.yaml", TRAINS / "amsterdam_metro.yaml"


def test_overall_names_the_runs_not_ok_and_those_not_drawn():
    assert plots.overall({"a": "ok", "b": "ok"}) == "ok"
    line = plots.overall({"a": "ok", "b": "flagged: x", "c, not drawn": "failed: y"}, "strategies")
    assert line == "failed: 2 of 3 strategies not ok: b (flagged), c, not drawn (failed); see summary.json", line


def test_a_journeys_flagged_and_failed_distributions_are_marked():
    """The journey figure's legend read 'whole-journey NLP: 12.81 kWh' beside the one distribution
    that kept the timetable, with no word that the cheaper ones broke it; a failed distribution
    vanished. Each now carries its word, and the title counts them."""
    run = solve_run(load_track(ROKIN), load_train(METRO), "Rokin", "Centraal", Timing(running_time=80.0), points=100)
    figure = plots.journey_plot({"whole-journey NLP": [run], "timing windows NLP": [run]}, title="j",
                                statuses={"whole-journey NLP": "flagged: breaks the timetable", "timing windows NLP": "ok",
                                          "as timetabled": "failed: infeasible"})
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert any(label.startswith("whole-journey NLP: ") and label.endswith("(FLAGGED)") for label in labels), labels
    assert any(label.startswith("timing windows NLP: ") and "(" not in label for label in labels), labels
    title = figure.axes[0].get_title()
    assert "FAILED: 2 of 3 distributions not ok" in title and "as timetabled, not drawn (failed)" in title, title


def test_a_comparisons_failed_strategy_is_named_in_the_title():
    run = solve_run(load_track(ROKIN), load_train(METRO), "Rokin", "Centraal", Timing(running_time=80.0), points=100)
    figure = plots.compare_plot([Driven("ATO optimum", run.handle, run.trace)], run.segment,
                                statuses={"ATO optimum": "ok", "MARECO-style": "failed: cannot meet 71.8 s"})
    title = figure.axes[0].get_title()
    assert "FAILED: 1 of 2 strategies not ok: MARECO-style, not drawn (failed)" in title, title


def test_a_network_figure_says_which_strategies_are_not_ok():
    """network.png and network_supply.png carried the study's name alone: a failed study read like a
    result. Each strategy's word is in the legend, the failed ones named in the title."""
    track, train = load_track(TRACKS / "metro_line_4stops.yaml"), load_train(METRO)
    f = fleet.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0], ["T1"], 1.0, Supply(position=650.0),
                   points=200)
    outcome = strategies.run_strategies(f, ["independent"], progress=None)
    statuses = {"independent": "flagged: a pantograph voltage fell", "joint": "failed: Ipopt infeasible"}
    for draw in (netplots.network_plot, netplots.supply_plot):
        figure = draw(f, outcome, title="net", statuses=statuses)
        title = figure.axes[0].get_title()
        assert "FAILED: 2 of 2 strategies not ok" in title and "joint, not drawn (failed)" in title, title
        labels = [label for ax in figure.axes for label in ax.get_legend_handles_labels()[1]]
        assert any(label.startswith("independent") and label.endswith("(FLAGGED)") for label in labels), labels


@pytest.mark.slow
def test_a_fronts_advice_not_ok_is_ringed_apart_from_its_runs(tmp_path):
    """K = 200 with the nearest-level advice: three advices stand past the stop (flagged, no running
    time) while every ATO run is ok. The figure ringed the ATO points and dropped the advice without
    a word; now the runs are not ringed, the advice not drawn is counted, the profiles figure has no
    flag, and the terminal table shows each point's status."""
    folder = api.pareto_folder(track=ROKIN, train=METRO, points=200, count=4, das="round", workers=1,
                               out=tmp_path, plot=False)
    table = folder.table
    advice_bad = table["das_status"].astype(str).str.startswith("flagged")
    assert advice_bad.sum() >= 2 and table["das_running_time_s"][advice_bad].isna().all()
    assert all(runs_ok(table)), table["status"].tolist()
    figure = plots.pareto_plot(table, title="front", runs_ok=runs_ok(table))
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert any(f"{int(advice_bad.sum())} of 4 not drawn: stood off the stop" in label for label in labels), labels
    assert not any(label.startswith("not ok (") for label in labels), labels
    assert folder.text.splitlines()[0].split()[-1] == "status", folder.text


def test_a_fronts_failed_point_is_named_not_drawn_and_breaks_no_line(tmp_path):
    """A study time of 60 s on Rokin-Centraal (the fastest run takes 71.7 s) fails. pareto_profiles
    drew the solved points with no word of it; pareto's lines broke at the failed row (NaN), its ring
    had no coordinates and its title no status. Both figures, drawn as `ecostudy pareto` draws them,
    now name the point `not drawn` in their title, and the front's lines join every solved point."""
    cases = front_cases(train_document(METRO)[0], track_document(ROKIN), "Rokin", "Centraal", count=2,
                        supplement_max=0.1, points=60, timing=Timing(running_time=60.0))
    ran = run_expanded("pareto", Expanded(tmp_path, cases), "test")
    assert ran.table["running_time_s"].isna().sum() == 1
    drawings = front_drawings(ran.cases, ran.rows, ran.table, "front")
    for stem in ("pareto", "pareto_profiles"):
        title = drawings[stem](None).axes[0].get_title()
        assert "FAILED: 1 of 3 points not ok: study 60 s, not drawn (failed)" in title, (stem, title)
    lines = drawings["pareto"](None).axes[0].get_lines()
    front_line = next(line for line in lines if line.get_label() == "traction (at the wheel)")
    assert len(front_line.get_xdata()) == 2 and not np.isnan(np.asarray(front_line.get_xdata(), float)).any()


def test_a_runs_timing_window_is_drawn_and_said_kept_on_screen(tmp_path):
    """A window at 500 m (from 40 s, at most 55 km/h) braked the run to 55 km/h there: speed.png
    showed the dip with no mark, and the screen's verification line did not name the window."""
    window = Window(distance=500.0, earliest=40.0, max_speed=55.0 / 3.6)
    run = solve_run(load_track(ROKIN), load_train(METRO), "Rokin", "Centraal", Timing(running_time=80.0), points=100,
                    windows=(window,))
    ax = plots.speed_plot(run).axes[0]
    line = next(line for line in ax.get_lines() if line.get_label().startswith("timing point"))
    assert line.get_label() == "timing point 500 m: from 40 s, at most 55 km/h: kept", line.get_label()
    assert list(line.get_xdata()) == [500.0, 500.0]
    assert any(list(bar.get_ydata()) == pytest.approx([55.0, 55.0]) for bar in ax.get_lines())
    study = write_yaml(tmp_path / "win.yaml", {
        "name": "win", "track": str(ROKIN), "train": str(METRO), "from": "Rokin", "to": "Centraal",
        "running_time_s": 80, "points": 100, "output": str(tmp_path / "out"),
        "windows": [{"position_m": 500, "earliest_s": 40, "max_speed_kmh": 55}]})
    done = CliRunner().invoke(app, ["solve", str(study), "--no-plot"])
    assert done.exit_code == 0, done.output
    said = next(line for line in done.stdout.splitlines() if line.strip().startswith("verification"))
    assert re.search(r"; timing point at 500 m kept \(4\d\.\d\d s, 5\d\.\d\d km/h\)$", said), said
