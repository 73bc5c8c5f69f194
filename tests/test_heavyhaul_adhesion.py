"""The plant's adhesion limit (switchable, ``adhesion: true``) and its energy balance: every joule the
efforts put in is a named loss or stored energy, with the effect on and off."""
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.physics import GRAVITY
from ecostudy.heavyhaul.plant import CascadePlant, curtius_kniffler
from ecostudy.io.loaders import load_consist

from .test_heavyhaul_study import PAPER, level, study


def test_adhesion_caps_the_locomotives_by_hand():
    """Curtius & Kniffler: mu = 0.161 + 7.5 / (v + 44), v in km/h: 0.3315 at rest, so a 126 t
    locomotive pulls at most 0.3315 * 126 t * g = 409.7 kN (its motors: 560 kN) and brakes
    dynamically at most mu(72 km/h) m g = 0.2257 * 126 t * g = 279.0 kN (its brake: 4800 kW / 20 m/s
    = 240 kN, which stays); wagons are not capped."""
    assert curtius_kniffler(0.0) == pytest.approx(0.161 + 7.5 / 44)
    consist = load_consist(PAPER)
    free, held = CascadePlant(consist, level()), CascadePlant(consist, level(), adhesion=True)
    for speed, (low, high) in ((0.0, (-400e3, 0.3315 * 126e3 * GRAVITY)), (20.0, (-240e3, 240e3))):
        lows, highs = held.envelopes(np.full(consist.cars, speed))
        assert highs[0] == pytest.approx(high, rel=1e-3) and lows[0] == pytest.approx(low, rel=1e-3)
        assert lows[5] == free.envelopes(np.full(consist.cars, speed))[0][5]  # a wagon: its brake
    assert free.envelopes(np.zeros(consist.cars))[1][0] == pytest.approx(560e3)


def test_the_energy_balance_closes_with_and_without_adhesion(tmp_path):
    """On the 5 km line (K_b = 1): traction - dynamic - wagon brakes = running + curve resistance +
    grade + coupler damping + the change of kinetic and coupler energy, within 0.1 % of traction
    (3e-5 kWh of 593 measured); with adhesion the start pulls less hard (980 -> 720 kN)."""
    runs = {}
    for adhesion in (False, True):
        out = tmp_path / str(adhesion)
        result = CliRunner().invoke(app, ["heavyhaul", str(study(tmp_path, brake_penalty=[1], adhesion=adhesion)),
                                          "--out", str(out), "--no-progress", "--no-plot"])
        assert result.exit_code == 0, result.output  # ok: the run stops within 1 m of the stop
        runs[adhesion] = run = pd.read_csv(out / "runs.csv").iloc[0]
        assert abs(run["balance_residual_kWh"]) < 1e-3 * run["traction_kWh"]
        assert run["running_resistance_kWh"] > 0 and run["coupler_damping_kWh"] > 0 and run["grade_kWh"] != 0
    assert runs[True]["force_max_kN"] < 0.9 * runs[False]["force_max_kN"]
    # the locomotives' largest effort against mu(v) m g: the paper's plant pulls its 560 kN motors past
    # the 409.7 kN a 126 t locomotive's wheels hold at rest (560 / 409.7 = 1.37); capped, at most the grip
    assert runs[False]["adhesion_use_max"] > 1.3 and runs[True]["adhesion_use_max"] <= 1.0 + 1e-6
