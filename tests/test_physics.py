"""Physics functions against hand-computed values, on scalars, arrays and Pyomo expressions."""
import numpy as np
import pyomo.environ as pyo
from numpy.testing import assert_allclose

from ecostudy.core import physics


def test_davis_resistance_scalar_and_array():
    # Amsterdam metro, Farooqi 2018 §4.4: A + B v + C v^2 at 10 m/s = 3975.9 + 243.6 + 438
    assert_allclose(physics.davis_resistance(10.0, 3975.9, 24.36, 4.38), 4657.5)
    assert_allclose(physics.davis_resistance(np.array([0.0, 10.0]), 3975.9, 24.36, 4.38), [3975.9, 4657.5])


def test_gradient_force_uses_static_mass():
    # 131 403 kg on 20 per mille uphill: Ms g tan(alpha)
    assert_allclose(physics.gradient_force(131403.0, 0.020), 131403 * 9.80665 * 0.020)
    assert physics.gradient_force(1000.0, -0.01) < 0


def test_curve_force():
    assert_allclose(physics.curve_force(1e5, 6.0, 1 / 600), 1000.0)
    assert physics.curve_force(1e5, 6.0, 0.0) == 0.0


def test_hinge_is_smooth_max():
    x = np.array([-10.0, 0.0, 10.0])
    assert_allclose(physics.hinge(x, 0.01), [0.0, 0.005, 10.0], atol=1e-5)


def test_table_force_honours_table_within_tolerance():
    speeds = np.array([0, 10, 15, 20, 25.0])
    forces = np.array([200e3, 200e3, 133e3, 100e3, 80e3])
    width = physics.table_width(speeds, forces, tolerance=0.002)
    fine = np.linspace(0, 25, 2001)
    exact = np.interp(fine, speeds, forces)
    assert np.max(np.abs(physics.table_force(fine, speeds, forces, width) / exact - 1)) <= 0.002
    # constant beyond the ends
    assert_allclose(physics.table_force(np.array([30.0]), speeds, forces, width), [80e3], rtol=1e-3)


def test_same_formula_builds_pyomo_expressions():
    m = pyo.ConcreteModel()
    m.v = pyo.Var(initialize=12.0)
    expr = physics.davis_resistance(m.v, 3975.9, 24.36, 4.38)
    assert_allclose(pyo.value(expr), physics.davis_resistance(12.0, 3975.9, 24.36, 4.38))
    speeds, forces = np.array([0, 10, 20.0]), np.array([200.0, 200.0, 100.0])
    tab = physics.table_force(m.v, speeds, forces, 0.1)
    assert_allclose(pyo.value(tab), physics.table_force(12.0, speeds, forces, 0.1))


def test_envelope_force_power():
    env = physics.Envelope("force_power", max_force=200e3, max_power=2e6)
    assert_allclose(env.force(np.array([5.0, 10.0, 20.0])), [200e3, 200e3, 100e3])


def test_step_integral_against_quadrature():
    # a grade force in kN with steps at 100 m, 130 m and 400 m, rounded over 0.5 m
    cuts, values, w = [0.0, 100.0, 130.0, 400.0, 900.0], [-25.0, 12.0, 3.0, 40.0], 0.5
    coef = physics.step_integral(cuts, values, w)

    def smoothed(x):
        return physics.smooth_table_slope(x, coef, w)
    x = np.linspace(0.0, 900.0, 900_001)
    f = smoothed(x)
    quad = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(x))])  # trapezoid, 1 mm
    phi = physics.smooth_table(x, coef, w)
    assert_allclose(phi, quad, atol=1e-5)  # Phi is the smoothed step function's integral
    exact = np.interp(x, cuts, np.concatenate([[0.0], np.cumsum(np.multiply(values, np.diff(cuts)))]))
    jumps = np.abs(np.diff(values))
    assert np.max(np.abs(phi - exact)) <= 0.5 * w * jumps.sum()  # and the step function's within w/2 a step
    # away from the steps the smoothed function is the step function's value
    assert_allclose(smoothed(np.array([50.0, 115.0, 250.0, 650.0])), values, rtol=2e-3)
    # an 8 m interval over the step at 100 m: its mean is the step function's (1.5 m at -25, 6.5 m at 12)
    a, b = 98.5, 106.5
    mean = physics.interval_mean(physics.smooth_table(a, coef, w), physics.smooth_table(b, coef, w), b - a,
                                 smoothed(0.5 * (a + b)))
    assert_allclose(mean, (1.5 * -25.0 + 6.5 * 12.0) / 8.0, atol=0.5 * w * 37.0 / 8.0)  # within a step's w/2
    assert abs(smoothed(0.5 * (a + b)) - mean) > 5.0  # where the middle's value is far from it


def test_interval_mean_stands_still_and_takes_pyomo():
    coef = physics.step_integral([0.0, 10.0, 20.0], [1.0, 3.0], 0.5)
    phi = physics.smooth_table(10.0, coef, 0.5)
    middle = physics.smooth_table_slope(10.0, coef, 0.5)
    assert_allclose(middle, 2.0)
    assert_allclose(physics.interval_mean(phi, phi, 0.0, middle), 2.0)  # no length: the point's value
    m = pyo.ConcreteModel()
    m.a, m.b = pyo.Var(initialize=9.0), pyo.Var(initialize=11.0)
    expr = physics.interval_mean(physics.smooth_table(m.a, coef, 0.5), physics.smooth_table(m.b, coef, 0.5),
                                 m.b - m.a, physics.smooth_table_slope(0.5 * (m.a + m.b), coef, 0.5))
    assert_allclose(pyo.value(expr), 2.0, atol=1e-3)


def test_a_table_is_taken_for_a_force_and_power_limit_only_where_it_is_never_stronger():
    """A table whose points lie on min(F, P / v) was replaced by that curve even where its corner falls
    between two points: braking [0, 100] km/h -> [120, 80] kN became min(120 kN, 2222 kW / v), 120 kN
    at 50 km/h where the table says 100, and an all-out run on a flat 3 km line braked 387 m before the
    stop instead of the table's 437 m (an independent integration), verified ok. Now such a table stays
    a table; the shipped tables, sampled hyperbolas with the corner on a point, are still fitted."""
    from ecostudy.core.physics import force_power_fit
    from ecostudy.io.loaders import load_train

    from .conftest import TRAINS
    kmh = 1 / 3.6
    assert force_power_fit([0.0, 100 * kmh], [120e3, 80e3]) is None
    assert force_power_fit([0.0, 50 * kmh], [150e3, 100e3]) is None
    # corner on a point, the hyperbola 11 % below the chord at 54 km/h: the table says more
    assert force_power_fit([0, 36 * kmh, 72 * kmh, 108 * kmh], [150e3, 150e3, 75e3, 50e3]) is None
    for name in ("amsterdam_metro.yaml", "regional_alstom.yaml"):  # within CHORD_TOLERANCE below the chords
        assert load_train(TRAINS / name).traction.kind == "force_power", name
