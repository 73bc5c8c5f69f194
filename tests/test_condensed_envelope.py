"""The condensed SBPC program's envelope evaluation (``ocp.condensed._Envelope``) gives the numbers
of ``Envelope.smooth_function`` to the bit, for a table, a force-power hyperbola and no power limit,
and repeats its last answer for the same speed."""
import numpy as np
import pytest

from ecostudy.core.physics import Envelope
from ecostudy.ocp.condensed import DIFF, FORCE_SCALE, _Envelope

ENVELOPES = {
    "table": Envelope("table", speeds=(0.0, 10.0, 12.5, 15.0, 25.0), forces=(2e5, 2e5, 1.6e5, 1.33e5, 8e4), width=0.5),
    "force_power": Envelope("force_power", max_force=2e5, max_power=2e6),
    "no_power_limit": Envelope("force_power", max_force=2e5, max_power=float("inf")),
}


@pytest.mark.parametrize("name", ENVELOPES)
def test_the_fused_envelope_is_smooth_function_to_the_bit(name):
    envelope = ENVELOPES[name]
    f, fused = envelope.smooth_function(), _Envelope(envelope)
    speeds = np.concatenate([np.random.default_rng(3).uniform(-1.0, 30.0, 2000), [0.0, -0.0, 10.0, 10.0]])
    for v in map(float, speeds):
        expected = (f(v) / FORCE_SCALE, (f(v + DIFF) - f(v - DIFF)) / (2 * DIFF * FORCE_SCALE))
        assert fused(v) == expected, (name, v)
