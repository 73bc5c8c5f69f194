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
