"""The plant's in-train physics (air-brake propagation, draft gear), the metrics read from the
couplers (largest draft and buff, run-ins, rainflow), each against a case worked by hand; the
energy balance with every effect on; the switches and their bad input."""
import dataclasses
from collections import Counter

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.core.types import DraftGear
from ecostudy.heavyhaul import draftgear
from ecostudy.heavyhaul.airbrake import BrakePipe, signal_delays
from ecostudy.heavyhaul.fatigue import damage, rainflow
from ecostudy.heavyhaul.metrics import in_train_metrics, run_ins
from ecostudy.heavyhaul.plant import LOSSES, CascadePlant
from ecostudy.io.loaders import consist_from_document, load_consist

from .conftest import write_yaml
from .test_heavyhaul_study import PAPER, level, study


def consist(wagons=200, resistance=True, **changes):
    """The shipped ore train (2 + ``wagons`` + 2), without running resistance if asked."""
    doc = yaml.safe_load(PAPER.read_text())
    doc["vehicles"][1]["count"] = wagons
    if not resistance:
        for t in doc["types"].values():
            t["resistance"] = {"c0_mps2": 0, "c1_per_s": 0, "c2_per_m": 0}
    for key, value in changes.items():
        doc[key] = value
    return consist_from_document(doc, "test consist")


def test_rainflow_counts_the_astm_e1049_example():
    """ASTM E1049-85 §5.4.4, Fig. 6 and its table: the history -2, 1, -3, 5, -1, 3, -4, 4, -2 has
    half cycles of range 3, 6 and 9, 1.5 cycles of range 4 and one of range 8."""
    counts = Counter()
    for r, _, n in rainflow([-2, 1, -3, 5, -1, 3, -4, 4, -2]):
        counts[float(r)] += n
    assert dict(counts) == {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}
    # points between the turning points change nothing; Miner's proxy by hand (m = 3, range 1 per unit)
    assert rainflow([-2, 0, 1, -3, 5, 5, -1, 3, -4, 4, -2]) == rainflow([-2, 1, -3, 5, -1, 3, -4, 4, -2])
    by_hand = 0.5 * 27 + 1.5 * 64 + 0.5 * 216 + 512 + 0.5 * 729
    assert damage(rainflow([-2, 1, -3, 5, -1, 3, -4, 4, -2]), reference=1.0) == pytest.approx(by_hand)


def test_the_last_wagons_brake_starts_later_by_the_trains_length_over_the_signal_speed():
    """From the head's front the signal reaches the first wagon's centre after (2 x 20.47 + 6.035) m /
    250 m/s = 0.188 s and the last one's after (2 x 20.47 + 199.5 x 12.07) m / 250 m/s = 9.795 s;
    each then builds up as 1 - exp(-t / 8 s) of its command and is released as exp(-t / 17 s)."""
    c = load_consist(PAPER)
    delays = signal_delays(c, c.air_brake.signal_speed)
    first, last = 2, 201
    assert delays[first] == pytest.approx((2 * 20.47 + 6.035) / 250)
    assert delays[last] - delays[first] == pytest.approx(199 * 12.07 / 250)
    command = np.where(np.arange(c.cars) == first, -100e3, 0.0) + np.where(np.arange(c.cars) == last, -100e3, 0.0)
    pipe = BrakePipe(np.zeros(c.cars), np.zeros(c.cars), command, delays, c.air_brake)
    for k in (first, last):
        assert pipe.at(delays[k] - 1e-6)[k] == 0.0 and pipe.at(delays[k] + 1e-3)[k] < 0.0
        assert pipe.at(delays[k] + 8.0)[k] == pytest.approx(-100e3 * (1 - np.exp(-1)))
    # released 15 s on: the last wagon builds up until the release signal reaches it, then falls (17 s)
    released = BrakePipe(pipe.at(15.0), command, np.zeros(c.cars), delays, c.air_brake)
    reached = -100e3 + (pipe.at(15.0)[last] + 100e3) * np.exp(-delays[last] / 8.0)
    assert released.at(delays[last])[last] == pytest.approx(reached) and reached < pipe.at(15.0)[last]
    assert released.at(delays[last] + 17.0)[last] == pytest.approx(reached * np.exp(-1))


def test_a_command_sent_while_another_still_travels_reaches_each_wagon_in_turn():
    """The last wagon (9.795 s down the pipe) is sent -100 kN and, 1 s later, a release: the release
    is still travelling when the step starts; 12 s after the brake command it has built up for 1 s
    (1 - exp(-1/8)) and released for 12 - 10.795 s (exp(-t/17)); the first wagon (0.188 s) had both
    before the step."""
    c = load_consist(PAPER)
    delays = signal_delays(c, c.air_brake.signal_speed)
    first, last = 2, 201
    command = np.where(np.isin(np.arange(c.cars), [first, last]), -100e3, 0.0)
    zero = np.zeros(c.cars)
    forces = BrakePipe(zero, zero, command, delays, c.air_brake).at(1.0)  # the brake command's first second
    pipe = BrakePipe(forces, zero, zero, delays, c.air_brake, flight=[(1.0, command)])  # then the release
    built = -100e3 * (1 - np.exp(-1 / 8.0))
    assert pipe.at(11.0)[last] == pytest.approx(built * np.exp(-(12.0 - delays[last] - 1.0) / 17.0))
    assert pipe.at(delays[last] - 1.0 - 1e-6)[last] == pytest.approx(0.0)  # the brake not there yet
    head = -100e3 * (1 - np.exp(-(1.0 - delays[first]) / 8.0))  # applied for 1 s - d, released at 1 s + d
    on = -100e3 + (head + 100e3) * np.exp(-delays[first] / 8.0)
    assert pipe.at(11.0)[first] == pytest.approx(on * np.exp(-(11.0 - delays[first]) / 17.0))


def test_the_plant_brakes_alike_in_one_step_and_in_pieces_shorter_than_the_pipe():
    """The 20 s wagon braking of the next test taken as 5 steps of 4 s (shorter than the 9.8 s the
    signal needs to the last wagon, as the terminal approach's 1 s pieces are): the same brake forces
    and, to the integrator's tolerance, speeds at the end."""
    c = consist(resistance=False)
    plant = CascadePlant(c, level(), air_brake=True)
    state = plant.initial(5000.0, 15.0)
    command = np.where(plant.loco, 0.0, -20e3)
    whole = plant.step(state, command, 20.0).state
    pieces = state
    for _ in range(5):
        pieces = plant.step(pieces, command, 4.0).state
    assert np.allclose(pieces.brakes, whole.brakes, rtol=1e-9, atol=1e-6)
    assert np.allclose(pieces.speeds, whole.speeds, atol=1e-4) and len(pieces.sent) == 3  # sent at 8 (seen), 12, 16 s


def test_the_plant_brakes_with_the_impulse_of_the_delayed_lagged_brakes():
    """The ore train without resistance on the level at 15 m/s, every wagon commanded -20 kN for
    one 20 s step: the train's momentum falls by the brakes' impulse, sum over wagons of
    u (T - d_i - tau (1 - exp(-(T - d_i) / tau))) (the closed form of the first-order lag after its
    delay), 41.5 % of what instant brakes give."""
    c = consist(resistance=False)
    T, u, impulses = 20.0, -20e3, []
    for on in (True, False):
        plant = CascadePlant(c, level(), air_brake=on)
        state = plant.initial(5000.0, 15.0)
        step = plant.step(state, np.where(plant.loco, 0.0, u), T)
        impulse = float(np.dot(c.mass, step.state.speeds - state.speeds))
        wagons = ~plant.loco
        if on:
            d, tau = plant.delays[wagons], c.air_brake.build_up
            expected = float(np.sum(u * (T - d - tau * (1 - np.exp(-(T - d) / tau)))))
        else:
            expected = u * T * wagons.sum()
        assert impulse == pytest.approx(expected, rel=1e-4) and step.wagon_brake_work > 0
        impulses.append(impulse)
    assert impulses[0] / impulses[1] == pytest.approx(0.4155, abs=1e-4)


def two_cars(gear, damping=0.0):
    """A 126 t locomotive and a 66 t wagon, no resistance, the couplers' damping ``damping``."""
    c, cars = consist(wagons=1, resistance=False), [0, 2]
    return dataclasses.replace(c, kinds=tuple(c.kinds[i] for i in cars), mass=c.mass[cars], length=c.length[cars],
                               resistance=c.resistance[cars], traction=tuple(c.traction[i] for i in cars),
                               dynamic_brake=tuple(c.dynamic_brake[i] for i in cars),
                               pneumatic_brake=c.pneumatic_brake[cars], damping=damping, draft_gear=gear)


def test_slack_closes_when_the_dead_band_is_crossed_and_the_cars_then_collide_elastically():
    """The wagon runs into the standing locomotive at 0.1 m/s through 25 mm of slack (k_l = k_u =
    10 488 kN/m, no damping): nothing touches for 12.5 mm / 0.1 m/s = 0.125 s; then a spring contact
    of half a period pi sqrt(mu / k), mu = m1 m2 / (m1 + m2), 0.202 s, leaves the locomotive at
    2 m2 v / (m1 + m2) = 0.06875 m/s and the wagon at (m2 - m1) v / (m1 + m2) = -0.03125 m/s."""
    k, v = 10488e3, 0.1
    gear = DraftGear(0.025, k, k, 0.01, 1e-5)
    c = two_cars(gear)
    plant = CascadePlant(c, level(), draft_gear=True, rtol=1e-9)
    start = plant.initial(5000.0, 0.0)
    state = start._replace(speeds=np.array([0.0, v]))
    touch = 0.0125 / v
    before = plant.step(state, np.zeros(2), touch - 0.005)
    assert abs(before.state.speeds[0]) < 1e-6 and before.largest_coupler_force < 2.0
    m1, m2 = c.mass
    contact = np.pi * np.sqrt(m1 * m2 / (m1 + m2) / k)
    after = plant.step(before.state, np.zeros(2), 0.01 + contact)
    assert after.state.speeds == pytest.approx([2 * m2 * v / (m1 + m2), (m2 - m1) * v / (m1 + m2)], abs=2e-5)
    times, forces = plant.history[-1]
    pressed = times[np.abs(forces[:, 0]) > 100.0]  # above 100 N (0.01 mm): from touching to parting
    assert pressed[0] == pytest.approx(touch, abs=1e-3) and pressed[-1] == pytest.approx(touch + contact, abs=1e-3)
    assert abs(after.coupler_forces[0]) < 1.0 and after.losses[LOSSES.index("draft_gear")] == 0.0


def test_a_load_unload_cycle_dissipates_the_loop_area():
    """Stretch a coupling from 0 to 60 mm and back at 0.2 m/s (>> v_0 = 0.01 m/s): with 20 mm of
    slack the gear engages over 60 - 10 = 50 mm, and the loop between the loading (13 984 kN/m) and
    unloading (6 992 kN/m) lines holds (k_l - k_u) 0.05^2 / 2 = 8.74 kJ; the elastic part gives back
    what it took (its potential), the hysteresis part dissipates the loop."""
    gear = DraftGear(0.02, 13984e3, 6992e3, 0.01, 1e-5)
    x = np.concatenate([np.linspace(0, 0.06, 30001), np.linspace(0.06, 0, 30001)[1:]])
    rate = np.where(np.arange(x.size) <= 30000, 0.2, -0.2)
    elastic, hysteresis, damping = draftgear.forces(x, rate, gear, 0.0)
    dx = np.diff(x)
    loop = float(np.sum(0.5 * (hysteresis[1:] + hysteresis[:-1]) * dx))
    assert loop == pytest.approx((13984e3 - 6992e3) * 0.05 ** 2 / 2, rel=2e-3)
    assert abs(np.sum(0.5 * (elastic[1:] + elastic[:-1]) * dx)) < 1e-6 * loop and not damping.any()
    assert draftgear.potential(0.06, gear) == pytest.approx(0.5 * 10488e3 * 0.05 ** 2, rel=1e-3)
    # the loading line on the way out, the unloading line on the way back
    at = np.argmin(np.abs(x[:30001] - 0.04))
    assert elastic[at] + hysteresis[at] == pytest.approx(13984e3 * 0.03, rel=1e-3)
    back = 30001 + np.argmin(np.abs(x[30001:] - 0.04))
    assert elastic[back] + hysteresis[back] == pytest.approx(6992e3 * 0.03, rel=1e-3)
    # no slack and equal stiffnesses: the paper's linear coupler
    linear = DraftGear(0.0, 1e7, 1e7, 0.01, 1e-3)
    assert sum(draftgear.forces(np.array([0.01]), np.array([0.3]), linear, 1.5e6)) == pytest.approx(1e5 + 4.5e5)


def test_the_energy_balance_closes_with_every_effect_on():
    """A 2 + 20 + 2 ore train with air brakes, draft gears and adhesion, 5 per mille up then the
    level: pulling, braking with the wagons, releasing and pulling again (five 20 s steps): traction -
    dynamic - wagon brakes = running + curves + grade + damping + draft gear + the change of kinetic
    and elastic energy, within 0.1 % of traction; the draft gear dissipates."""
    c = consist(wagons=20)
    plant = CascadePlant(c, level(0.005), adhesion=True, air_brake=True, draft_gear=True)
    pull = np.where(plant.loco, 300e3, 0.0)
    brake = np.where(plant.loco, -50e3, -8e3)
    state = plant.quasi_static(5000.0, 12.0, pull)
    stored, works = plant.stored_energy(state), np.zeros(3 + len(LOSSES))
    for u in (pull, brake, brake, np.zeros(c.cars), pull):
        step = plant.step(state, u, 20.0)
        state = step.state
        works += [step.traction_work, step.dynamic_brake_work, step.wagon_brake_work, *step.losses]
    traction, dynamic, wagons, *losses = works
    residual = traction - dynamic - wagons - sum(losses) - (plant.stored_energy(state) - stored)
    assert abs(residual) < 1e-3 * traction
    assert losses[LOSSES.index("draft_gear")] > 0 and losses[LOSSES.index("coupler_damping")] > 0 and wagons > 0


def test_run_ins_draft_and_buff_read_from_a_history():
    """Coupler 2 of three goes 100 kN draft, 80 kN buff, 100 kN draft, 300 kN buff: two run-ins, one
    run-out; 30 kN wiggles stay under the 50 kN threshold; the largest draft is coupler 2's 100 kN
    (first at t = 1 s) and the largest buff its 300 kN at t = 4 s, 2 x 20.47 m behind the head."""
    c = load_consist(PAPER)
    forces = np.zeros((6, c.cars - 1))
    forces[:, 1] = [0, 100e3, -80e3, 100e3, -300e3, 0]
    forces[:, 0] = [0, 30e3, -30e3, 30e3, -30e3, 0]
    assert run_ins(forces)[0][:3].tolist() == [0, 2, 0] and run_ins(forces)[1][:3].tolist() == [0, 1, 0]
    m = in_train_metrics([(np.arange(6.0), forces)], c)
    assert (m["draft_max_kN"], m["draft_coupler"], m["draft_time_s"]) == (100.0, 2, 1.0)
    assert (m["buff_max_kN"], m["buff_coupler"], m["buff_time_s"]) == (300.0, 2, 4.0)
    assert m["buff_position_m"] == pytest.approx(2 * 20.47) and m["run_ins_count"] == 2
    assert m["fatigue_damage_coupler"] == 2 and m["rainflow_cycles_over_100kN_count"] == 2.5


def test_an_effect_without_its_data_is_refused_in_one_line(tmp_path):
    """``draft_gear: true`` with a consist that gives no draft_gear data: exit 2, one line naming the
    study file and the field; a gear that would make energy is refused by the consist's schema."""
    doc = yaml.safe_load(PAPER.read_text())
    del doc["draft_gear"]
    bare = write_yaml(tmp_path / "bare.yaml", doc)
    path = study(tmp_path, consist=str(bare), draft_gear=True)
    result = CliRunner().invoke(app, ["heavyhaul", str(path), "--out", str(tmp_path / "o"), "--no-progress"])
    assert result.exit_code == 2, result.output
    assert "draft_gear" in result.output and "gives no draft_gear data" in result.output
    doc = yaml.safe_load(PAPER.read_text())
    doc["draft_gear"]["unloading_stiffness_kN_per_m"] = 2e4
    with pytest.raises(Exception, match="must not exceed loading_stiffness_kN_per_m"):
        consist_from_document(doc, "gear")


def test_lagged_brakes_stop_a_train_and_never_drive_it_back():
    """A 2 + 20 + 2 ore train at 1 m/s on the level, its wagons braking 20 kN each for 20 s and then
    released: it stops within the first step while the brakes still build up, stays stopped while
    they are released (17 s), and the brakes put no energy in (balance within 0.1 % of the kinetic
    energy it had)."""
    c = consist(wagons=20)
    plant = CascadePlant(c, level(), air_brake=True)
    state = plant.initial(5000.0, 1.0)
    stored, works = plant.stored_energy(state), np.zeros(3 + len(LOSSES))
    for u in (np.where(plant.loco, 0.0, -20e3), np.zeros(c.cars)):
        step = plant.step(state, u, 20.0)
        state = step.state
        works += [step.traction_work, step.dynamic_brake_work, step.wagon_brake_work, *step.losses]
        assert np.abs(state.speeds).max() < 1e-3
    traction, dynamic, wagons, *losses = works
    residual = traction - dynamic - wagons - sum(losses) - (plant.stored_energy(state) - stored)
    assert abs(residual) < 1e-3 * stored and wagons > 0.5 * stored


@pytest.mark.slow
def test_draft_gear_slack_does_not_flood_the_run_with_numerical_warnings(tmp_path):
    """The ore train over the 5 km hump with draft gear, the observer and adhesion: a coupler in its
    slack is a flat force, on which scipy's finite-difference Jacobian grows its step without bound
    and numpy warned 170 times ("overflow / invalid value encountered in multiply") over a run that is
    otherwise sound; the run is ok, stops at its mark and prints no warning."""
    from .conftest import TRACKS
    path = study(tmp_path, track=str(TRACKS / "heavyhaul_hump_5km.yaml"), brake_penalty=[40], adhesion=True,
                 draft_gear=True, observer=True)
    r = CliRunner().invoke(app, ["heavyhaul", str(path), "--out", str(tmp_path / "o"), "--workers", "1", "--no-plot"])
    assert r.exit_code == 0, r.output
    assert "warning" not in r.output.lower() and "encountered" not in r.output, r.output
    assert "heavyhaul: ok" in r.output
