"""Segments, train-length speed limits and grid placement."""
import dataclasses
import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from ecostudy.core.errors import EcostudyWarning
from ecostudy.core.grid import MIN_INTERVALS, Profile, make_grid, make_segment, node_limits, train_length_limit
from ecostudy.io.loaders import load_track, load_train

from .conftest import solve_written


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


def test_every_piece_between_changes_gets_at_least_two_intervals(metro, amsterdam):
    """A 2 m piece before a 0.5 km/h restriction, on a 1000 m segment with K = 100: its share in
    proportion to length would be one interval, which is given MIN_INTERVALS (taken from the
    longest piece); a segment whose pieces are all long enough is not moved."""
    seg = make_segment(amsterdam, metro, "Rokin", "Centraal")
    short = dataclasses.replace(seg, limit=Profile(np.array([0.0, 2.0, 30.0]), np.array([20.0, 0.5 / 3.6, 20.0])))
    nodes = make_grid(short, 100)
    assert len(nodes) == 100
    edges = np.searchsorted(nodes, np.concatenate([[0.0], short.breakpoints(), [short.distance]]))
    assert np.diff(edges).min() == MIN_INTERVALS == 2


def test_a_short_piece_before_a_restriction_does_not_slow_the_all_out_run(tmp_path):
    """All-out over a flat 1000 m with 0.5 km/h from 2 m to 30 m (72 km/h elsewhere): a fine-step
    forward/backward integration of the same train gives 268.69 s; with one interval on the first
    2 m the NLP had to crawl it at the mean of 0 and 0.5 km/h (295.09 s at K = 100 and 300)."""
    r, out = solve_written(
        tmp_path, "name: b\nsource: test\nmass_t: 100\nrotating_mass_factor: 0.1\nlength_m: 0\n"
        "davis: {a_N: 3000, b_N_per_mps: 0, c_N_per_mps2: 0}\ntraction: {max_force_kN: 200}\n"
        "braking: {max_force_kN: 100}\ntraction_efficiency: 0.8\n",
        "name: zero\nsource: test\nlength_m: 1000\nstops:\n  - {name: A, position_m: 0}\n"
        "  - {name: B, position_m: 1000}\nspeed_limits:\n  - {position_m: 0, speed_kmh: 72}\n"
        "  - {position_m: 2, speed_kmh: 0.5}\n  - {position_m: 30, speed_kmh: 72}\n",
        "--objective", "time", "--points", "100")
    assert r.exit_code == 0, r.output
    running = json.loads((out / "summary.json").read_text())["running_time_s"]
    assert running == pytest.approx(268.69, rel=0.01)


def test_a_tunnel_outside_the_trains_listed_cross_sections_is_warned_of(tmp_path):
    """An 80 m² tunnel on a train that lists 40 m² only is costed at 40 m²: a warning names the track
    file, the tunnel's position and the train's listed sections; a 40 m² tunnel warns of nothing."""
    train = tmp_path / "train.yaml"
    train.write_text("name: tunnelled\nsource: test\nmass_t: 100\nrotating_mass_factor: 0.1\nlength_m: 0\n"
                     "davis: {a_N: 3000, b_N_per_mps: 0, c_N_per_mps2: 0}\ntraction: {max_force_kN: 200}\n"
                     "braking: {max_force_kN: 100}\n"
                     "tunnel_resistance:\n  - {cross_section_m2: 40, c_kN_per_kmh2: 0.0001}\n")
    for area in (80, 40):
        track = tmp_path / f"track{area}.yaml"
        track.write_text(f"name: tunnel {area}\nsource: test\nlength_m: 1000\nstops:\n  - {{name: A, position_m: 0}}\n"
                         "  - {name: B, position_m: 1000}\nspeed_limits:\n  - {position_m: 0, speed_kmh: 72}\n"
                         f"tunnels:\n  - {{position_m: 300, length_m: 300, cross_section_m2: {area}}}\n")
        if area == 40:  # in the list: no warning (pyproject makes one an error)
            make_segment(load_track(track), load_train(train), "A", "B")
            continue
        with pytest.warns(EcostudyWarning) as seen:
            make_segment(load_track(track), load_train(train), "A", "B")
        assert [str(w.message) for w in seen] == [
            f"{track.resolve()}: tunnels: the tunnel at 300 m has a cross section of 80 m², outside the 40 m² train "
            "'tunnelled' gives a tunnel_resistance for: costed as 40 m²"]
