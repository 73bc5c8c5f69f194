"""The locomotives' notches (switchable, ``notches: true``): every applied locomotive effort is a notch
of its envelope at its speed, by hand and in a closed-loop run; the energy balance closes with them;
bad notch data and a switch without data are refused in one line."""
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.heavyhaul.plant import LOSSES, CascadePlant, friction
from ecostudy.studies import heavyhaul
from ecostudy.studies.heavyhaul import drive, expand

from .conftest import write_yaml
from .test_heavyhaul_intrain import consist
from .test_heavyhaul_study import PAPER, level, study

P = 4800e3  # [W]: the shipped locomotive's traction and dynamic-brake power


def test_a_notch_applies_its_share_of_the_envelope_by_hand():
    """2 + 20 + 2 on the level, 20 s steps. Traction asked at 0.6 of the envelope (15 m/s, above 4800 kW /
    560 kN = 8.57 m/s: the power part) rounds to notch 5 of 8, so the four locomotives put in 0.625 x 4 x
    4800 kW x 20 s = 66.67 kWh whatever the speed does (without notches: 79.06 kWh, the request held as a
    force as the train speeds up). Dynamic braking asked at 0.3 of the envelope (20 m/s, above 4800 kW /
    400 kN = 12 m/s) rounds to notch 2 of 8: 0.25 x 4 x 4800 kW x 20 s = 26.67 kWh taken out."""
    c = consist(wagons=20)
    plant = CascadePlant(c, level(), notches=True)
    pull = np.where(plant.loco, 0.6 * P / 15.0, 0.0)
    step = plant.step(plant.quasi_static(5000.0, 15.0, pull), pull, 20.0)
    assert step.levels[plant.loco].tolist() == [0.625] * 4 and np.isnan(step.levels[~plant.loco]).all()
    assert step.traction_work == pytest.approx(0.625 * 4 * P * 20.0, rel=1e-6)
    assert step.state.speeds.min() > 8.6 and step.dynamic_brake_work == 0.0
    free = CascadePlant(c, level()).step(plant.quasi_static(5000.0, 15.0, pull), pull, 20.0)
    assert free.levels is None and free.traction_work > 1.1 * step.traction_work  # the old plant: 79.06 kWh
    brake = np.where(plant.loco, -0.3 * P / 20.0, 0.0)
    step = plant.step(plant.quasi_static(5000.0, 20.0, brake), brake, 20.0)
    assert step.levels[plant.loco].tolist() == [-0.25] * 4
    assert step.dynamic_brake_work == pytest.approx(0.25 * 4 * P * 20.0, rel=1e-6)
    assert step.state.speeds.min() > 12.0 and step.traction_work == 0.0


class Recording(CascadePlant):
    """The real plant, keeping every step it takes (and the request it was given)."""

    taken: list = []

    def step(self, state, requested, dt):
        result = super().step(state, requested, dt)
        Recording.taken.append((state, np.asarray(requested, float), result))
        return result


def test_a_closed_loop_run_applies_only_notches_and_its_energy_balance_closes(tmp_path, monkeypatch):
    """The 5 km line with a hump, K_b = 1, notches on: in every step (the controller's samples and the
    stopping sample's pieces) each locomotive's level is k/8 of its traction or dynamic-brake envelope,
    the effort it applies at every speed it passes through is that share of its envelope there, and
    some requests were off a notch (the rounding acted); traction - dynamic - wagon brakes = every named
    loss + the stored change within 0.1 % of traction; the train stops within 1 m."""
    monkeypatch.setattr(heavyhaul, "CascadePlant", Recording)
    Recording.taken = []
    _, _, _, cases = expand(study(tmp_path, brake_penalty=[1], notches=True))
    _, _, record, _, plant = drive(cases[0])
    assert Recording.taken and plant.notches.traction == 8
    off_notch = 0
    for state, requested, step in Recording.taken:
        levels = step.levels[plant.loco]
        assert np.allclose(levels * 8, np.rint(levels * 8)) and np.all(np.abs(levels) <= 1)
        dynamic, upper = (e[plant.loco] for e in plant.motor_envelopes(step.state.speeds))
        applied = plant.efforts(requested, step.state.speeds, step.levels)[plant.loco]
        assert np.allclose(applied, np.where(levels >= 0, levels * upper, levels * dynamic))
        _, _, _, speed, effort = step.adhesion  # an integrator point's applied effort (the most adhesion used)
        dynamic, upper = plant.motor_envelopes(np.full(plant.n, speed))
        share = effort / (upper[0] if effort >= 0 else dynamic[0] * friction(speed))  # a brake acts as friction
        assert share * 8 == pytest.approx(np.rint(share * 8), abs=1e-9)
        low, high = (e[plant.loco] for e in plant.envelopes(state.speeds))
        asked = requested[plant.loco]
        share = np.clip(asked, low, high) / np.where(asked >= 0, high, -low)
        off_notch += int(np.any(np.abs(share * 8 - np.rint(share * 8)) > 0.01))
    assert off_notch > 10 and any((s.levels[plant.loco] < 0).any() for _, _, s in Recording.taken)
    residual = (record.traction_work - record.dynamic_brake_work - record.wagon_brake_work - sum(record.losses)
                - record.stored_change)
    assert abs(residual) < 1e-3 * record.traction_work and record.stood
    assert record.losses[LOSSES.index("running_resistance")] > 0


def refusal(tmp_path, doc, name):
    """The one line `ecostudy heavyhaul` prints for a notches study with consist ``doc`` (as ``name``), exit 2."""
    path = study(tmp_path, consist=str(write_yaml(tmp_path / name, doc)), notches=True)
    result = CliRunner().invoke(app, ["heavyhaul", str(path), "--out", str(tmp_path / "o"), "--no-progress"])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1, result.output
    return lines[0]


@pytest.mark.parametrize("count", [0, -2])
def test_a_non_positive_notch_count_is_refused_in_one_line(tmp_path, count):
    """``notches: {traction: 0 or -2}`` in the consist file: exit 2, one line naming the file and the field;
    ``notches: true`` with a consist that gives no notches: one line naming the study and the field."""
    doc = yaml.safe_load(PAPER.read_text())
    doc["notches"]["traction"] = count
    line = refusal(tmp_path, doc, "bad_notches.yaml")
    assert "bad_notches.yaml" in line and "notches.traction" in line and "greater than 0" in line
    del doc["notches"]
    line = refusal(tmp_path, doc, "bare.yaml")
    assert "hh.yaml" in line and "notches" in line and "gives no notches data" in line
