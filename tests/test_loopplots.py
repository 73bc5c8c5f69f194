"""The bands plot of a closed-loop study: per controller the 5-95 % band of the runs' speeds over
position (one fill_between polygon) and their median (one line), not an overlay of every run."""
import numpy as np
from matplotlib.collections import PolyCollection

from ecostudy.core.grid import make_segment
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
        assert len(medians) == 1 and len(ax.get_lines()) == 2  # the median and the speed limit
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
