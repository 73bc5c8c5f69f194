"""Segments, train-length speed limits and grid placement."""
import numpy as np
from numpy.testing import assert_allclose

from ecostudy.core.grid import Profile, make_grid, make_segment, node_limits, train_length_limit


def test_train_length_limit_raises_only_when_tail_clears():
    limit = Profile(np.array([0.0, 100.0, 300.0]), np.array([20.0, 10.0, 25.0]))
    eff = train_length_limit(limit, 50.0)
    assert eff(99.0) == 20.0      # lowering applies when the head reaches it
    assert eff(100.0) == 10.0
    assert eff(320.0) == 10.0     # tail still in the 10 m/s section
    assert eff(350.0) == 25.0     # tail has left it


def test_grid_has_nodes_on_every_change(metro, amsterdam):
    seg = make_segment(amsterdam, metro, "Rokin", "Centraal")
    nodes = make_grid(seg, 500)
    assert len(nodes) == 500
    for b in seg.breakpoints():
        assert np.min(np.abs(nodes - b)) < 1e-9
    assert np.all(np.diff(nodes) > 0) and nodes[0] == 0 and nodes[-1] == seg.distance


def test_reverse_direction_mirrors_gradients(metro, amsterdam):
    fwd = make_segment(amsterdam, metro, "Rokin", "Centraal")
    bwd = make_segment(amsterdam, metro, "Centraal", "Rokin")
    x = np.linspace(1, fwd.distance - 1, 200)
    assert_allclose(bwd.gradient(fwd.distance - x), -fwd.gradient(x))


def test_node_limits_take_the_lower_side(metro, amsterdam):
    seg = make_segment(amsterdam, metro, "Rokin", "Centraal")
    nodes = make_grid(seg, 300)
    lim = node_limits(seg, nodes)
    at = np.argmin(np.abs(nodes - 950.0))  # 80 -> 60 km/h
    assert_allclose(lim[at] * 3.6, 60.0)
