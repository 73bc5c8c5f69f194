"""With air brakes the reference keeps below a limit on a descent by the speed the train gains while
its brakes lag (heavyhaul.reference.descent_margins, heavyhaul.airbrake.brake_lag)."""
import numpy as np
import pytest

from ecostudy.core.physics import GRAVITY
from ecostudy.core.types import Track
from ecostudy.heavyhaul.airbrake import brake_lag
from ecostudy.heavyhaul.reference import descent_margins, single_mass

from .test_heavyhaul_intrain import consist


def test_the_brakes_lag_is_the_wagons_mean_signal_delay_plus_the_build_up():
    """The ore train: the wagons' centres 2 x 20.47 + (j + 0.5) x 12.07 m behind the front (j = 0..199,
    every wagon the same brake), at 250 m/s, plus tau_b = 8 s."""
    mean_centre = 2 * 20.47 + 100 * 12.07
    assert brake_lag(consist()) == pytest.approx(mean_centre / 250.0 + 8.0, rel=1e-9)


def test_a_limit_is_lowered_by_the_speed_gained_while_the_brakes_lag_where_the_grade_needs_braking():
    """Level, -10 per mille, -1 per mille (held by the resistance), +5 per mille under 22 m/s, then
    18 m/s on the level: only the -10 piece is lowered, by (g 0.010 - R(22) / m) x 13 s; backwards the
    +5 piece is the descent."""
    train = single_mass(consist(), 0.3)
    zero = np.zeros(1)
    track = Track("t", 10000.0, {}, np.array([0.0, 2000, 4000, 6000, 8000]), np.array([0.0, -0.010, -0.001, 0.005, 0.0]),
                  zero, zero, np.array([0.0, 8000]), np.array([22.0, 18.0]))
    a, b, c = train.davis
    resisted = (a + b * 22.0 + c * 22.0 ** 2) / train.mass
    assert GRAVITY * 0.001 < resisted < GRAVITY * 0.005  # the -1 piece needs no braking, the +5 one would backwards
    lowered = descent_margins(track, train, 13.0)
    assert lowered.limit_positions.tolist() == [0, 2000, 4000, 8000]
    assert lowered.limits == pytest.approx([22.0, 22.0 - (GRAVITY * 0.010 - resisted) * 13.0, 22.0, 18.0], rel=1e-12)
    back = descent_margins(track, train, 13.0, forward=False)
    assert back.limits == pytest.approx([22.0, 22.0 - (GRAVITY * 0.005 - resisted) * 13.0, 18.0], rel=1e-12)
    assert back.limit_positions.tolist() == [0, 6000, 8000]
    assert descent_margins(track, train, 0.0) is track


def test_a_descent_of_several_pieces_keeps_its_largest_margin_throughout():
    """-10 then -6 per mille under one 22 m/s limit, then level, then -10 per mille again under 18 m/s:
    the first descent is lowered by the -10 piece's margin over both its pieces (the reference does not
    speed up between them), the second by its own, under its own limit."""
    train = single_mass(consist(), 0.3)
    zero = np.zeros(1)
    track = Track("t", 12000.0, {}, np.array([0.0, 2000, 4000, 6000, 8000]), np.array([0.0, -0.010, -0.006, 0.0, -0.010]),
                  zero, zero, np.array([0.0, 7000]), np.array([22.0, 18.0]))
    a, b, c = train.davis
    margin = [(GRAVITY * 0.010 - (a + b * v + c * v ** 2) / train.mass) * 13.0 for v in (22.0, 18.0)]
    assert GRAVITY * 0.006 > (a + b * 22.0 + c * 22.0 ** 2) / train.mass  # the -6 piece needs braking too
    lowered = descent_margins(track, train, 13.0)
    assert lowered.limit_positions.tolist() == [0, 2000, 6000, 7000, 8000]
    assert lowered.limits == pytest.approx([22.0, 22.0 - margin[0], 22.0, 18.0, 18.0 - margin[1]], rel=1e-12)
