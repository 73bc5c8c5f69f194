"""The stepping plant (core/plant.py): step by step it reproduces the verification trace; a train
that is not the model stops where a hand calculation says; noise is seeded and recorded; a step's
adhesion use is taken at every edge it crosses."""
import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.control.loop import run_loop
from ecostudy.core.adhesion import Adhesion
from ecostudy.core.grid import Profile, Segment
from ecostudy.core.physics import Envelope
from ecostudy.core.plant import Cruise, Noise, Plant, Truth, adhesion_use
from ecostudy.core.types import State, Train

from .conftest import TRAINS, write_yaml


def drive(plant, control_at, dt, limit=300.0):
    """Step ``plant`` from standstill, ``control_at(state)`` held over each step, until it stops."""
    state, trace, work, moved = State(), [State()], 0.0, False
    while state.time < limit:
        step = plant.step(state, control_at(state), dt)
        state, work = step.state, work + step.traction_work
        trace.append(state)
        moved = moved or state.speed > 1.0
        if moved and state.speed <= 0.0:
            break
    return trace, work


def by_position(nodes, handle):
    return lambda s: float(handle[min(max(np.searchsorted(nodes, s.position, side="right") - 1, 0), len(handle) - 1)])


def by_time(times, handle):
    return lambda s: float(handle[min(max(np.searchsorted(times, s.time + 1e-9, side="right") - 1, 0), len(handle) - 1)])


def test_stepping_under_the_optimal_handle_reproduces_the_verification_trace(amsterdam_76s):
    r = amsterdam_76s
    trace, work = drive(Plant(r.segment, r.train), by_position(r.nodes, r.handle), dt=0.02)
    t = np.array([s.time for s in trace])
    v = np.array([s.speed for s in trace])
    ver = r.trace
    # the handle is sampled every 20 ms, so each switch comes up to one step late
    assert trace[-1].position == pytest.approx(ver.stop_position, abs=0.5)
    assert t[-1] == pytest.approx(ver.arrival_time, abs=0.1)
    assert work == pytest.approx(ver.traction_energy, rel=1e-3)
    assert np.max(np.abs(np.interp(t, ver.t, ver.v) - v)) < 0.1 / 3.6


def test_a_heavier_train_stops_where_the_hand_calculation_says():
    """Constant forces on a flat track: traction F_T for t1 = 20 s, then full braking F_B, against a
    constant resistance A. Every acceleration is a force over M, so with a 10 % heavier train
    driven on the same clock every position scales by 1 / 1.1: it stops 1/11 of the nominal
    distance short. Driven by position instead (brake at the same place), the mass cancels:
    v^2 = 2 x1 (F_T - A) / M and the braking distance M v^2 / (2 (F_B + A)) do not depend on M."""
    M, FT, FB, A, t1 = 200e3, 100e3, 150e3, 5e3, 20.0
    train = Train("analytic", M, M, 0.0, (A, 0.0, 0.0), Envelope("force_power", max_force=FT),
                  Envelope("force_power", max_force=FB))
    flat = Profile(np.array([0.0]), np.array([0.0]))
    segment = Segment(5000.0, flat, flat, Profile(np.array([0.0]), np.array([100.0])))
    a1, d = (FT - A) / M, (FB + A) / M
    x_brake = 0.5 * a1 * t1**2
    x_stop = x_brake + (a1 * t1) ** 2 / (2 * d)  # 95 m + 58.2 m = 153.2 m
    on_clock = by_time(np.array([0.0, t1]), [1.0, -1.0])
    at_place = by_position(np.array([0.0, x_brake, segment.distance]), [1.0, -1.0])
    nominal, _ = drive(Plant(segment, train), on_clock, dt=0.1)
    heavy, _ = drive(Plant(segment, train, Truth(mass=1.1)), on_clock, dt=0.1)
    assert nominal[-1].position == pytest.approx(x_stop, abs=0.01)
    assert heavy[-1].position == pytest.approx(x_stop / 1.1, abs=0.01)  # 13.9 m short
    assert nominal[-1].position - heavy[-1].position > 13.0
    heavy_by_place, _ = drive(Plant(segment, train, Truth(mass=1.1)), at_place, dt=0.01)
    # braking starts within one step (0.01 s at most 0.2 m/s) after x_brake
    assert heavy_by_place[-1].position == pytest.approx(x_stop, abs=0.3)


def test_on_the_metro_a_heavier_train_misses_the_stop_under_the_planned_handle(amsterdam_76s):
    """The Amsterdam optimum replayed open loop on a 10 % heavier train: on the planned clock it
    stops tens of metres short; by position it overruns a few metres (the Davis resistance and the
    power limits do not scale with the mass, so the mass no longer cancels)."""
    r = amsterdam_76s
    heavy = Plant(r.segment, r.train, Truth(mass=1.1))
    on_clock, _ = drive(heavy, by_time(r.trajectory.time, r.handle), dt=0.05)
    by_place, _ = drive(heavy, by_position(r.nodes, r.handle), dt=0.05)
    assert -80.0 < on_clock[-1].position - r.segment.distance < -20.0
    assert 1.0 < by_place[-1].position - r.segment.distance < 20.0


def test_noise_is_seeded_and_disturbs():
    M = 100e3
    train = Train("coaster", M, M, 0.0, (2e3, 0.0, 0.0), Envelope("force_power", max_force=50e3),
                  Envelope("force_power", max_force=80e3))
    flat = Profile(np.array([0.0]), np.array([0.0]))
    plant = Plant(Segment(2000.0, flat, flat, Profile(np.array([0.0]), np.array([40.0]))), train)
    noise = Noise(acceleration=0.05, position=1.0, speed=0.1, seed=7)

    def run(n):
        rng, state, seen = n.generator(), State(0.0, 10.0, 0.0), []
        for _ in range(50):
            state = plant.step(state, 0.0, 0.1, n.disturbance(rng)).state
            seen.append(n.measure(state, rng))
        return state, seen

    a, seen_a = run(noise)
    b, seen_b = run(noise)
    c, _ = run(Noise(acceleration=0.05, position=1.0, speed=0.1, seed=8))
    calm, seen_calm = run(Noise())
    assert a == b and seen_a == seen_b
    assert a != c and abs(a.position - calm.position) > 1e-3
    assert seen_calm[-1] == calm  # no noise: the sensor reads the state
    # coasting 5 s from 10 m/s against 2 kN on 100 t: 0.02 m/s^2, v = 9.9 m/s, x = 49.75 m
    assert calm.speed == pytest.approx(9.9, abs=1e-9) and calm.position == pytest.approx(49.75, abs=1e-8)


def hump_plant(traction=150e3, max_acceleration=float("inf")):
    """200 t on level track with a 3 % hump from ``HUMP[0]`` to ``HUMP[1]`` m, held by mu = 0.3 on
    its 200 t (588 kN): the resistance, and so a force that follows it, jumps at the hump's edges."""
    M = 200e3
    train = Train("hump", M, M, 0.0, (5e3, 0.0, 0.0), Envelope("force_power", max_force=traction),
                  Envelope("force_power", max_force=150e3), max_acceleration=max_acceleration,
                  adhesion=Adhesion(M, "constant", 0.3))
    flat = Profile(np.array([0.0]), np.array([0.0]))
    grade = Profile(np.array([0.0, HUMP[0], HUMP[1]]), np.array([0.0, 0.03, 0.0]))
    return Plant(Segment(2000.0, grade, flat, Profile(np.array([0.0]), np.array([40.0]))), train)


HUMP = (102.0, 110.0)


def test_a_step_takes_the_adhesion_use_at_the_edges_it_crosses():
    """Cruise control holds 10 m/s with F = F_R(x, v): 5 kN on the level, 64 kN on the hump (0.11
    of the grip). A 2 s step from 95 m to 115 m crosses the whole hump: its two ends (what the closed
    loop read) ask 0.0085 of the grip, the step's piece ends the hump's 0.11."""
    plant, hold = hump_plant(), Cruise(10.0)
    step = plant.step(State(95.0, 10.0, 0.0), hold, 2.0)
    assert step.state.position == pytest.approx(115.0, abs=1e-6)  # F = F_R: the speed held throughout
    ends = adhesion_use(plant, [95.0, step.state.position], [10.0, step.state.speed], [hold, hold])
    on_hump = adhesion_use(plant, [105.0], [10.0], [hold])
    assert ends == pytest.approx(5e3 / (0.3 * 200e3 * 9.81), rel=1e-3)
    assert on_hump > 10 * ends and step.adhesion == pytest.approx(on_hump, rel=1e-9)
    # a train without an adhesion limit: nothing computed, the same step
    free = Plant(plant.segment, replace(plant.train, adhesion=None))
    bare = free.step(State(95.0, 10.0, 0.0), hold, 2.0)
    assert bare.adhesion is None and bare[:6] == step[:6]


class FullTraction:
    solve_seconds: list = []

    def plan(self, measured):
        return 1.0


def test_the_closed_loop_takes_the_adhesion_use_where_a_step_crosses_an_edge():
    """Full traction capped at 0.5 m/s^2 (F_T = M a + F_R): 105 kN on the level, 164 kN on the hump
    (0.18 and 0.28 of the grip). In 2 s samples (plant steps) from a stand the train is at 100 m
    after 20 s and at 121 m after 22 s: no step ends on the hump, and the use at the steps' ends,
    all the loop read, is the level's."""
    plant = hump_plant(traction=300e3, max_acceleration=0.5)
    loop = run_loop(plant, FullTraction(), 2.0, plant_step=2.0, until=130.0)
    positions = [s.position for s in loop.states]
    assert not any(HUMP[0] <= x <= HUMP[1] for x in positions) and positions[-1] > HUMP[1]
    at_ends = adhesion_use(plant, positions, [s.speed for s in loop.states], [1.0] * len(positions))
    on_hump = adhesion_use(plant, [105.0], [10.0], [1.0])
    assert at_ends == pytest.approx(105e3 / (0.3 * 200e3 * 9.81), rel=1e-3) and on_hump > at_ends + 0.09
    assert loop.adhesion_use_max == pytest.approx(on_hump, rel=1e-3)  # the hump's speeds, 10.0-10.4 m/s


@pytest.mark.parametrize("sample_time, plant_step, named", [(0.0, 0.1, "sample time"), (-1.0, 0.1, "sample time"),
                                                            (float("nan"), 0.1, "sample time"), (0.1, 0.0, "plant step")])
def test_a_loop_without_a_clock_is_refused(sample_time, plant_step, named):
    """A sample of 0 s never advanced the clock (the loop ran for ever); a plant step of 0 s divided by
    zero. A sample shorter than the plant step is one step of the sample."""
    with pytest.raises(ValueError, match=f"the {named} is a number of seconds > 0"):
        run_loop(hump_plant(), FullTraction(), sample_time, plant_step=plant_step)
    short = run_loop(hump_plant(traction=300e3, max_acceleration=0.5), FullTraction(), 0.5, plant_step=2.0, until=1.0)
    assert [round(s.time, 9) for s in short.states[:3]] == [0.0, 0.5, 1.0]


def test_a_train_braked_into_a_slow_limit_on_a_descent_is_replayed_past_its_first_interval(tmp_path):
    """The commuter's all-out run (K = 200) down 30 per mille brakes in full from 80 to 10 km/h into
    a 10 km/h limit at 1000 m, then holds 10 km/h on part of its brakes. The replay's integrator
    took one step from before 1000 m to beyond the train's stop under full braking, by when the
    brakes had driven it back behind 1000 m: both ends of the step before the interval's end, its
    crossing was missed, and the replay braked in full to a stand at 1005 m, 495 m short of its
    stop (verification -494.6 m, -178.9 s). A train its brakes hold stands; the replay reaches the
    stop (-0.01 m, +0.11 s)."""
    track = write_yaml(tmp_path / "descent.yaml", {
        "name": "descent", "source": "test", "length_m": 1500,
        "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 1500}],
        "gradients": [{"position_m": 0, "gradient_permille": -30}],
        "speed_limits": [{"position_m": 0, "speed_kmh": 80}, {"position_m": 1000, "speed_kmh": 10}]})
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["solve", "--track", str(track), "--train", str(TRAINS / "yazhemsky2017_commuter.yaml"),
                                      "--objective", "time", "-K", "200", "--no-plot", "--no-progress", "--out", str(out)])
    check = json.loads((out / "summary.json").read_text())["verification"]
    assert abs(check["stop_error_m"]) < 1.0 and abs(check["arrival_time_error_s"]) < 0.5, check
    assert result.exit_code == 0, result.output
