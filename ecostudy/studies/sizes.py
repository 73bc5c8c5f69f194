"""The size of a whole study, estimated before anything is computed: its runs (cases × grid points,
draws × controllers × samples, legs × trains × strategies, sweeps × samples) shared among the
workers, refused above the 2 h one command may take or half the machine's memory
(:func:`ecostudy.core.budget.check_study`), unless ``--force``. One run's own limits are
:mod:`ecostudy.studies.estimate`'s.

The constants are measured on this project's shared 2-core machine (pessimistic):

- one space-domain run: :func:`ecostudy.studies.estimate.run_seconds` (a ``run`` study's own check is
  its kind's ``size``, :func:`ecostudy.studies.batch.run_study_size`);
- a network study: its clock steps (every leg of every train, for every strategy): the 2-train study
  took 78.0 CPU s over 6 146 steps with one worker (12.7 ms a step; ``python bench/bench_sizes.py
  --kinds network``, busy machine); as a user starts them on a quiet machine with one worker, the
  2-train, 3-train and 20-stop studies took 52, 149 and 579 s (8.5, 16.2 and 17.0 ms a step): taken
  as 20 ms (:data:`NETWORK_SECONDS_PER_STEP`) a step weighted by its leg's slowness
  (:func:`~ecostudy.studies.estimate.leg_slowness`), after the segments' first runs
  (:func:`~ecostudy.studies.estimate.first_runs`, :data:`NETWORK_BYTES_PER_POINT`);
- a heavy-haul run: the first 30 samples of ``studies/heavyhaul_fence.yaml`` (``python
  bench/bench_sizes.py --kinds heavyhaul``, busy machine) took 0.11 CPU s a sample at f = 10 (the
  plant's integration, the observer and the QP) and 0.42 s at f = 1 (every car a locomotive group,
  the largest QP): 0.15 s a sample and the QP's share of the 0.5 s at f = 1 scaled as the cube of
  its inputs (:data:`HEAVYHAUL_SECONDS_PER_SAMPLE`, :func:`heavyhaul_runs`), over 1.5 times the
  reference's samples, after its set-up (the condensed QP built: :func:`heavyhaul_setup_seconds`,
  1.1 CPU s at f = 1, Np = 8, Nc = 6 and 130 s at Np = 30, Nc = 24, docs/guards.md); its memory a worker's and its condensed QP's matrices (:func:`heavyhaul_bytes`:
  f = 1, Np = 30, Nc = 24 peaked at 1.12 GB, docs/guards.md);
- a comparison (``compare``): the all-out run, the ATO optimum with its DAS phases (two NLPs more)
  and the heuristics (taken as one run more), one after the other (:func:`check_compare`);
- a journey (``journey``): each segment's front (:data:`~ecostudy.studies.journey.FRONT_COUNT` runs, shared among the workers), then the
  whole-journey NLP (every segment at once) and every split's runs, one after the other
  (:func:`check_journey`).
"""
import warnings
from itertools import groupby
from pathlib import Path

import numpy as np

from ecostudy.core.defaults import DAS_TIME_LIMIT_S
from ecostudy.ocp.phases import rspc_modes
from ecostudy.core.budget import MAX_RUN_SECONDS, WORKER_BYTES, check_run, check_study, how_many
from ecostudy.core.errors import EcostudyWarning
from ecostudy.heavyhaul.linear import virtual_car_count
from ecostudy.io.documents import named_file, read_document
from ecostudy.io.loaders import consist_from_document, read_train, validate
from ecostudy.io.loopfile import SimulateFile
from ecostudy.studies import closedloop
from ecostudy.studies.batch import STUDY_KINDS
from ecostudy.studies.journey import FRONT_COUNT
from ecostudy.studies.estimate import (RSPC_MEASURED_MODES, case_size, check_closed_loop,
                                       check_network, first_runs, horizon_samples, run_bytes, run_seconds, spec_seconds,
                                       table_points)

NETWORK_SECONDS_PER_STEP = 0.02
# [bytes] a network command's process per grid point of its first runs: it keeps every segment's run
# (the legs' guesses) as it solves the next: 490 MB, 917 MB and 1.64 GB at K = 2 000, 5 000 and 10 000
# against 265 MB at K = 500 (the 2-train study, one worker; a lone space run grows 75 kB a point)
NETWORK_BYTES_PER_POINT = 145e3
HEAVYHAUL_SECONDS_PER_SAMPLE = {1: 0.5}  # f = 1: one locomotive group per car, the largest QP
HEAVYHAUL_SECONDS_PER_SAMPLE_GROUPED = 0.15
HEAVYHAUL_MEASURED_INPUTS = {1: 1224}  # the QP inputs of those measurements: 204 cars x Nc = 6 (f = 1)
HEAVYHAUL_SETUP_SECONDS = 3.5e-10  # [s] a product of the set-up (:func:`heavyhaul_setup_seconds`): 1.6e-10 to 3.2e-10 measured
HEAVYHAUL_SQUARES = 2.5  # dense inputs x inputs matrices a run holds at its peak (:func:`heavyhaul_bytes`)


def check_run_study(path, workers=1):
    """Refuse a ``run`` study estimated above the command's budget (unless forced): its kind's
    ``size`` (:func:`ecostudy.studies.batch.run_study_size`) on its cases."""
    kind = STUDY_KINDS.get("run")
    kind.size(Path(path), kind.expand(Path(path)).cases, workers)


def check_front(where, count, points, workers=1, das=None, das_time_limit=DAS_TIME_LIMIT_S, tables=0):
    """Refuse a Pareto front of ``count`` runs of ``points`` grid nodes (``tables``: the train's table
    points, :func:`~ecostudy.studies.estimate.table_points`) estimated above the budget."""
    check_study(where, f"a front of {count} points at K = {points}",
                [run_seconds(points, das, das_time_limit, tables)] * count, workers, run_bytes(points, tables))


def check_closed_loop_study(path, workers=1, only=None, out=None):
    """Refuse a closed-loop study too big for the command or a run, or that cannot end: first from
    the file alone (controllers x draws x samples to the latest arrival), before the study's own
    set-up solves anything (its all-out SOCP took minutes at K = 20 000); then with every draw's
    true train (:func:`check_closed_loop`). ``only``: the controllers run (all when None); ``out``: the
    output folder, checked before the expansion solves anything (None: the study's own)."""
    s = validate(SimulateFile, read_document(path), path)
    chosen = [c for c in s.controllers if not only or c.name in only]
    what = f"{len(chosen)} controllers x {s.draws} draws"
    train = study_train(path, s.train)
    modes = len(rspc_modes(train)) if any(c.kind == "rspc" for c in chosen) else RSPC_MEASURED_MODES
    per_run = []
    for c in chosen:
        sample_time = c.sample_time_s or s.sample_time_s
        samples = s.window_s[1] / sample_time
        seconds = samples * spec_seconds(c.model_dump(), s.points, horizon_samples(s.window_s[1], sample_time), modes)
        check_run(path, "controllers", f"{c.name}: {how_many(samples)} samples of {c.sample_time_s or s.sample_time_s:g} s "
                  f"at K = {s.points}", seconds)
        per_run += [seconds] * s.draws
    check_study(path, what, per_run, workers, run_bytes(s.points, table_points(train)), part_hint="--only CONTROLLER")
    study, _, cases = closedloop.expand(path, out)
    runs = check_closed_loop(cases, path)
    sizes: dict = {}  # a run's memory as solve's: its grid's nodes and the train's table points (case_size)
    check_study(path, what, [r for r, c in zip(runs, cases) if not only or c["labels"]["controller"] in only],
                workers, max((run_bytes(*case_size(c, sizes)) for c in cases), default=0), part_hint="--only CONTROLLER")


def study_train(path, train):
    """The study ``path``'s train (its file ``train``, read quietly: the study's expansion shows its
    warnings)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)
        return read_train(named_file(path, "train", train))[1]


def network_runs(study, path):
    """Seconds of each run of a network study: the segments' first runs
    (:func:`~ecostudy.studies.estimate.first_runs`, shared among the workers), then each strategy
    (every train over every leg, its steps weighted by
    :func:`~ecostudy.studies.estimate.leg_slowness`)."""
    legs = check_network(study, path)
    per_strategy = sum(leg.weighted for leg in legs) * len(study.names) * NETWORK_SECONDS_PER_STEP
    return first_runs(study) + [per_strategy] * len(study.strategies)


def check_network_study(study, path, workers=1):
    """Refuse a network study (loaded: :func:`ecostudy.io.loaders.load_network_study`) too big for one
    run (a first run, a leg) or for the command (the first runs and every strategy; each worker
    holds a first run's model)."""
    strategies, trains, firsts = len(study.strategies), len(study.names), len(first_runs(study))
    check_study(path, f"{strategies} strateg{'ies' if strategies != 1 else 'y'} x {trains} train{'s' * (trains != 1)} "
                f"after {firsts} first run{'s' * (firsts != 1)} at K = {study.points:,}", network_runs(study, path),
                workers, study.points * NETWORK_BYTES_PER_POINT)


def heavyhaul_bytes(cars, nc, np_):
    """Memory of a heavy-haul run's condensed QP (``heavyhaul.condensed.CondensedHorizon``) of
    ``cars`` virtual cars over Nc = ``nc`` moves and Np = ``np_`` samples [bytes]: its prediction
    matrices (Np x (2 cars - 1) states x cars Nc inputs doubles) and :data:`HEAVYHAUL_SQUARES` dense
    matrices of the inputs squared (the Hessian, its products, the solver's copy)."""
    inputs = cars * nc
    return 8.0 * (np_ * (2 * cars - 1) * inputs + HEAVYHAUL_SQUARES * inputs ** 2)


def _heavyhaul_sizes(cases):
    """(case, virtual cars) of each heavy-haul case."""
    kinds = consist_from_document(cases[0]["consist"], "consist").kinds if cases else ()
    lengths = [len(list(run)) for _, run in groupby(kinds)]
    return [(c, virtual_car_count(lengths, c["labels"]["f"])) for c in cases]


def heavyhaul_sample_seconds(inputs):
    """CPU seconds of one heavy-haul sample with a QP of ``inputs`` (virtual cars x Nc): the grouped
    constant (the plant, the observer, a small QP) and a dense QP's cube of its inputs, scaled to
    the f = 1 measurement: 132 inputs 0.15 s, 1 224 inputs 0.5 s, 528 inputs (f = 10, Nc = 24) 0.18 s
    (0.10 s measured; the cube of the inputs alone put it at 9.6 s)."""
    qp = HEAVYHAUL_SECONDS_PER_SAMPLE[1] - HEAVYHAUL_SECONDS_PER_SAMPLE_GROUPED  # the QP's share at f = 1
    return HEAVYHAUL_SECONDS_PER_SAMPLE_GROUPED + qp * (inputs / HEAVYHAUL_MEASURED_INPUTS[1]) ** 3


def heavyhaul_setup_seconds(cars, nc, np_):
    """CPU seconds of a heavy-haul run's set-up (``studies.heavyhaul.case_controller``) for ``cars``
    virtual cars, Nc = ``nc``, Np = ``np_``: the condensed QP's Hessian, Np products of the (2 cars -
    1) states by the inputs squared, and its factor, the inputs cubed:
    :data:`HEAVYHAUL_SETUP_SECONDS` a product of (Np (2 cars - 1) + inputs) x inputs^2."""
    inputs = cars * nc
    return HEAVYHAUL_SETUP_SECONDS * (np_ * (2 * cars - 1) + inputs) * inputs ** 2


def heavyhaul_runs(study, reference, cases, path=None):
    """Seconds of each run of a heavy-haul study (its samples, up to ``max_samples``):
    :func:`ecostudy.studies.heavyhaul.expand`'s study, reference and cases: its set-up
    (:func:`heavyhaul_setup_seconds`) and its samples (:func:`heavyhaul_sample_seconds`); with
    ``path``, a run estimated above one run's budget (its time, or its process's memory: a worker and
    its QP, :func:`heavyhaul_bytes`) is refused (unless forced)."""
    samples = min(study.max_samples, int(np.ceil(1.5 * reference.running_time / study.sample_time_s)))
    # too long at the least a sample costs (the plant's, a small QP's): the samples are the cause
    field = "sample_time_s" if samples * HEAVYHAUL_SECONDS_PER_SAMPLE_GROUPED > MAX_RUN_SECONDS else "horizons"
    out = []
    for c, cars in _heavyhaul_sizes(cases):
        inputs = cars * c["labels"]["Nc"]
        seconds = (heavyhaul_setup_seconds(cars, c["labels"]["Nc"], c["labels"]["Np"])
                   + samples * heavyhaul_sample_seconds(inputs))
        if path is not None:
            check_run(path, field, f"{c['scenario']}: {inputs:,} QP inputs (virtual cars x Nc) a sample, "
                      f"{samples:,} samples of {study.sample_time_s:g} s", seconds,
                      WORKER_BYTES + heavyhaul_bytes(cars, c["labels"]["Nc"], c["labels"]["Np"]))
        out.append(seconds)
    return out


def check_heavyhaul_study(path, study, reference, cases, workers=1):
    """Refuse a heavy-haul study with a run estimated above one run's budget, or the study above the
    command's (unless forced): each worker holds the largest run's QP."""
    largest = max((heavyhaul_bytes(cars, c["labels"]["Nc"], c["labels"]["Np"]) for c, cars in _heavyhaul_sizes(cases)),
                  default=0.0)
    check_study(path, "the study's runs", heavyhaul_runs(study, reference, cases, path), workers, largest)


def check_compare(where, points, tables=0):
    """Refuse a comparison of runs of ``points`` grid nodes (``tables``: the train's table points,
    :func:`~ecostudy.studies.estimate.table_points`) estimated above the command's budget (unless forced)."""
    runs = [run_seconds(points, None, table_points=tables), run_seconds(points, "phases", table_points=tables),
            run_seconds(points, None, table_points=tables)]  # all-out, ATO + DAS, heuristics
    check_study(where, f"a comparison at K = {points}", [], 1, run_bytes(points, tables), serial=runs)


def check_journey(where, nodes, workers=1, splits=4, whole=1, tables=0):
    """Refuse a journey whose segments' runs have ``nodes`` grid nodes (one count a segment;
    ``tables``: the train's table points) estimated above the command's budget (unless forced): the
    fronts shared among ``workers``, then ``whole`` NLPs of every segment at once and ``splits``
    distributions of a run a segment."""
    fronts = [run_seconds(k, table_points=tables) for k in nodes for _ in range(FRONT_COUNT)]
    serial = [run_seconds(sum(nodes), table_points=tables)] * whole + [run_seconds(k, table_points=tables) for k in nodes] * splits
    check_study(where, f"a journey of {len(nodes)} segments at K = {max(nodes, default=0)}", fronts, workers,
                run_bytes(sum(nodes), tables), serial=serial)
