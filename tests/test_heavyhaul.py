"""The cascade plant of Zhang & Zhuan eq. 1: hand calculations on a two-car
train and on the paper's 204-car ore train."""
import dataclasses

import numpy as np
import pytest

from ecostudy.core.grid import Profile, Segment
from ecostudy.core.physics import GRAVITY, Envelope
from ecostudy.core.types import Consist
from ecostudy.heavyhaul.plant import CascadePlant
from ecostudy.heavyhaul.reference import table_reference
from ecostudy.io.loaders import load_consist

from .conftest import TRAINS


def flat(distance=50000.0, grade=None):
    starts, values = (np.array([0.0]), np.array([0.0])) if grade is None else grade
    return Segment(distance, Profile(starts, values), Profile(np.zeros(1), np.zeros(1)),
                   Profile(np.zeros(1), np.array([30.0])))


def two_cars(resistance=0.0, damping=150e3):
    big = Envelope("force_power", max_force=1e6)
    return Consist("two", ("locomotive", "wagon"), np.array([100e3, 60e3]), np.array([20.0, 12.0]),
                   np.array([[resistance, 0.0, 0.0]] * 2), (big, None), (big, None), np.array([0.0, 100e3]),
                   stiffness=5e6, damping=damping, force_limit=1e6)


def test_two_cars_momentum_is_exact_and_the_coupler_carries_the_wagons_share():
    """A locomotive pulling a wagon with F = 80 kN on flat track: the centre of mass accelerates at
    F / (m1 + m2) = 0.5 m/s^2 whatever the couplers do; once the coupler's oscillation has died out
    it carries F m2 / (m1 + m2) = 30 kN and both cars have the same speed."""
    plant = CascadePlant(two_cars(), flat())
    state = plant.initial(head=100.0, speed=10.0)
    for _ in range(6):
        step = plant.step(state, [80e3, 0.0], 10.0)
        state = step.state
    mean = float(np.dot(plant.consist.mass, state.speeds) / plant.consist.mass.sum())
    assert mean == pytest.approx(10.0 + 0.5 * 60.0, rel=1e-7)
    assert step.coupler_forces[0] == pytest.approx(30e3, rel=1e-4)
    assert state.speeds[0] == pytest.approx(state.speeds[1], abs=1e-6)
    assert step.traction_work > 0 and step.dynamic_brake_work == 0 and step.wagon_brake_work == 0


def test_efforts_are_clipped_to_each_cars_envelope():
    plant = CascadePlant(two_cars(), flat())
    u = plant.efforts(np.array([5e6, -5e6]), np.array([10.0, 10.0]))
    assert list(u) == [1e6, -100e3]  # traction envelope; a wagon brakes, never pulls
    assert plant.efforts(np.array([-5e6, 5e6]), np.array([10.0, 10.0]))[1] == 0.0


def test_every_car_feels_its_own_grade():
    """A 10 per-mille climb starting between the two cars: only the head car is on it; the
    accelerations at that instant follow by hand (coupler at its free length, equal speeds)."""
    seg = flat(grade=(np.array([0.0, 90.0]), np.array([0.0, 0.010])))
    plant = CascadePlant(two_cars(), seg)
    state = plant.initial(head=100.0, speed=10.0)  # head at 100 m (on the climb), wagon at 84 m
    d = plant.derivatives(np.concatenate([state.positions, state.speeds, [0, 0, 0]]), np.array([0.0, 0.0]))
    assert d[2] == pytest.approx(-GRAVITY * 0.010) and d[3] == pytest.approx(0.0)


def test_the_ore_train_in_steady_pull_keeps_the_static_in_train_forces():
    """Zhang & Zhuan's train (2 + 200 + 2, 13 704 t) at 15 m/s on flat track, the four locomotives
    each pulling a quarter of the whole train's running resistance, started in the quasi-static
    state: it holds its speed for a minute and every coupler keeps carrying the sum of (effort -
    resistance) of the cars ahead (within 1 N): tension behind the head locomotives, compression
    ahead of the tail ones, none in the middle; far below the 2000 kN limit."""
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    assert consist.cars == 204 and consist.mass.sum() == pytest.approx(13_704e3)
    plant = CascadePlant(consist, flat())
    resist = plant.resistance(plant.initial(3000.0, 15.0).positions, np.full(consist.cars, 15.0))
    u = np.zeros(consist.cars)
    u[consist.locomotives] = resist.sum() / 4
    state = plant.quasi_static(3000.0, 15.0, u)
    expected = np.cumsum(u - resist)[:-1]
    for _ in range(3):
        step = plant.step(state, u, 20.0)
        state = step.state
    assert np.max(np.abs(step.coupler_forces - expected)) < 1.0
    assert np.all(np.abs(state.speeds - 15.0) < 1e-6)
    assert step.coupler_forces[1] == pytest.approx(2 * u[0] - resist[:2].sum()) and abs(step.coupler_forces[101]) < 1.0
    assert step.largest_coupler_force < consist.force_limit


def test_a_train_started_unstretched_swings_slowly_about_the_static_forces():
    """Started with every coupler at its free length, the same train does not settle within a
    minute: the slowest longitudinal mode of a 2.5 km chain (about 33 s for a wave there and back
    at sqrt(k/m) 12 m = 151 m/s) is barely damped by the couplers; the centre of mass still keeps
    its speed exactly (the efforts equal the resistance)."""
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    plant = CascadePlant(consist, flat())
    state = plant.initial(3000.0, 15.0)
    u = np.zeros(consist.cars)
    u[consist.locomotives] = plant.resistance(state.positions, state.speeds).sum() / 4
    swings = []
    for _ in range(6):
        state = plant.step(state, u, 10.0).state
        swings.append(state.speeds[0] - state.speeds[101])
        assert np.dot(consist.mass, state.speeds) / consist.mass.sum() == pytest.approx(15.0, abs=1e-5)
    assert max(swings) > 0.02 and min(swings) < -0.02  # the head and the middle swap leads


def test_the_design_model_predicts_the_plant_over_one_sample():
    """Zhang & Zhuan eq. 2 (linearised, damping left out, ZOH at Ts = 20 s) against the nonlinear
    cascade plant: +50 kN on each locomotive from the quasi-static state at 15 m/s moves the mean
    speed by 0.2916 m/s in the model and 0.2902 m/s in the plant (0.5 %); the head and middle cars
    within 3 %; the coupler-force changes behind the head within 6 %. With c1 = 0 the model keeps
    momentum exactly: sum m dv = Ts sum du."""
    from ecostudy.heavyhaul.linear import design_model
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    plant = CascadePlant(consist, flat())
    n = consist.cars
    resist = plant.resistance(plant.initial(3000.0, 15.0).positions, np.full(n, 15.0))
    u = np.zeros(n)
    u[consist.locomotives] = resist.sum() / 4
    du = np.zeros(n)
    du[consist.locomotives] = 50e3
    state = plant.quasi_static(3000.0, 15.0, u)
    step = plant.step(state, u + du, 20.0)
    model = design_model(consist.mass, consist.resistance[:, 1], np.full(n - 1, consist.stiffness), 20.0)
    predicted = model.B @ du  # from the operating point (deviation 0)
    dv_plant = step.state.speeds - state.speeds
    mean = lambda dv: np.dot(consist.mass, dv) / consist.mass.sum()  # noqa: E731
    assert mean(predicted[:n]) == pytest.approx(mean(dv_plant), rel=0.01)
    assert predicted[[0, 101]] == pytest.approx(dv_plant[[0, 101]], rel=0.03)
    dfin = step.coupler_forces - plant.coupler_forces(state.positions, state.speeds)
    assert consist.stiffness * predicted[n:n + 3] == pytest.approx(dfin[:3], rel=0.06)
    lossless = design_model(consist.mass, np.zeros(n), np.full(n - 1, consist.stiffness), 20.0)
    assert np.dot(consist.mass, (lossless.B @ du)[:n]) == pytest.approx(20.0 * du.sum(), rel=1e-9)


def test_the_fence_method_keeps_the_slow_mode_and_the_momentum():
    """Virtual cars of f = 10 never mixing locomotives and wagons: n_f = 1 + 20 + 1 = 22 (paper
    002 §III-C). With couplers in series between virtual-car centres the slowest longitudinal mode
    keeps its period (32.94 s full, 32.97 s reduced) and a step of efforts moves the mean speed
    alike; efforts shared back to the cars in proportion to mass sum to the virtual car's."""
    from ecostudy.heavyhaul.linear import design_model, fence, virtual_car_count
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    n = consist.cars
    reduced = fence(consist, 10, 20.0)
    assert len(reduced.members) == virtual_car_count([2, 200, 2], 10) == 22
    assert all(len({consist.kinds[i] for i in cars}) == 1 for cars in reduced.members)

    def slowest_period(model):
        w = np.sort(np.abs(np.linalg.eigvals(model.Ac).imag))
        return 2 * np.pi / w[w > 1e-6][0]

    full = design_model(consist.mass, np.zeros(n), np.full(n - 1, consist.stiffness), 20.0)
    lossless = fence(dataclasses.replace(consist, resistance=consist.resistance * 0), 10, 20.0)
    assert slowest_period(full) == pytest.approx(32.94, abs=0.01)
    assert slowest_period(lossless.model) == pytest.approx(slowest_period(full), rel=0.002)
    du = np.zeros(n)
    du[consist.locomotives] = 50e3
    virtual = reduced.reduce(du)
    assert virtual.sum() == pytest.approx(du.sum()) and reduced.share(virtual, consist.mass).sum() == pytest.approx(du.sum())
    full_c1 = design_model(consist.mass, consist.resistance[:, 1], np.full(n - 1, consist.stiffness), 20.0)
    mean_full = np.dot(consist.mass, (full_c1.B @ du)[:n]) / consist.mass.sum()
    vm = (reduced.model.B @ virtual)[:22]
    assert np.dot(reduced.model.mass, vm) / reduced.model.mass.sum() == pytest.approx(mean_full, rel=1e-3)
    # the other settings: one real coupler per virtual coupler makes the reduced train stiffer (its
    # slow mode about sqrt(10) times quicker); equal sharing gives every car of a virtual car the same
    single = fence(dataclasses.replace(consist, resistance=consist.resistance * 0), 10, 20.0, coupling="single")
    assert slowest_period(single.model) < 0.5 * slowest_period(full)
    equal = fence(consist, 10, 20.0, sharing="equal").share(np.full(22, 100e3), consist.mass)
    assert equal[0] == pytest.approx(50e3) and equal[2] == pytest.approx(10e3) and equal.sum() == pytest.approx(2.2e6)


def test_the_receding_horizon_controller_tracks_a_new_reference_within_the_limits():
    """Zhang & Zhuan's RHC (eqs. 4-8; Ts = 20 s, Np = 8, Nc = 4, K_f = 10, K_v = 60, K_e = 10,
    K_b = 40) on the fence-reduced model (f = 10, 22 virtual cars) drives the full 204-car plant
    on flat track from 15 m/s to a new reference of 20 m/s: the mean speed never exceeds the
    reference (eq. 7), reaches it within 0.05 m/s in 8 samples, in-train forces stay far below
    2000 kN, the locomotives' efforts move by at most the 200 kN rate limit per sample, and each
    QP solves (Ipopt on one model written once, bounds changed) in well under Ts."""
    from ecostudy.heavyhaul.linear import fence
    from ecostudy.heavyhaul.loop import run
    from ecostudy.heavyhaul.rhc import RecedingHorizon
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    plant = CascadePlant(consist, flat(60000.0))
    reduction = fence(consist, 10, 20.0)
    kinds = reduction.kinds
    controller = RecedingHorizon(reduction.model, kinds, np_=8, nc=4)
    resist = plant.resistance(plant.initial(5000.0, 15.0).positions, np.full(consist.cars, 15.0))
    u = np.zeros(consist.cars)
    u[consist.locomotives] = resist.sum() / 4
    state = plant.quasi_static(5000.0, 15.0, u)
    controller.previous = reduction.reduce(u) / 1e3
    state, rec = run(plant, reduction, controller, state, table_reference([0.0, 1e6], [72.0, 72.0]), 10)
    assert np.all(rec.mean_speed <= 20.0 + 0.01)
    assert abs(rec.mean_speed[7] - 20.0) < 0.05 and abs(rec.mean_speed[-1] - 20.0) < 0.05
    assert rec.largest_coupler.max() < 0.5 * consist.force_limit
    locos = reduction.locomotives
    steps = np.abs(np.diff(np.vstack([reduction.reduce(u)[None, :], rec.efforts])[:, locos], axis=0))
    assert steps.max() <= 200e3 * 1.001
    assert rec.traction_work > 0 and np.all(rec.solve_seconds > 0.0)  # every solve timed (no bound on the time: shared machines)


def test_the_kalman_observer_recovers_speeds_and_extensions_from_the_locomotives():
    """Eq. 10 on the fence-reduced model (22 virtual cars, the two locomotive groups measured),
    fed the measured locomotive speeds of the full plant while the locomotives accelerate it: from
    an estimate that starts with every wagon group 1 m/s off and no coupler extension, the
    estimated wagon speeds come within 0.05 m/s of the plant's (mass-weighted) after 20 samples
    (0.6 m/s off after 10), the extensions within 0.05 m; the observability matrix has full rank."""
    from ecostudy.heavyhaul.linear import fence
    from ecostudy.heavyhaul.loop import reduced_state
    from ecostudy.heavyhaul.observer import KalmanObserver
    from ecostudy.heavyhaul.rhc import input_offsets
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    plant = CascadePlant(consist, flat(60000.0))
    reduction = fence(consist, 10, 20.0)
    kinds = reduction.kinds
    nv = len(kinds)
    resist = plant.resistance(plant.initial(5000.0, 15.0).positions, np.full(consist.cars, 15.0))
    u = np.zeros(consist.cars)
    u[consist.locomotives] = resist.sum() / 4 + 20e3
    state = plant.quasi_static(5000.0, 15.0, u)
    truth = reduced_state(plant, reduction, state)
    guess = truth.copy()
    guess[1:nv - 1] += 1.0
    guess[nv:] = 0.0
    observer = KalmanObserver(reduction.model, kinds, estimate=guess)
    C, A = observer.C, reduction.model.A
    powers = [np.eye(len(A))]
    for _ in range(len(A) - 1):
        powers.append(powers[-1] @ A)
    assert np.linalg.matrix_rank(np.vstack([C @ p for p in powers]), tol=1e-9) == 2 * nv - 1
    errors = []
    for _ in range(20):
        speeds = reduction.reduce(state.speeds, consist.mass)
        shifted = reduction.reduce(u) - input_offsets(reduction.model.mass, reduction.resistance, speeds, np.zeros(nv))
        estimate = observer.update(speeds[reduction.locomotives], shifted)
        state = plant.step(state, u, 20.0).state
        truth = reduced_state(plant, reduction, state)
        errors.append(np.max(np.abs(estimate[1:nv - 1] - truth[1:nv - 1])))
    assert errors[0] > 0.1 and errors[-1] < 0.05
    assert np.max(np.abs(estimate[nv:] - truth[nv:])) < 0.05  # m; "truth" for a virtual coupler: boundary force / k


def test_the_loop_with_the_observer_tracks_like_the_loop_with_the_true_state():
    """The same 15 -> 20 m/s manoeuvre, the controller fed by the Kalman observer (eq. 10, from
    the locomotives' speeds only, started from the quasi-static estimate): it stays within the
    limits and ends within 0.1 m/s of the reference; no solve overran Ts."""
    from ecostudy.heavyhaul.linear import fence
    from ecostudy.heavyhaul.loop import reduced_state, run
    from ecostudy.heavyhaul.observer import KalmanObserver
    from ecostudy.heavyhaul.rhc import RecedingHorizon
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    plant = CascadePlant(consist, flat(60000.0))
    reduction = fence(consist, 10, 20.0)
    kinds = reduction.kinds
    resist = plant.resistance(plant.initial(5000.0, 15.0).positions, np.full(consist.cars, 15.0))
    u = np.zeros(consist.cars)
    u[consist.locomotives] = resist.sum() / 4
    state = plant.quasi_static(5000.0, 15.0, u)
    controller = RecedingHorizon(reduction.model, kinds)
    controller.previous = reduction.reduce(u) / 1e3
    observer = KalmanObserver(reduction.model, kinds, estimate=reduced_state(plant, reduction, state))
    state, rec = run(plant, reduction, controller, state, table_reference([0.0, 1e6], [72.0, 72.0]), 12, observer=observer,
                     applied=reduction.reduce(u))
    assert rec.overruns == 0 and rec.largest_coupler.max() < 0.5 * consist.force_limit
    assert np.all(rec.mean_speed <= 20.0 + 0.1) and abs(rec.mean_speed[-1] - 20.0) < 0.1


def test_cars_in_a_curve_pay_roeckls_resistance_and_the_route_loads():
    """On the shipped representative heavy-haul line a car whose centre is in the 600 m curve
    pays Roeckl's 0.5 / (600 - 30) of its weight; a car on straight track nothing."""
    import warnings

    from ecostudy.core.grid import make_segment
    from ecostudy.io.loaders import load_track, train_from_dict
    from .conftest import TRACKS
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        track = load_track(TRACKS / "heavyhaul_representative_45km.yaml")
    point = train_from_dict({"name": "p", "source": "test", "mass_t": 100, "rotating_mass_factor": 0.0,
                             "length_m": 0, "davis": {"a_N": 1000, "b_N_per_mps": 0, "c_N_per_mps2": 5},
                             "traction": {"max_force_kN": 500}, "braking": {"max_force_kN": 500},
                             "curve_resistance": "roeckl"})
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    plant = CascadePlant(consist, make_segment(track, point, "Loading", "Port"))
    flat_plant = CascadePlant(consist, make_segment(track, point, "Loading", "Port"), curves=False)
    positions = np.full(consist.cars, 20500.0)
    positions[0] = 16000.0  # straight, on the 2 per-mille grade
    speeds = np.zeros(consist.cars)
    extra = plant.resistance(positions, speeds) - flat_plant.resistance(positions, speeds)
    assert extra[0] == 0.0 and extra[5] == pytest.approx(consist.mass[5] * GRAVITY * 0.5 / 570)


def test_the_fenced_objective_weighs_what_each_virtual_car_stands_for():
    """per_car: a virtual car's speed counts for its cars, its effort's square for the sum of its
    cars' squared shares, a virtual coupler for the real couplers between the centres; f = 1 and
    'virtual' weigh every term as one."""
    from ecostudy.heavyhaul.linear import Represented, fence
    from ecostudy.heavyhaul.rhc import objective_terms
    consist = load_consist(TRAINS / "heavyhaul_zhang_zhuan.yaml")
    full = fence(consist, 1, 20.0)
    assert all(np.allclose(a, b) for a, b in zip(full.represented(consist.mass), Represented.each(204)))
    reduced = fence(consist, 10, 20.0)
    r = reduced.represented(consist.mass)
    assert r.cars.sum() == 204 and list(r.cars[:3]) == [2, 10, 10]
    assert np.allclose(r.effort[:2], [0.5, 0.1])  # equal masses: 1 / cars
    assert r.couplers.sum() == 202 and r.couplers[0] == 6  # centres 0.5 and 6.5 (of 203: half an end group inside it)
    assert all(np.allclose(a, 1) for a in reduced.represented(consist.mass, "virtual"))
    terms = objective_terms(reduced.model, reduced.kinds, (10.0, 60.0, 10.0, 40.0), r)
    assert terms.kv[1] == 600.0 and terms.penalty[1] == pytest.approx(4.0) and terms.penalty[0] == 0.5


def test_a_car_entering_a_curve_below_300_m_feels_roeckls_force_grow_without_a_jump():
    """Roeckl's two fits jump by 43 % at 300 m radius. A 12 m wagon entering a 250 m curve feels the
    force grow with the share of its length in the curve, 0 to 0.65 / (250 - 55) of its weight, by
    at most its 1/12000 per millimetre: no step where its mean curvature passes 1/300 (which read
    through the formula would be a 24 % jump of the full force for the stiff integrator to step
    through)."""
    seg = Segment(5000.0, Profile(np.zeros(1), np.zeros(1)), Profile(np.array([0.0, 1000.0]), np.array([0.0, 1 / 250])),
                  Profile(np.zeros(1), np.array([30.0])))
    plant = CascadePlant(two_cars(), seg)
    centres = np.arange(990.0, 1010.0, 0.001)  # the wagon's centre across the entry, 1 mm apart
    force = np.array([plant.grade_curve(np.array([c + 16.0, c]))[1][1] for c in centres])
    full = 60e3 * GRAVITY * 0.65 / (250 - 55)
    assert force[0] == 0.0 and force[-1] == pytest.approx(full)
    assert np.all(np.diff(force) >= -1e-9 * full) and np.max(np.diff(force)) < 1.01 * full * 0.001 / 12.0


def test_brakes_oppose_the_motion_of_a_train_rolling_back_and_the_balance_closes():
    """The two cars rolling back at 2 m/s on flat track, the locomotive's dynamic brake asked 50 kN
    and the wagon's pneumatic brake its 100 kN (the paper's plant: no air-brake pipe): the brakes
    slow the train at 150 kN / 160 t = 0.94 m/s^2 (to -1.06 m/s after 1 s, not -2.94) and it stands
    after 2.1 s; the brakes' work is the kinetic energy it had, less what the couplers damp and store."""
    plant = CascadePlant(two_cars(), flat())
    start = plant.initial(head=100.0, speed=-2.0)
    brake = np.array([-50e3, -100e3])
    first = plant.step(start, brake, 1.0)
    mean = float(np.dot(plant.consist.mass, first.state.speeds) / plant.consist.mass.sum())
    assert mean == pytest.approx(-2.0 + 150e3 / 160e3, abs=1e-3)
    last = plant.step(first.state, brake, 9.0)
    assert np.abs(last.state.speeds).max() < 1e-3  # it stands, held by its brakes
    assert last.state.positions[0] == pytest.approx(100.0 - 2.0 ** 2 / (2 * 150e3 / 160e3), abs=0.01)
    braked = sum(s.dynamic_brake_work + s.wagon_brake_work for s in (first, last))
    damped = sum(s.losses[3] for s in (first, last))
    assert first.traction_work == last.traction_work == 0.0
    assert braked == pytest.approx(plant.stored_energy(start) - plant.stored_energy(last.state) - damped, rel=1e-4)


def test_brakes_hold_a_standing_train_against_a_grade_smaller_than_they_are():
    """The two cars standing on a 5 per-mille fall (the grade pulls them on with 160 t g 0.005 =
    7.8 kN) with the wagon's 100 kN brake on: they stand (a creep under 1 mm/s), where a brake
    applied as a fixed force pushed them back up at 0.6 m/s^2; with the brake released they roll."""
    plant = CascadePlant(two_cars(), flat(grade=(np.array([0.0]), np.array([-0.005]))))
    state = plant.initial(head=100.0)
    held = plant.step(state, np.array([0.0, -100e3]), 20.0).state
    assert np.abs(held.speeds).max() < 1e-3 and abs(held.positions[0] - 100.0) < 0.02
    rolled = plant.step(state, np.zeros(2), 20.0).state
    assert rolled.speeds.min() > 0.9  # 20 s at g 0.005 = 0.049 m/s^2
