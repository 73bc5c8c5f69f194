"""Figures say what their folder says: a flagged run's speed and energy figures carry FLAGGED
and the reason in their title, a compared strategy that is not ok says so in the legend, a front's
points not ok are ringed, and a '$' in a name is a dollar (it stopped every figure after the solve:
matplotlib read it as maths). Real solves, figures drawn by the tool's own plot functions."""
import pytest

from ecostudy.analysis.single import solve_run
from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train, train_from_dict
from ecostudy.report import plots

from .conftest import TRACKS, TRAINS, load_yaml

ROKIN, METRO = TRACKS / "amsterdam_rokin_centraal.yaml", TRAINS / "amsterdam_metro.yaml"


@pytest.mark.flagged_on_purpose  # K = 10: the re-simulation is outside tolerance
def test_a_flagged_runs_figures_say_it_in_their_titles():
    run = solve_run(load_track(ROKIN), load_train(METRO), "Rokin", "Centraal", Timing(running_time=76.0), points=10)
    assert not run.status.ok
    for figure in (plots.speed_plot(run), plots.energy_plot(run)):
        title = figure.axes[0].get_title()
        assert "FLAGGED: re-simulation outside tolerance" in title, title


def test_an_ok_runs_title_has_no_flag_and_a_dollar_in_a_name_is_drawn():
    doc = {**load_yaml(METRO), "name": "Tram $1} fare $2"}
    run = solve_run(load_track(ROKIN), train_from_dict(doc), "Rokin", "Centraal", Timing(running_time=76.0), points=100)
    assert run.status.ok
    title = plots.speed_plot(run).axes[0].get_title()
    assert title.startswith("Tram $1} fare $2 - Rokin to Centraal") and "FLAGGED" not in title, title
    plots.speed_plot(run).savefig(__import__("io").BytesIO(), format="png")  # drawn: mathtext raised here


def test_a_compared_strategy_not_ok_says_so_in_the_legend():
    run = solve_run(load_track(ROKIN), load_train(METRO), "Rokin", "Centraal", Timing(running_time=76.0), points=100)
    from ecostudy.core.simulate import Driven

    driven = Driven("ATO optimum", run.handle, run.trace)
    figure = plots.compare_plot([driven], run.segment, statuses={"ATO optimum": "flagged: stopped 2 m short"})
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert any(label.startswith("ATO optimum: ") and label.endswith("(FLAGGED)") for label in labels), labels
