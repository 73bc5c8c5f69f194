"""Figures read through their artists: one colour per strategy, distribution and limit kind (the
same in every plot), one line per split, axis limits from the data plotted, the energy flow of a
run adding up, and figures written as PNG, SVG or PDF at a chosen resolution."""
import re
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import matplotlib.pyplot as plt
import pytest
from matplotlib.artist import Artist
from matplotlib.colors import to_hex

from ecostudy.analysis.energyflow import run_energy_flow
from ecostudy.analysis.single import solve_run
from ecostudy.core.errors import InputError
from ecostudy.core.types import Supply, Timing
from ecostudy.core.units import to_kwh
from ecostudy.io.loaders import load_track, load_train, track_document, train_document
from ecostudy.network import fleet as fleets
from ecostudy.network import strategies
from ecostudy.report import heavyplots, loopplots, netplots, plots, style
from ecostudy.studies.closedloop import simulate_study
from ecostudy.studies.batch import Expanded, run_expanded
from ecostudy.studies.compare import compare_cases, outcomes, segment_of
from ecostudy.studies.heavyhaul import heavyhaul_study
from ecostudy.studies.pareto import sweep, weighted_points

from .conftest import TRACKS, TRAINS, write_yaml
from .test_heavyhaul_study import study as heavyhaul_file

SPEED_LIMIT = style.LIMIT["speed limit"]


def hexes(lines):
    return [to_hex(line.get_color()) for line in lines]


def labelled(ax):
    """The lines of ``ax`` that carry a legend label."""
    return [line for line in ax.get_lines() if not line.get_label().startswith("_")]


def limit_lines(ax):
    return [line for line in ax.get_lines() if line.get_label() == plots.SPEED_LIMIT]


@pytest.fixture(scope="module")
def metro():
    return load_track(TRACKS / "metro_line_4stops.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")


@pytest.fixture(scope="module")
def rokin():
    """Rokin -> Centraal in 76 s at K = 300 (regeneration on, uphill and downhill sections)."""
    track, train = load_track(TRACKS / "amsterdam_rokin_centraal.yaml"), load_train(TRAINS / "amsterdam_metro.yaml")
    return solve_run(track, train, "Rokin", "Centraal", Timing(running_time=76.0), points=300)


@pytest.fixture(scope="module")
def regional_compare(tmp_path_factory):
    """(table, the strategies' simulated runs, something with the segment) of a comparison run by
    the study engine, as ``ecostudy compare`` runs it."""
    cases = compare_cases(train_document(TRAINS / "regional_alstom.yaml")[0], track_document(TRACKS / "regional_808m.yaml"),
                          "Origin", "Destination", Timing(running_time=80.0), points=200)
    ran = run_expanded("compare", Expanded(tmp_path_factory.mktemp("compare"), cases), "test")
    return ran.table, outcomes(ran.cases, ran.rows), SimpleNamespace(segment=segment_of(cases[0]))


@pytest.fixture(scope="module")
def splits(metro):
    """Two segments each solved at two running times, arranged as five distributions of a journey."""
    track, train = metro
    runs = {t: [solve_run(track, train, a, b, Timing(running_time=t * d), points=200)
                for a, b, d in (("Noord", "Station", 1.0), ("Station", "Centrum", 1.9))] for t in (56.0, 62.0)}
    names = ["whole-journey NLP", "equal marginal saving", "same percentage", "MARECO-style", "as timetabled"]
    return {name: runs[56.0 if i % 2 == 0 else 62.0] for i, name in enumerate(names)}


@pytest.fixture(scope="module")
def network(metro):
    track, train = metro
    f = fleets.plan(track, train, ["Noord", "Station"], [56.0], 10.0, [0.0, 45.0], ["T1", "T2"], 1.0,
                    Supply(position=300.0), points=300, buffer=360.0)
    return f, strategies.run_strategies(f, ["independent", "triggering", "following"], progress=None)


# --- the style module -------------------------------------------------------------------------

def test_named_colours_are_distinct_within_each_group_and_from_the_limits():
    limits = {c.lower() for c in style.LIMIT.values()}
    assert len(limits) == len(style.LIMIT)
    for group, table in style.GROUPS.items():
        colours = [c.lower() for c in table.values()]
        assert len(set(colours)) == len(colours), group
        if group not in ("limit", "energy", "regime"):  # drawn over the limits: never in a limit's colour
            assert not limits & set(colours), group
    assert style.colour("MARECO-style") == style.STRATEGY["MARECO-style"] == style.DISTRIBUTION["MARECO-style"]
    with pytest.raises(KeyError, match="named: "):
        style.colour("no such strategy")


def test_a_palette_never_repeats_a_colour_and_keeps_named_and_repeated_keys():
    palette = style.Palette(["ATO optimum", "T1"])
    given = [palette(f"train {i}") for i in range(60)] + [palette() for _ in range(5)]
    assert len({c.lower() for c in given}) == 65
    assert palette("ATO optimum") == style.colour("ATO optimum")
    assert palette("T1") == palette("T1") and palette("T1").lower() not in {c.lower() for c in given}
    assert not {c.lower() for c in given} & {c.lower() for c in style.LIMIT.values()}
    assert style.colour("ATO optimum").lower() not in {c.lower() for c in given}


def _lab(colour):
    """CIE L*a*b* (D65) of a #rrggbb colour."""
    rgb = [int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)]
    r, g, b = [((c + 0.055) / 1.055) ** 2.4 if c > 0.04045 else c / 12.92 for c in rgb]
    xyz = ((0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047, 0.2126 * r + 0.7152 * g + 0.0722 * b,
           (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883)
    fx, fy, fz = [u ** (1 / 3) if u > 0.008856 else 7.787 * u + 16 / 116 for u in xyz]
    return np.array([116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)])


def test_the_trains_of_a_network_figure_are_told_apart_after_its_seven_strategies():
    """The trains get the colours handed out after the strategies': thin lines in one panel, so
    each pair at least 50 apart in CIE L*a*b* (cyan against teal, 35, read as one colour)."""
    strategies = ["independent", "receptivity", "triggering", "voltage", "dissension", "joint", "following"]
    palette = style.Palette(strategies + ["T1", "T2", "T3"])
    trains = [_lab(palette(name)) for name in ("T1", "T2", "T3")]
    assert min(np.linalg.norm(a - b) for i, a in enumerate(trains) for b in trains[i + 1:]) >= 50.0


@pytest.mark.parametrize("module", [plots, netplots, loopplots, heavyplots], ids=lambda m: m.__name__)
def test_plots_take_every_colour_from_the_style_module(module):
    source = (Path(module.__file__)).read_text()
    assert not re.search(r"color\s*=\s*[\"'f]", source), f"a colour written into {module.__name__}"
    assert not re.search(r"[\"'](tab:|C\d[\"'])|colormaps|cmap\s*=\s*[\"']|#[0-9a-fA-F]{6}", source)


def test_figures_written_in_each_format_at_the_resolution_asked(rokin, tmp_path):
    heads = {"png": b"\x89PNG", "svg": b"<?xml", "pdf": b"%PDF"}
    for fmt, head in heads.items():
        tmp = tmp_path / f"speed.{fmt}.tmp"  # atomic_write's temporary names say nothing of the format
        assert plots.speed_plot(rokin, tmp, fmt=fmt) is None
        assert tmp.read_bytes().startswith(head), fmt
    plots.energy_plot(rokin, tmp_path / "a.png", dpi=50)
    plots.energy_plot(rokin, tmp_path / "b.png", dpi=100)
    width = [int.from_bytes((tmp_path / f"{n}.png").read_bytes()[16:20], "big") for n in "ab"]
    assert width[1] == 2 * width[0]
    assert plots.energy_plot(rokin, tmp_path / "c.svg") is None  # the suffix gives the format
    assert (tmp_path / "c.svg").read_bytes().startswith(b"<?xml")
    assert style.output("SVG", 300).filename("speed") == "speed.svg"
    (tmp_path / "energy.png").write_bytes(b"an earlier run's")
    assert style.write(tmp_path, "energy", partial(plots.energy_plot, rokin), style.output("pdf", 72)) == "energy.pdf"
    assert (tmp_path / "energy.pdf").read_bytes().startswith(b"%PDF") and not (tmp_path / "energy.png").exists()
    with pytest.raises(InputError, match="--format: 'jpeg'"):
        style.output("jpeg")
    with pytest.raises(InputError, match="--dpi"):
        style.output("png", 5)


class Failing(Artist):
    """An artist whose drawing fails: the figure's file is open (SVG, PDF) when it is reached."""

    def draw(self, renderer):
        raise RuntimeError("drawing failed")


@pytest.mark.parametrize("fmt", style.FORMATS)
def test_a_figure_whose_drawing_fails_leaves_neither_part_of_it_nor_a_temporary_file(tmp_path, fmt):
    """Every figure goes to a hidden temporary name and is renamed into place: a drawing stopped
    halfway (an error here; SIGTERM in a command) leaves the earlier figure under the name, whole,
    and no other file (matplotlib wrote the SVG and PDF straight to the name: 0 or a few bytes)."""
    fig, ax = plots.figure()
    ax.plot([0, 1], [0, 1])
    fig.add_artist(Failing())
    with pytest.raises(RuntimeError, match="drawing failed"):
        style.save(fig, tmp_path / f"bands.{fmt}")
    assert list(tmp_path.iterdir()) == []
    earlier, _ = plots.figure()
    style.save(earlier, tmp_path / f"bands.{fmt}")
    whole = (tmp_path / f"bands.{fmt}").read_bytes()
    with pytest.raises(RuntimeError, match="drawing failed"):
        style.save(fig, tmp_path / f"bands.{fmt}")
    assert [p.name for p in tmp_path.iterdir()] == [f"bands.{fmt}"]
    assert (tmp_path / f"bands.{fmt}").read_bytes() == whole


# --- the defects ------------------------------------------------------------------------------

def test_compare_draws_each_strategy_in_its_own_colour(regional_compare):
    table, outcomes, case = regional_compare
    ax = plots.compare_plot(outcomes, case.segment, None).axes[0]
    runs = [line for line in labelled(ax) if line.get_label() != plots.SPEED_LIMIT]
    assert len(runs) == len(outcomes) == 6
    colours = hexes(runs)
    assert len(set(colours)) == 6, colours
    by_name = dict(zip([o.name for o in outcomes], colours))
    assert by_name["DAS phases"] != by_name["all-out"] and by_name["DAS phases"] != by_name["ATO optimum"]
    assert by_name["ATO optimum"] == style.colour("ATO optimum")
    assert SPEED_LIMIT not in colours


def test_journey_draws_every_distribution_once_per_split(splits):
    ax = plots.journey_plot(splits, None, "journey").axes[0]
    lines = [line for line in ax.get_lines() if len(line.get_xdata()) > 2]
    limits = [line for line in lines if line.get_color() == SPEED_LIMIT]
    assert len(limits) == 2 and len(limit_lines(ax)) == 1  # each segment's limit, one legend entry
    assert len(lines) - len(limits) == 5 * 2  # one line per distribution and segment
    legend = [line for line in labelled(ax) if line.get_label() != plots.SPEED_LIMIT]
    assert len(legend) == 5 and all(line.get_label().split(":")[0] in splits for line in legend)
    colours = hexes(legend)
    assert len(set(colours)) == 5 and SPEED_LIMIT not in colours
    stops = [line for line in ax.get_lines() if line.get_color() == style.LIMIT["stop"]]
    assert len(stops) == 2  # each segment's end drawn once, not once per distribution
    ends = sorted(float(line.get_xdata()[0]) for line in stops)
    assert ends == pytest.approx([650.0, 2100.0])


def test_pareto_axis_spans_the_front_not_the_weighted_points(metro):
    track, train = metro
    table, _ = sweep(track, train, "Noord", "Station", count=4, supplement_max=0.3, points=200)
    weighted = weighted_points(track, train, "Noord", "Station", points=200, energy_weights=[0.3, 30.0])
    t = table["running_time_s"]
    assert weighted["running_time_s"].max() > t.max() * 1.1  # a point the axis must not stretch to
    fig = plots.pareto_plot(table, None, "front", weighted)
    ax = fig.axes[0]
    lo, hi = ax.get_xlim()
    span = t.max() - t.min()
    assert t.min() - 0.05 * span <= lo < t.min() and t.max() < hi <= t.max() + 0.05 * span
    assert "beyond the front's times not shown" in " ".join(line.get_label() for line in ax.get_lines())
    assert "kWh" in ax.get_ylabel()


@pytest.mark.slow
def test_network_substation_curves_and_trains_in_distinct_colours(network):
    f, outcome = network
    fig = netplots.network_plot(f, outcome, None, "two trains")
    substation = fig.axes[-1]
    curves = labelled(substation)
    assert len(curves) == 3
    colours, dashes = hexes(curves), [line.get_linestyle() for line in curves]
    assert len(set(colours)) == 3 and len(set(dashes)) == 3
    trains = set(hexes(labelled(fig.axes[0])))
    assert len(trains) == 2 and not trains & set(colours)


def test_the_speed_limit_has_one_colour_in_every_plot(rokin, regional_compare, splits):
    _, outcomes, case = regional_compare
    figures = [plots.speed_plot(rokin, None), plots.profiles_plot([rokin], None),
               plots.compare_plot(outcomes, case.segment, None), plots.journey_plot(splits, None)]
    for fig in figures:
        lines = limit_lines(fig.axes[0])
        assert len(lines) == 1 and to_hex(lines[0].get_color()) == SPEED_LIMIT
    gradient = plots.speed_plot(rokin).axes[1].get_lines()[0]
    assert to_hex(gradient.get_color()) == style.LIMIT["gradient"]


# --- the plots that were missing --------------------------------------------------------------

def test_energy_flow_adds_up_to_the_traction_energy(rokin):
    flow, s = run_energy_flow(rokin), rokin.summary
    parts = sum(flow.parts().values())
    assert abs(parts - flow.traction) <= 0.005 * flow.traction  # within 0.5 %
    assert to_kwh(flow.traction) == pytest.approx(s["traction_energy_kWh"], rel=1e-9)
    assert to_kwh(flow.net) == pytest.approx(s["net_energy_kWh"], rel=1e-6)
    assert to_kwh(flow.braking) == pytest.approx(s["braking_energy_kWh"], rel=1e-9)
    assert flow.drawn > flow.traction and 0 < flow.regenerated < flow.braking
    assert flow.resistance > 0 and abs(flow.kinetic) < 1e-6 * flow.traction  # stop to stop

    ax = plots.energy_plot(rokin).axes[0]
    bars = {c.get_label(): (c.patches[0].get_y(), c.patches[0].get_height()) for c in ax.containers}
    assert list(bars) == ["drawn from the line", "losses in traction", "traction at the wheel", "resistance",
                          "potential energy", "kinetic energy", "regeneration returned", "braking dissipated",
                          "net from the line"]
    assert bars["traction at the wheel"][1] == pytest.approx(s["traction_energy_kWh"], rel=1e-9)
    bottom, height = bars["braking dissipated"]  # the waterfall ends at the balance residual
    assert abs(bottom) <= 0.005 * s["traction_energy_kWh"]
    assert height == pytest.approx(to_kwh(flow.dissipated), rel=1e-9)
    assert ax.get_ylabel() == "energy [kWh]"
    assert [to_hex(p.get_facecolor()) for p in ax.patches] == list(style.ENERGY.values())


@pytest.mark.slow
def test_substation_voltage_and_current_over_time(network):
    f, outcome = network
    fig = netplots.supply_plot(f, outcome, None, "two trains")
    volts, amps = fig.axes
    for ax, unit in ((volts, "[V]"), (amps, "[A]")):
        curves = [line for line in labelled(ax) if line.get_label() in outcome]
        assert len(curves) == 3 and len(set(hexes(curves))) == 3
        assert unit in ax.get_ylabel()
    bus = np.concatenate([line.get_ydata() for line in labelled(volts) if line.get_label() in outcome])
    current = np.concatenate([line.get_ydata() for line in labelled(amps)])
    assert np.all(bus <= f.supply.max_voltage + 1e-6) and np.all(bus > 0.5 * f.supply.voltage)
    assert np.all(current >= 0) and current.max() > 100  # the trains draw
    # a drawing bus sits at V_s - R_s I_s (eq. 7.8)
    line_v = labelled(volts)[0].get_ydata()
    line_i = labelled(amps)[0].get_ydata()
    drawing = line_i > 1.0
    assert line_v[drawing] == pytest.approx(f.supply.voltage - f.supply.resistance * line_i[drawing], rel=1e-6)


# --- closed-loop and heavy-haul figures -------------------------------------------------------

@pytest.fixture(scope="module")
def loop_study(tmp_path_factory):
    """Yazhemsky 2017's flat 1 km trip driven by the convex controller with and without the mass
    estimator and by its plan replayed open loop, two draws of a plant 10 % off in mass."""
    folder = tmp_path_factory.mktemp("loop")
    write_yaml(folder / "loop.yaml", {
        "name": "loop", "track": str(TRACKS / "yazhemsky2017_flat_1km.yaml"), "train": str(TRAINS / "yazhemsky2017_commuter.yaml"),
        "window_s": [0, 100], "points": 100, "sample_time_s": 0.5, "draws": 2, "seed": 3,
        "deviations": {"mass": {"low": 0.9, "high": 1.1}},
        "controllers": [{"name": "convex", "kind": "convex"}, {"name": "with estimator", "kind": "convex", "estimator": True},
                        {"name": "plan replayed", "kind": "open_loop", "sample_time_s": 1.0}]})
    return simulate_study(folder / "loop.yaml", out=folder / "out")


def test_closed_loop_plots_give_each_controller_one_colour_in_every_plot(loop_study):
    runs, names = loop_study.by_controller, list(loop_study.by_controller)
    bands = loopplots.bands(runs, loop_study.segment, None)
    medians = {}
    for ax, name in zip(bands.axes, names):
        median = [line for line in labelled(ax) if line.get_label() in ("median", "run")]
        limit = [line for line in ax.get_lines() if line.get_label() == "speed limit"]
        assert len(median) == 1 and len(limit) == 1 and hexes(limit) == [SPEED_LIMIT]  # as in plots.py's figures
        medians[name] = hexes(median)[0]
        band = ax.collections[0]  # the 5-95 % band, in the median's colour
        assert to_hex(band.get_facecolor()[0][:3]) == medians[name]
    assert len(set(medians.values())) == 3 and medians["convex"] == style.CONTROLLER["convex"]
    assert not set(medians.values()) & {c.lower() for c in style.LIMIT.values()}
    times = loopplots.solve_times(runs, loop_study.budgets, None).axes[0]
    named = {line.get_label().removesuffix(" (FLAGGED)"): line for line in labelled(times)}  # a controller not ok: marked
    assert {name: to_hex(line.get_color()) for name, line in named.items() if name in runs} == medians
    budgets = [line for line in labelled(times) if line.get_label().startswith("budget")]
    assert len(budgets) == 2 and set(hexes(budgets)) == {style.LIMIT["budget"]}
    assert len({line.get_linestyle() for line in budgets}) == 2
    masses = loopplots.mass_estimates(runs, None).axes[0]  # each draw in a colour of its own (tests/test_plots_status.py)
    estimated = labelled(masses)
    assert [line.get_label().split(":")[0] for line in estimated] == ["with estimator, draw 0", "with estimator, draw 1"]
    assert len(set(hexes(estimated))) == 2 and not set(hexes(estimated)) & {c.lower() for c in style.LIMIT.values()}


@pytest.mark.slow  # the two heavy-haul runs take about 20 s
def test_heavy_haul_curves_each_in_a_colour_of_their_own(tmp_path):
    outcome = heavyhaul_study(heavyhaul_file(tmp_path, brake_penalty=[1, 60], horizons=[{"np": 4, "nc": 2},
                                                                                          {"np": 6, "nc": 2}]),
                              out=tmp_path / "out")
    trade = heavyplots.trade_off(outcome.runs, None)
    curves = [line for ax in trade.axes[:2] for line in labelled(ax)
              if line.get_markeredgecolor() != style.LIMIT["not ok"]]  # the rings of flagged runs apart
    assert len(curves) == 2 * 2 * 2  # (f, Np, Nc) groups x two quantities x two panels
    assert len(set(hexes(curves))) == len(curves)
    assert all(len(line.get_xdata()) == 2 for line in curves)  # one point per K_b
    tracking = labelled(heavyplots.tracking(outcome, None).axes[0])  # the line's limit, the reference, the runs
    assert hexes(tracking[:2]) == [SPEED_LIMIT, style.colour("reference")] and len(tracking) == 2 + 4
    assert len(set(hexes(tracking))) == len(tracking)


def test_a_long_reason_in_a_title_says_it_is_clipped():
    """A figure's status line keeps at most two lines of a not-ok run's reason, and a clipped
    reason says so and where the whole one is, so a cut reason never reads as the whole."""
    reason = "flagged: " + "; ".join(f"car {i} over its coupler limit by {i}.5 kN at {100 * i} m" for i in range(1, 12))
    fig, ax = plt.subplots()
    plots.titled(ax, "a run", reason, width=60)
    lines = ax.get_title().split("\n")
    plt.close(fig)
    assert lines[1].startswith("FLAGGED: car 1") and len(lines) == 3
    assert lines[-1].endswith("... (whole reason: summary.json)") and len(lines[-1]) <= 60
    fig, ax = plt.subplots()
    plots.titled(ax, "a run", "flagged: 5.0 m short of the stop", width=60)
    assert ax.get_title().split("\n")[1:] == ["FLAGGED: 5.0 m short of the stop"]
    plt.close(fig)


def test_a_front_whose_every_point_failed_draws_a_figure_that_says_so(metro):
    """Every point of a front failed (no running time, no profile): the figures say so instead of
    the command stopping with an internal error on NaN axis limits."""
    track, train = metro
    table, _ = sweep(track, train, "Noord", "Station", count=2, supplement_max=0.3, points=100)
    failed = table.assign(running_time_s=np.nan, traction_energy_kWh=np.nan, net_energy_kWh=np.nan,
                          marginal_saving_kWh_per_s=np.nan, status="failed: the solver stopped")
    fig = plots.pareto_plot(failed, None, "front")
    words = " ".join(t.get_text() for a in fig.axes for t in a.texts) + fig.axes[0].get_title()
    assert f"all {len(table)} failed" in words and "FAILED" in fig.axes[0].get_title()
    fig = plots.profiles_plot([], None, "front")
    assert "no point of the front was solved" in " ".join(t.get_text() for t in fig.axes[0].texts)
