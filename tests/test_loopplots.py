"""The bands plot of a closed-loop study: per controller the 5-95 % band of the runs' speeds over
position (one fill_between polygon) and their median (one line), not an overlay of every run."""
import numpy as np
from matplotlib.collections import PolyCollection

from ecostudy.core.grid import make_segment
from ecostudy.core.status import Status
from ecostudy.core.units import to_kmh
from ecostudy.report.loopplots import bands, speed_percentiles


def _runs(segment, scales):
    """Runs whose speed is a hump over the segment, scaled per run."""
    x = np.linspace(0.0, segment.distance, 200)
    hump = 15.0 * np.sin(np.pi * x / segment.distance)
    return [{"profile": {"x": x.tolist(), "v": (s * hump).tolist()}} for s in scales]


def test_the_bands_plot_has_one_band_and_one_median_line_per_controller(metro, amsterdam):
    segment = make_segment(amsterdam, metro, "Rokin", "Centraal")
    runs = {"slow": _runs(segment, np.linspace(0.8, 0.9, 21)), "fast": _runs(segment, np.linspace(0.9, 1.1, 41))}
    fig = bands(runs, segment, None)
    axes = fig.axes
    assert len(axes) == 2
    positions = np.linspace(0.0, segment.distance, 600)
    for ax, (name, group) in zip(axes, runs.items()):
        polygons = [c for c in ax.collections if isinstance(c, PolyCollection)]
        assert len(polygons) == 1  # one band, not one artist per run
        medians = [line for line in ax.get_lines() if line.get_label() == "median"]
        assert len(medians) == 1 and len(ax.get_lines()) == 3  # the median, the speed limit and the stop
        low, median, high = to_kmh(speed_percentiles(group, positions))
        assert np.allclose(medians[0].get_ydata(), median)
        vertices = polygons[0].get_paths()[0].vertices
        # the band's outline runs along the 95th percentile and back along the 5th
        assert np.isclose(vertices[:, 1].max(), high.max()) and np.isclose(vertices[:, 1].min(), low.min())
        peak = np.argmax(median)
        assert low[peak] < median[peak] < high[peak]
        assert name in ax.get_title() and f"{len(group)} runs" in ax.get_title()
    # the percentiles are those of the runs: the fast group's median peak is 15 m/s (scale 1.0)
    assert np.isclose(to_kmh(speed_percentiles(runs["fast"], np.array([segment.distance / 2])))[1, 0],
                      to_kmh(15.0), rtol=1e-3)


def test_a_run_that_overshot_its_stop_is_drawn_to_where_it_stood_with_its_reason(metro, amsterdam):
    """An ato run of `ecostudy simulate` stood 16.66 m beyond Centraal: the band was cut at the stop
    (the train still at 22 km/h there) and its title said `1 runs, 0 ok` with no reason."""
    segment = make_segment(amsterdam, metro, "Rokin", "Centraal")
    end = segment.distance + 16.66
    run = {"profile": {"x": [0.0, 500.0, segment.distance, end], "v": [0.0, 15.0, 6.0, 0.0]}}
    reason = "flagged: stopped 16.66 m beyond the stop (tolerance 1 m)"
    fig = bands({"ato": [run]}, segment, None, ok={"ato": 0}, statuses={"ato draw 0": Status.parse(reason)})
    ax = fig.axes[0]
    line = next(line for line in ax.get_lines() if line.get_label() == "run")
    assert line.get_xdata()[-1] == end and line.get_ydata()[np.searchsorted(line.get_xdata(), segment.distance)] > 0
    stop = next(line for line in ax.get_lines() if line.get_label() == "stop")
    assert list(stop.get_xdata()) == [segment.distance] * 2
    assert ax.get_title() == f"ato: 1 runs, 0 ok (runs.csv's status)\ndraw 0 {reason}", ax.get_title()
