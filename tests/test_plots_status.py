"""Figures say what their folder says: a flagged run's speed and energy figures carry FLAGGED
and the reason in their title, a compared strategy that is not ok says so in the legend, a front's
points not ok are ringed, and a '$' in a name is a dollar (it stopped every figure after the solve:
matplotlib read it as maths). Real solves, figures drawn by the tool's own plot functions."""
import pandas as pd
import pytest

from ecostudy.analysis.single import solve_run
from ecostudy.core.grid import make_segment
from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train, train_from_dict
from ecostudy.report import heavyplots, loopplots, plots, style

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


def test_a_heavy_haul_trade_off_rings_its_flagged_runs():
    """The trade-off figure drew runs that never arrived exactly as ok ones: now each run not ok is
    ringed in the colour of a run not ok, and the legend counts them."""
    runs = pd.DataFrame({"f": [10] * 3, "Np": [4] * 3, "Nc": [2] * 3, "K_b": [1.0, 40.0, 60.0],
                         "force_max_kN": [900.0, 700.0, 650.0], "force_max_braking_kN": [600.0, 300.0, 110.0],
                         "energy_total_kWh": [8485.0, 8400.0, 59788.0], "wagon_brake_kWh": [3000.0, 2500.0, 2400.0],
                         "status": ["ok", "ok", "flagged"]})
    figure = heavyplots.trade_off(runs, None)
    rings = [line for ax in figure.axes for line in ax.get_lines() if line.get_markeredgecolor() == style.LIMIT["not ok"]]
    assert len(rings) == 4 and all(list(line.get_xdata()) == [60.0] for line in rings)
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert any(label.startswith("flagged (1 of 3 runs") for label in labels), labels


def test_a_closed_loop_band_says_how_many_of_its_runs_are_ok():
    segment = make_segment(load_track(ROKIN), load_train(METRO), "Rokin", "Centraal")
    run = {"profile": {"x": [0.0, 500.0, segment.distance], "v": [0.0, 15.0, 0.0]}}
    figure = loopplots.bands({"convex": [run, run], "rspc": [run, run]}, segment, None, ok={"convex": 1, "rspc": 2})
    (convex, rspc) = (ax.title for ax in figure.axes)
    assert convex.get_text() == "convex: 2 runs, 1 ok (runs.csv's status)" and convex.get_color() == style.LIMIT["not ok"]
    assert rspc.get_text() == "rspc: 2 runs, 2 ok (runs.csv's status)" and rspc.get_color() == style.LIMIT["title"]
