"""The size of a whole study estimated before computing (``studies/sizes.py``, ``core/budget.check_study``):
runs × their estimate shared among the workers, refused above the 2 h one command may take or half
the machine's memory, with the estimate and how to run a part, unless ``--force``. Every shipped
study passes."""
from pathlib import Path

import numpy as np
import pytest

from ecostudy.core.budget import check_study, forced, machine_memory, study_estimate
from ecostudy.core.errors import InputError
from ecostudy.io.loaders import load_network_study
from ecostudy.io.yamlsafe import load_yaml
from ecostudy.studies import sizes
from ecostudy.studies.workers import every_core

from .conftest import STUDIES, TRACKS, TRAINS, write_yaml
from .test_bad_input import one_line, run

METRO, AMS = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml"
HEAVY = sorted(p for p in STUDIES.glob("*.yaml") if "consist" in load_yaml(p.read_text()))
LIGHT = sorted(p for p in STUDIES.glob("*.yaml") if p not in HEAVY)


def check_file(path, workers, only=None):
    """The study check its command makes, by the study's kind."""
    doc = load_yaml(Path(path).read_text())
    if "controllers" in doc:
        sizes.check_closed_loop_study(path, workers, only)
    elif "trains" in doc:
        sizes.check_network_study(load_network_study(path), path, workers)
    elif "consist" in doc:
        from ecostudy.studies.heavyhaul import expand
        study, _, reference, cases = expand(path)
        sizes.check_heavyhaul_study(path, study, reference, cases, workers)
    else:
        sizes.check_run_study(path, workers)


def test_the_estimate_shares_the_work_and_counts_every_worker():
    total, wall, nbytes = study_estimate([10.0] * 8, workers=4, run_bytes=1e8)
    assert (total, wall) == (80.0, 20.0) and nbytes == pytest.approx(4 * (0.4e9 + 1e8))
    assert study_estimate([100.0, 1.0], workers=2)[1] == 100.0  # never below the longest run
    assert study_estimate([5.0], workers=64)[2] == pytest.approx(0.4e9)  # one run: one worker busy


@pytest.mark.parametrize("runs, workers, fragments", [
    ([3600.0] * 3, 1, ["3 runs, an estimated 3 h of computing (3 h with 1 worker)", "above the 2 h"]),
    ([600.0] * 100, 4, ["100 runs", "16.7 h of computing (4.2 h with 4 workers)"]),
    ([1.0] * 1000, 1000, ["with 1000 workers an estimated 400.0 GB of memory", "use fewer --workers"]),
    ([10800.0], 1, ["cases: 1 run, an estimated 3 h of computing"]),
])
def test_a_study_too_big_for_one_command_is_refused_with_its_estimate(runs, workers, fragments):
    with pytest.raises(InputError) as refused:
        check_study("s.yaml", "the study's cases", runs, workers)
    text = str(refused.value)
    assert text.startswith("s.yaml: study: the study's cases:") and "--force" in text
    for fragment in fragments:
        assert fragment in text, text
    with forced():
        check_study("s.yaml", "the study's cases", runs, workers)


def test_one_worker_over_the_memory_is_not_told_to_use_fewer():
    with pytest.raises(InputError) as refused:
        check_study("s.yaml", "a study", [1.0], 1, run_bytes=1e15)
    text = str(refused.value)
    assert "with 1 worker an estimated" in text and "fewer" not in text, text


def sweep_study(tmp_path, n, points=1000, das=None):
    doc = {"name": "big", "track": str(AMS), "train": str(METRO), "points": points, "objective": "energy",
           "sweep": {"supplement_percent": [1 + 0.01 * i for i in range(n)]}, "output": str(tmp_path / "out")}
    if das:
        doc["das"] = das
    return write_yaml(tmp_path / "big.yaml", doc)


@pytest.mark.parametrize("n, points, das, workers, fragments", [
    (3000, 2000, None, 1, ["3000 runs", "h of computing"]),
    (300, 2000, "minlp", 2, ["300 runs", "with 2 workers"]),
    (256, 200, None, 256, ["memory", "use fewer --workers"]),
])
def test_run_refuses_a_sweep_too_big_before_computing(tmp_path, n, points, das, workers, fragments):
    r = run("run", sweep_study(tmp_path, n, points, das), "--workers", workers, "--no-progress")
    one_line(r, "big.yaml: study:", "--force", *fragments)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("count, points, fragments", [
    (10000, 100000, ["a front of 10000 points at K = 100000", "days of computing"]),
    (5000, 20000, ["a front of 5000 points at K = 20000", "above the 2 h"]),
])
def test_pareto_refuses_a_front_too_big_before_computing(tmp_path, count, points, fragments):
    r = run("pareto", "--track", AMS, "--train", METRO, "--count", count, "--points", points, "--out",
            tmp_path / "o", "--no-plot")
    one_line(r, "command line: study:", "--force", *fragments)


def test_a_closed_loop_study_too_big_is_refused_and_a_part_of_it_runs(tmp_path):
    doc = load_yaml((STUDIES / "metro_monte_carlo.yaml").read_text())
    doc.update(track=str(AMS), train=str(METRO), output=str(tmp_path / "out"), draws=300)
    path = write_yaml(tmp_path / "mc.yaml", doc)
    r = run("simulate", path, "--workers", 2, "--no-progress", "--no-plot")
    one_line(r, "mc.yaml: study: 8 controllers x 300 draws: 2400 runs", "with 2 workers", "--only CONTROLLER",
             "--force")
    sizes.check_closed_loop_study(path, 2, ["rspc"])  # one controller's 300 runs: about 22 min


def test_a_network_study_too_big_for_the_command_is_refused(tmp_path):
    doc = load_yaml((STUDIES / "network_metro_2trains.yaml").read_text())
    doc.update(track=str(TRACKS / "metro_line_4stops.yaml"), train=str(METRO), output=str(tmp_path / "out"),
               supplement_percent=None, running_times_s=[240, 400, 250], time_step_s=0.05)
    doc["trains"] = [{"name": f"T{i}", "offset_s": 60.0 * i} for i in range(8)]
    doc["strategies"] = ["independent", "receptivity", "triggering", "voltage", "dissension", "joint"]
    r = run("network", write_yaml(tmp_path / "net.yaml", doc), "--no-plot")
    one_line(r, "net.yaml: study: 6 strategies x 8 trains", "above the 2 h", "--force")


def network_variant(tmp_path, name, file="net.yaml", **fields):
    """A shipped network study with ``fields`` changed (``points``: the space grid of every
    segment's first runs)."""
    doc = load_yaml((STUDIES / f"{name}.yaml").read_text())
    for key in ("track", "train"):
        doc[key] = str((STUDIES / doc[key]).resolve())
    doc.update(output=str(tmp_path / "out"), **fields)
    return write_yaml(tmp_path / file, doc)


def test_a_network_study_counts_its_first_runs(tmp_path):
    """The segments' first runs (all-out and net-energy, at K = points) are counted: 38 of them on
    the 20-stop line at K = 100 000 are over the 2 h with one worker (the strategies' legs alone,
    all that was counted, were 11 min), and two workers each holding one at K = 100 000 are over
    half the memory of any machine of up to 30 GB."""
    path = network_variant(tmp_path, "network_regional_20stops", points=100000)
    with pytest.raises(InputError) as refused:
        sizes.check_network_study(load_network_study(path), path, 1)
    text = str(refused.value)
    for fragment in ["net.yaml: study: 3 strategies x 3 trains after 38 first runs at K = 100,000", "above the 2 h",
                     "--force"]:
        assert fragment in text, text


def test_network_refuses_first_runs_too_big_before_computing(tmp_path):
    """The 2-train study at K = 100 000 (estimated at 2 min, it grew to 5.7 GB in its first runs before it
    was stopped past 900 s): two workers each holding its first runs (14.5 GB) are over half the
    memory of any machine of up to 59 GB."""
    if (machine_memory() or 0) > 59e9:
        pytest.skip("this machine has more than 59 GB: two workers at K = 100 000 (about 29.8 GB) fit in half of it, "
                    "so the study is not refused here")
    r = run("network", network_variant(tmp_path, "network_metro_2trains", points=100000), "--workers", 2, "--no-plot")
    one_line(r, "net.yaml: study: 7 strategies x 2 trains after 6 first runs at K = 100,000", "memory",
             "use fewer --workers", "--force")
    assert not (tmp_path / "out").exists()


def test_a_network_study_with_slow_legs_is_estimated_dearer_per_step(tmp_path):
    """The 2-train study took 3.2 times the CPU at a 100 % supplement (188 against 58 s, one worker)
    over 1.8 times the clock steps, and 2.6 times at half the step (0.25 s, the same running times)
    over twice the steps: a step costs more the slower its leg is run (docs/guards.md)."""
    def estimate(**fields):
        path = network_variant(tmp_path, "network_metro_2trains", f"{len(fields)}{sorted(fields)}.yaml", **fields)
        return sum(sizes.network_runs(load_network_study(path), path))
    shipped = estimate()
    assert estimate(supplement_percent=100) >= 3.0 * shipped
    assert 1.9 * shipped <= estimate(time_step_s=0.25) <= 2.1 * shipped


@pytest.mark.parametrize("path", LIGHT, ids=[p.stem for p in LIGHT])
def test_every_shipped_study_passes_its_estimate(path):
    """Each shipped study at its default workers (every core) and with one worker (metro_monte_carlo,
    the nearest the limit, at about 1.9 h)."""
    check_file(path, every_core(None))
    check_file(path, 1)


@pytest.mark.slow  # each heavy-haul study solves its reference run first (10-20 s)
@pytest.mark.parametrize("path", HEAVY, ids=[p.stem for p in HEAVY])
def test_every_shipped_heavyhaul_study_passes_its_estimate(path):
    check_file(path, every_core(None))
    check_file(path, 1)


@pytest.mark.slow  # solves the study's reference run first
def test_a_heavyhaul_estimate_grows_with_its_qp_from_the_measured_constant(tmp_path):
    """f = 10 at Nc = 24 (528 QP inputs) took 0.10 CPU s a sample (its first 20 samples, busy
    machine; 0.11 s at Nc = 6): estimated at 0.18 s, where the cube of the inputs over the measured
    132 put it at 9.6 s. f = 1 at Nc = 6 (1 224 inputs) stays at its measured 0.5 s."""
    from ecostudy.studies.heavyhaul import expand
    doc = load_yaml((STUDIES / "heavyhaul_fence.yaml").read_text())
    for key in ("consist", "track"):
        doc[key] = str((STUDIES / doc[key]).resolve())
    doc.update(output=str(tmp_path / "out"), horizons=[{"np": 30, "nc": 24}, {"np": 8, "nc": 6}])
    study, _, reference, cases = expand(write_yaml(tmp_path / "hh.yaml", doc))
    samples = min(study.max_samples, int(np.ceil(1.5 * reference.running_time / study.sample_time_s)))
    cars = {1: 204, 10: 22}  # virtual cars: the set-up (sizes.heavyhaul_setup_seconds) comes once a run
    per_sample = {(c["labels"]["f"], c["labels"]["Nc"]):
                  (r - sizes.heavyhaul_setup_seconds(cars[c["labels"]["f"]], c["labels"]["Nc"], c["labels"]["Np"])) / samples
                  for c, r in zip(cases, sizes.heavyhaul_runs(study, reference, cases))}
    assert 0.15 < per_sample[(10, 24)] < 0.3
    assert per_sample[(1, 6)] == pytest.approx(0.5)


@pytest.mark.parametrize("cars, nc, np_, measured", [(102, 6, 8, 0.14), (204, 6, 8, 1.24),
                                                    (102, 24, 30, 13.28), (204, 24, 30, 130.4)])
def test_a_heavyhaul_run_setup_is_estimated_between_its_measured_cpu_and_2_2_times_it(cars, nc, np_, measured):
    """The set-up of heavyhaul_fence.yaml's runs (the plant, the fence reduction and the condensed
    QP built, CPU s, niced on the busy machine; docs/guards.md) at f = 2 and 1 (102 and 204 virtual
    cars) with its Np = 8, Nc = 6 and with Np = 30, Nc = 24: the estimate lies between the measured
    CPU and 2.2 times it (the band of the other kinds' estimates). At f = 10 (22 cars) the set-up is
    about a sample's 0.15 s (0.08 s measured at Np = 30, Nc = 24, estimated at 0.18 s; under 0.01 s at
    Np = 8, Nc = 6): the estimate keeps it under two samples."""
    assert measured <= sizes.heavyhaul_setup_seconds(cars, nc, np_) <= 2.2 * measured
    assert sizes.heavyhaul_setup_seconds(22, 24, 30) < 2 * sizes.HEAVYHAUL_SECONDS_PER_SAMPLE_GROUPED


@pytest.mark.parametrize("points, sample_time, fragments", [
    (20000, 0.1, ["convex: 760 samples of 0.1 s at K = 20000", "2.4 h", "one run"]),
    (10000, 0.02, ["convex: 3,800 samples of 0.02 s at K = 10000", "3.7 h", "one run"]),
])
def test_a_convex_controller_on_a_huge_grid_is_refused_from_the_file_alone(tmp_path, points, sample_time, fragments):
    """Refused before the study's set-up solves its all-out SOCP (over 100 s at K = 20 000)."""
    doc = {"name": "k", "track": str(AMS), "train": str(METRO), "window_s": [0, 76], "points": points,
           "sample_time_s": sample_time, "controllers": [{"name": "convex", "kind": "convex"}], "draws": 1,
           "output": str(tmp_path / "out")}
    r = run("simulate", write_yaml(tmp_path / "k.yaml", doc), "--no-progress", "--no-plot")
    one_line(r, "k.yaml: controllers:", "--force", *fragments)


def test_a_convex_sample_is_estimated_between_its_measured_cpu_and_twice_it():
    """200 samples of 0.38 s on the Amsterdam case, each K in a fresh process (docs/guards.md, busy
    machine): 10, 60 and 352 CPU ms a sample at K = 200, 1 000 and 3 000, set-up included."""
    from ecostudy.studies.estimate import sample_seconds
    for points, measured in [(200, 0.010), (1000, 0.060), (3000, 0.352)]:
        assert measured <= sample_seconds("convex", points) <= 2 * measured, points


def test_sbpc_with_its_defaults_is_estimated_from_its_own_measurement():
    """SBPC nominal with its defaults took 95 and 72 CPU ms a sample at K = 200 and 400, with DAS levels
    alone 117 ms at K = 200 (200 samples of 0.38 s, fresh process); with metro_terminal.yaml's DAS
    levels, reserves and terminal approach, 548 ms at K = 200 (its study's draw 0) and 683 ms without
    deviations or noise."""
    from ecostudy.studies.estimate import spec_seconds
    for spec, points, measured in [({"kind": "sbpc", "variant": "nominal"}, 200, 0.095), ({"kind": "sbpc"}, 400, 0.072),
                                   ({"kind": "sbpc", "das_levels": True}, 200, 0.117)]:
        assert measured <= spec_seconds(spec, points) <= 2 * measured, spec
    terminal = next(c for c in load_yaml((STUDIES / "metro_terminal.yaml").read_text())["controllers"]
                    if c["name"] == "sbpc_nominal")
    assert 0.683 <= spec_seconds(terminal, 200) <= 2 * 0.548
    assert spec_seconds({**terminal, "das_levels": False, "brake_reserve": None, "terminal_reserve": None,
                         "terminal_fit": False}, 200) == spec_seconds({"kind": "sbpc"}, 200)


# CPU s a sample of one whole trip (draw 0, the Amsterdam case's 76 s window, fresh process, docs/guards.md)
# at T_s = 0.38, 0.19 and 0.095 s: k_f = 200, 400 and 800 samples in SBPC's plan
@pytest.mark.parametrize("spec, measured, times", [
    ({"kind": "sbpc", "variant": "nominal", "block": 20}, {0.38: 0.117, 0.19: 0.083, 0.095: 0.194}, 2),
    ({"kind": "sbpc", "variant": "multi", "block": 20, "transcription": "condensed"},
     {0.38: 0.018, 0.19: 0.022, 0.095: 0.142}, 6),
])
def test_an_sbpc_sample_is_estimated_dearer_as_its_sample_time_shrinks(spec, measured, times):
    """SBPC plans over every sample to the arrival: at a quarter of the sample time its NLP is four times
    larger and a sample cost 1.7 (simultaneous) and 7.9 (condensed) times the CPU. The estimate was
    the constant at any sample time (130 and 22 ms against 194 and 142 measured at 0.095 s); it stays
    at 0.38 s and follows the plan's size below."""
    from ecostudy.studies.estimate import SAMPLE_SECONDS, SBPC_PLAIN_SECONDS, horizon_samples, spec_seconds
    estimate = {ts: spec_seconds(spec, 100, horizon_samples(76, ts)) for ts in measured}
    assert estimate[0.38] == (SBPC_PLAIN_SECONDS if spec["variant"] == "nominal"
                              else SAMPLE_SECONDS[("sbpc", "multi", "condensed")])
    assert estimate[0.095] >= times * estimate[0.38]
    assert measured[0.095] <= estimate[0.095] <= 2 * measured[0.095]
    assert estimate[0.19] >= measured[0.19]


def test_an_rspc_sample_is_estimated_dearer_by_the_sequences_its_horizon_enumerates():
    """RSPC enumerates modes^N switching sequences a sample (six modes with the default DAS levels); its
    constant is at N = 3. The estimate was that constant at any N (and a 4-level horizon of 8 modes
    estimated like 6); it grows with the sequences, each step beyond 3 pruned to 0.8 of its
    branches, never below the constant."""
    from ecostudy.studies.estimate import SAMPLE_SECONDS, spec_seconds
    rspc = {"kind": "rspc"}
    assert spec_seconds(rspc, 100) == spec_seconds({**rspc, "rspc": {"horizon": 3}}, 100) == SAMPLE_SECONDS["rspc"]
    assert spec_seconds({**rspc, "rspc": {"horizon": 5}}, 100) == pytest.approx(36 * 0.8 ** 2 * SAMPLE_SECONDS["rspc"])
    assert spec_seconds({**rspc, "rspc": {"horizon": 6}}, 100) == pytest.approx(216 * 0.8 ** 3 * SAMPLE_SECONDS["rspc"])
    assert spec_seconds({**rspc, "rspc": {"horizon": 4}}, 100, modes=8) == pytest.approx(8 ** 4 / 6 ** 3 * 0.8
                                                                                         * SAMPLE_SECONDS["rspc"])
    assert spec_seconds({**rspc, "rspc": {"horizon": 1}}, 100) == SAMPLE_SECONDS["rspc"]


# CPU a sample of RSPC's whole run of draw 0 at N = 4, 5 and 6 over its N = 3 run's, and a step's
# median over N = 3's: metro_monte_carlo.yaml (two sessions) and yazhemsky2017_monte_carlo.yaml's
# trip driven by RSPC (docs/guards.md, "RSPC's horizon")
RSPC_GROWTH_MEASURED = {4: [4.1, 3.9, 4.1, 4.27, 5.28], 5: [19.3, 19.5, 21.9, 21.7, 28.1], 6: [114, 94.3]}


def test_an_rspc_sample_beyond_three_steps_is_estimated_within_half_again_of_its_measured_growth():
    """The pruning drops about a fifth of each step's branches: a sample grew 17-28 times from N = 3
    to 5 (whole runs and steps, two tracks) where m^N / 6^3 estimated 36, twice the CPU. Estimated
    now within 1.5 times either way of every measurement."""
    from ecostudy.studies.estimate import rspc_scale
    for horizon, growths in RSPC_GROWTH_MEASURED.items():
        for growth in growths:
            assert growth / 1.5 <= rspc_scale(horizon) <= 1.5 * growth, (horizon, growth, rspc_scale(horizon))


def rspc_study(tmp_path, horizon, draws, levels=None):
    """metro_monte_carlo.yaml's RSPC controller alone with the horizon N (and the train's DAS levels)."""
    train = METRO
    if levels is not None:
        doc = load_yaml(METRO.read_text())
        train = write_yaml(tmp_path / f"metro_{len(levels)}.yaml", {**doc, "das_handle_levels": levels})
    doc = load_yaml((STUDIES / "metro_monte_carlo.yaml").read_text())
    doc.update(track=str(AMS), train=str(train), output=str(tmp_path / "out"), draws=draws,
               controllers=[{"name": "rspc", "kind": "rspc", "sample_time_s": 0.38, "rspc": {"horizon": horizon}}])
    return write_yaml(tmp_path / f"rspc{horizon}_{len(levels or ())}.yaml", doc)


def test_a_closed_loop_study_of_rspc_over_six_steps_is_refused_with_its_estimate(tmp_path):
    """100 draws of RSPC at N = 6 were estimated at 2 min (6 ms a sample, as at N = 3); a whole run at
    N = 6 took 636 CPU ms a sample, 114 times N = 3's 5.6 ms (draw 0, docs/guards.md), so 100 runs
    about 3.5 h of computing: on one worker refused with its estimate (0.66 s a sample, 216 x 0.8^3 =
    111 times), on two (1.8 h) within the 2 h a command may run, as the same study at N = 3."""
    sizes.check_closed_loop_study(rspc_study(tmp_path, 3, 100), 1)
    sizes.check_closed_loop_study(rspc_study(tmp_path, 6, 100), 2)
    with pytest.raises(InputError) as refused:
        sizes.check_closed_loop_study(rspc_study(tmp_path, 6, 100), 1)
    text = str(refused.value)
    for fragment in ("rspc6_0.yaml: study: 1 controllers x 100 draws: 100 runs", "3.7 h of computing", "--force"):
        assert fragment in text, text


def test_an_rspc_run_is_estimated_over_its_trains_modes(tmp_path):
    """A train with four traction and two braking levels gives RSPC eight modes: 8^3 sequences a sample
    at N = 3 against the default levels' 6^3, in the check of every draw and in the file's."""
    from ecostudy.studies.closedloop import expand
    from ecostudy.studies.estimate import check_closed_loop
    levels = [-1.0, -0.5, 0.0, 0.25, 0.5, 0.75, 1.0]
    six, eight = (check_closed_loop(expand(path)[2], path) for path in (rspc_study(tmp_path, 3, 1),
                                                                         rspc_study(tmp_path, 3, 1, levels)))
    assert eight[0] == pytest.approx(8 ** 3 / 6 ** 3 * six[0])
    sizes.check_closed_loop_study(rspc_study(tmp_path, 5, 100), 1)  # 100 x 200 samples x 0.14 s: 46 min
    with pytest.raises(InputError, match=r"100 runs, an estimated 3.2 h of computing"):
        sizes.check_closed_loop_study(rspc_study(tmp_path, 5, 100, levels), 1)


@pytest.mark.parametrize("controller, sample_time, fragments", [
    ({"kind": "sbpc", "variant": "multi", "block": 20, "transcription": "condensed"}, 0.01,
     ["sbpc: 7,600 samples of 0.01 s at K = 100", "10.9 h", "one run"]),
    ({"kind": "sbpc", "variant": "nominal", "block": 20}, 0.005,
     ["sbpc: 15,200 samples of 0.005 s at K = 100", "4.8 h", "one run"]),
])
def test_an_sbpc_study_at_short_samples_is_refused_with_its_estimate(tmp_path, controller, sample_time, fragments):
    """Estimated at the 0.38 s constant, these were accepted (2.8 min and 33 min) and would have run for
    hours: each sample's NLP covers every sample to the arrival. Refused from the file alone, exit 2."""
    doc = {"name": "k", "track": str(AMS), "train": str(METRO), "window_s": [0, 76], "points": 100,
           "sample_time_s": sample_time, "controllers": [{"name": "sbpc", **controller}], "draws": 1,
           "output": str(tmp_path / "out")}
    r = run("simulate", write_yaml(tmp_path / "k.yaml", doc), "--no-progress", "--no-plot")
    one_line(r, "k.yaml: controllers:", "give --force to run it anyway", *fragments)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("nc, peak", [(24, 1.115e9), (12, 0.588e9)])
def test_a_heavyhaul_run_memory_is_estimated_from_its_qp_matrices(nc, peak):
    """f = 1 (204 virtual cars), Np = 30: the process of its first samples peaked at ``peak`` bytes
    (docs/guards.md); the estimate is a worker and its QP's matrices, between that and twice it."""
    from ecostudy.core.budget import WORKER_BYTES
    assert peak <= WORKER_BYTES + sizes.heavyhaul_bytes(204, nc, 30) <= 2 * peak


def test_solve_refuses_a_run_too_big_for_the_memory_with_its_estimate(tmp_path):
    """`solve` had no size check but for a MINLP search: a K = 60 000 run of a train whose braking is an
    82-point table (a TTOBench train with pneumatic brakes; every node's rows carry the table) was
    accepted, 22.7 GB estimated on a 25.3 GB machine. Refused with its estimate, before computing."""
    import json
    from .conftest import DATA
    doc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    doc["max pn braking force"] = {"unit": "kN", "value": 100.0}
    train = tmp_path / "CN_Beijing_Subway.json"
    train.write_text(json.dumps(doc))
    from ecostudy.io.loaders import load_train
    from ecostudy.studies.estimate import run_bytes, table_points
    tables = table_points(load_train(train))
    assert tables == 82  # 81 speeds and the regenerative corner speed
    if run_bytes(100000, tables) < machine_memory() / 2:
        pytest.skip("a machine with more memory than a K = 100 000 run of this train needs twice over")
    result = run("solve", "--track", DATA / "ttobench_track.json", "--train", train, "--supplement", 10, "-K", 100000,
                 "--no-plot", "--out", tmp_path / "o")
    one_line(result, "command line: --points: a run at K = 100000: an estimated", "of memory, above half of this "
             "machine's", "give --force to run it anyway")
    assert not (tmp_path / "o").exists()


def test_a_grid_larger_than_asked_is_said(tmp_path):
    """A track with 300 gradient changes between its stops: each is a grid node, so K = 100 asked ran at
    K = 301 without a word (a TTOBench track of 20 000 rows ran at K = 20 001, 7 GB and rising)."""
    track = {"name": "many grades", "source": "test", "length_m": 3000,
             "stops": [{"name": "A", "position_m": 0}, {"name": "B", "position_m": 3000}],
             "gradients": [{"position_m": 10 * n, "gradient_permille": (-1) ** n} for n in range(300)],
             "speed_limits": [{"position_m": 0, "speed_kmh": 80}]}
    result = run("solve", "--track", write_yaml(tmp_path / "t.yaml", track), "--train", METRO, "--supplement", 10,
                 "-K", 100, "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert ("warning: command line: --points: the track's profile changes between A and B are each a grid node: "
            "K = 301, not the 100 asked") in result.output, result.output


@pytest.mark.parametrize("study, workers, fragments", [
    ("yazhemsky2017_closed_loop", 1, ["study: 3 controllers x 1 draws: 3 runs, an estimated 3.3 h of computing"]),
    ("metro_terminal", 2, ["controllers: sbpc_nominal: 76,000 samples of 0.001 s at K = 200", "14 days", "one run"]),
])
def test_a_shipped_closed_loop_study_at_1_ms_samples_is_refused_with_its_estimate(tmp_path, study, workers, fragments):
    """Every controller of a shipped closed-loop study at 1 ms samples (200 000 on the 1 km trip's
    200 s window, 76 000 on the metro's 76 s): refused from the file alone, in one line with the
    samples and the estimate, exit 2, nothing written. (The 1 km trip's 3.3 h with 2 workers are 1.65 h
    of wall time, under the 2 h: accepted; measured, its replay ran 84 000 samples in 80 CPU s and its
    convex controller takes 21 CPU ms a sample, 30 min a run: docs/guards.md.)"""
    doc = load_yaml((STUDIES / f"{study}.yaml").read_text())
    for key in ("track", "train"):
        doc[key] = str((STUDIES / doc[key]).resolve())
    doc.update(sample_time_s=0.001, output=str(tmp_path / "out"))
    for controller in doc["controllers"]:
        controller.pop("sample_time_s", None)
    r = run("simulate", write_yaml(tmp_path / "ms.yaml", doc), "--workers", workers, "--no-progress", "--no-plot")
    one_line(r, "ms.yaml:", "give --force to run it anyway", *fragments)
    assert not (tmp_path / "out").exists()
