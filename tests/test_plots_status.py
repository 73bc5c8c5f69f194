"""Figures say what their folder says: a flagged run's speed and energy figures carry FLAGGED
and the reason in their title, a compared strategy that is not ok says so in the legend, a front's
points not ok are ringed, a heavy-haul run's forces and the tracking of every run, a closed loop's
solve times and mass estimates, a calibration's residuals and a validation say which runs are not
ok, and a '$' in a name is a dollar (it stopped every figure after the solve: matplotlib read it as
maths). Real solves, figures drawn by the tool's own plot functions."""
import pandas as pd
import pytest
from matplotlib.colors import to_hex

from ecostudy.analysis.single import solve_run
from ecostudy.calibration.estimate import calibrate_logs
from ecostudy.calibration.generate import generate_log, true_train
from ecostudy.calibration.validate import validate_log
from ecostudy.core.grid import make_segment
from ecostudy.core.status import Status
from ecostudy.core.types import Timing
from ecostudy.io.loaders import load_track, load_train, train_from_dict
from ecostudy.io.logfile import parse_log
from ecostudy.report import calplots, heavyplots, loopplots, plots, style
from ecostudy.studies.closedloop import simulate_study
from ecostudy.studies.heavyhaul import heavyhaul_study

from .conftest import TRACKS, TRAINS, load_yaml, write_yaml
from .test_heavyhaul_study import study as heavyhaul_file

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


def test_a_heavy_haul_runs_figures_carry_its_status_and_the_tracking_its_limit(tmp_path):
    """The paper's plant asks more than dry rail gives: the run is flagged, which its forces figure
    and the tracking figure did not say; the tracking figure now also draws the line's limit."""
    outcome = heavyhaul_study(heavyhaul_file(tmp_path, brake_penalty=[1]), out=tmp_path / "out")
    (case,), status = outcome.cases, heavyplots.statuses(outcome)
    assert str(status["Kb=1 f=10 Np=4 Nc=2"]).startswith("flagged: a locomotive asked")
    forces = heavyplots.forces(case, outcome.summaries[case["key"]], None, status=status["Kb=1 f=10 Np=4 Nc=2"])
    assert "FLAGGED: a locomotive asked" in forces.axes[0].get_title()
    ax = heavyplots.tracking(outcome, None).axes[0]
    assert "FLAGGED: 1 of 1 runs not ok: Kb=1 f=10 Np=4 Nc=2 (flagged)" in ax.get_title().replace("\n", " ")
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert "Kb=1 f=10 Np=4 Nc=2 (FLAGGED)" in lines, list(lines)
    assert to_hex(lines[plots.SPEED_LIMIT].get_color()) == style.LIMIT["speed limit"]


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    """Yazhemsky 2017's flat 1 km trip, two draws of a plant up to 10 % off: the convex controller with
    the mass estimator and the plan replayed open loop, which stops short of the stop (flagged)."""
    folder = tmp_path_factory.mktemp("loop")
    write_yaml(folder / "loop.yaml", {
        "name": "loop", "track": str(TRACKS / "yazhemsky2017_flat_1km.yaml"), "train": str(TRAINS / "yazhemsky2017_commuter.yaml"),
        "window_s": [0, 100], "points": 100, "sample_time_s": 0.5, "draws": 2, "seed": 3,
        "deviations": {"mass": {"low": 0.9, "high": 1.1}, "resistance": {"low": 0.9, "high": 1.1}},
        "controllers": [{"name": "estimator", "kind": "convex", "estimator": True},
                        {"name": "replayed", "kind": "open_loop"}]})
    return simulate_study(folder / "loop.yaml", out=folder / "out")


def test_a_closed_loops_solve_times_name_its_runs_not_ok(loop):
    statuses = loopplots.run_statuses(loop.runs, loop.by_controller)
    assert [str(s).split(":")[0] for s in statuses.values()] == ["ok", "ok", "flagged", "flagged"], statuses
    ax = loopplots.solve_times(loop.by_controller, loop.budgets, None, title="loop", statuses=statuses).axes[0]
    assert "FLAGGED: 2 of 4 runs not ok: replayed draw 0 (flagged), replayed draw 1 (flagged)" in ax.get_title().replace("\n", " ")
    labels = ax.get_legend_handles_labels()[1]
    assert "estimator" in labels and "replayed (FLAGGED)" in labels, labels


def test_each_draws_mass_estimate_is_in_the_colour_of_its_true_mass(loop):
    """Every estimate and every true mass were drawn in the controller's one colour: which truth an
    estimate should reach could not be read. Now each draw has its own colour, its truth dotted in it;
    the title speaks of the estimating controller's runs only (all ok)."""
    ax = loopplots.mass_estimates(loop.by_controller, None, title="loop").axes[0]
    estimates = [line for line in ax.get_lines() if line.get_label().startswith("estimator, draw")]
    truths = [line for line in ax.get_lines() if line.get_linestyle() == ":"]
    assert len(estimates) == len(truths) == 2 and len({to_hex(line.get_color()) for line in estimates}) == 2
    for estimate, truth in zip(estimates, truths):
        assert to_hex(estimate.get_color()) == to_hex(truth.get_color())
        assert estimate.get_label().endswith(f"true {truth.get_ydata()[0]:.3f}")
    assert ax.get_title() == "loop: estimate (solid) and true mass (dotted), each draw in its own colour"


@pytest.fixture(scope="module")
def regional_log():
    """A log of the regional train 5 % heavier with 10 % more resistance than its file, on the
    calibration line, without the line's power: (track, train, log)."""
    track, train = load_track(TRACKS / "calibration_line.yaml"), load_train(TRAINS / "regional_alstom.yaml")
    truth = true_train(train, mass=1.05, davis=(1.1, 1.1, 1.1))
    frame, _ = generate_log(track, truth, ["West", "Middle", "East"], truth, seed=1)
    text = "---\ntrack: t.yaml\ntrain: r.yaml\n---\n" + frame.drop(columns=["power_line_kW"]).to_csv(index=False)
    return track, train, parse_log(text, "there.csv", "there")


def test_a_flagged_calibrations_residuals_say_so(regional_log):
    track, train, log = regional_log
    result = calibrate_logs([log], track, train, ("mass", "davis_a", "efficiency"), draws=0)
    assert result.status == "flagged" and "efficiency not identifiable" in result.reason
    figure = calplots.residuals(result.residuals, None, "calibration", status=Status.parse(result.status, result.reason))
    title = figure.texts[0]  # the figure's own title, over every run's panels
    assert "FLAGGED: efficiency not identifiable" in title.get_text() and title.get_color() == style.LIMIT["not ok"]


def test_a_validations_runs_not_ok_are_named_and_marked(regional_log):
    track, train, log = regional_log
    table = validate_log(log, track, train, 0.02, 0.05)
    assert list(table["status"]) == ["flagged", "flagged"], table[["status", "reason"]]
    figure = calplots.validation(table, None, "there")
    assert "FLAGGED: 2 of 2 runs not ok: there run 0 (flagged), there run 1 (flagged)" in figure.texts[0].get_text()
    assert [t.get_text() for t in figure.axes[0].get_xticklabels()] == ["there\nrun 0 (FLAGGED)", "there\nrun 1 (FLAGGED)"]


def test_a_compared_run_that_stood_off_its_stop_gives_where_it_stood_not_an_arrival():
    """compare.png's legend read '77.8 s' for a run that stood short of its stop, as an arrival."""
    import dataclasses

    from ecostudy.core.simulate import Driven

    run = solve_run(load_track(ROKIN), load_train(METRO), "Rokin", "Centraal", Timing(running_time=76.0), points=100)
    short = dataclasses.replace(run.trace, stop_position=run.segment.distance - 40.0)
    figure = plots.compare_plot([Driven("arrived", run.handle, run.trace), Driven("short", run.handle, short)],
                                run.segment, statuses={"short": "flagged: stopped 40 m short"})
    labels = figure.axes[0].get_legend_handles_labels()[1]
    assert any(label.startswith(f"arrived: {run.trace.arrival_time:.1f} s, ") for label in labels), labels
    assert any(label.startswith(f"short: stood 40.0 m short of the stop at {run.trace.arrival_time:.1f} s")
               for label in labels), labels
