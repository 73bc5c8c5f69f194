"""Size and time estimates of one run, made before anything is computed: work that would run for
days, fill the memory or simulate a train that never arrives is refused with its estimate
(:func:`ecostudy.core.budget.check_run`), unless the command is given ``--force``.

The constants are measured on this project's shared 2-core machine (so they are pessimistic):

- a network leg (the time-domain NLP of :mod:`ecostudy.ocp.timedomain`) of 200 and 2 000 clock
  steps (the metro's Noord - Station in 100 s) took 28 s and 233 s to build and solve from a cold
  start (286 and 332 Ipopt iterations) and 24 MB and 144 MB of memory: about 0.12 s and 72 kB a step;
- a closed-loop sample, CPU seconds per sample with the run's set-up (``python bench/bench_sizes.py
  --kinds simulate [--loop-study studies/metro_terminal.yaml]``, busy machine, draw 0 of each
  controller): SBPC nominal 548 ms, two-step 384 ms, multi-objective 88 ms (simultaneous, K = 200) and
  52 ms (condensed, K = 100; 17-21 ms since each process runs one OpenBLAS thread, draws 0-2 with
  ``python bench/bench_monte_carlo.py``, docs/closed_loop.md); SPPC nominal 59 ms (K = 200), two-step 147 ms (K = 100); RSPC 5.7 ms
  at its default horizon N = 3 with the six default DAS modes, scaled by the sequences it enumerates,
  modes^N, each step beyond 3 pruned to 0.8 of its branches (:func:`rspc_scale`; ``python
  bench/bench_rspc.py --step-costs``);
  convex 8.4 ms at K = 100; a replay (open loop, ATO) 0.8-1.1 ms: :data:`SAMPLE_SECONDS`, to two
  digits. SBPC and SPPC plan over the samples left, so their grid matters less than their variant.
  SBPC's plan has a state on every sample to the arrival (k_f of them): at T_s = 0.38, 0.19 and
  0.095 s (k_f = 200, 400, 800; whole trips, defaults) a sample took 117, 83 and 194 ms, multi
  condensed 18, 22 and 142 ms (docs/guards.md, "SBPC at short samples"): its constants are at
  k_f = 200 and scaled by (k_f / 200)^0.5, condensed ^1.5 (:func:`sbpc_scale`); SPPC's NLP is on
  the space grid, its samples as dear at 0.095 s as at 0.38 s (47 and 68 ms).
  Those SBPC constants are with ``metro_terminal.yaml``'s DAS levels, reserves and terminal approach:
  SBPC nominal with those options took 683 ms a sample at K = 200 without deviations or noise (taken as
  0.8 s), with its defaults 95 and 72 ms a sample at K = 200 and 400, with DAS levels alone
  117 ms at K = 200 (busy machine, docs/guards.md), taken as 0.13 s (:data:`SBPC_PLAIN_SECONDS`,
  :func:`spec_seconds`). The convex SOCP grows faster than K:
  the all-out SOCP of the Amsterdam case took 0.17, 0.69, 3.3 and 9.4 s at K = 200, 1000, 2000 and
  5000 and over 100 s at 20 000 (busy machine); a sample (200 of 0.38 s, fresh process, docs/guards.md)
  took 10, 60 and 352 ms at K = 200, 1 000 and 3 000, so a sample is taken as
  8 ms + 4.5 ms x (K / 200)^1.7 (:func:`sample_seconds`);
- one space-domain run (build, NL write, Ipopt, verification): the first 12 cases of
  ``studies/metro_supplements.yaml`` (K = 500, ``python bench/bench_sizes.py --kinds run --cases
  12``, busy machine) took 0.52-2.25 CPU s, 1.86 ms a grid point on average (the first case of a
  scenario 3.9-4.5 ms: it solves the all-out run and writes the NLP the others re-use):
  :data:`RUN_SECONDS_PER_POINT`; a DAS ``phases`` advice adds two NLPs of the same size and ``minlp``
  its time limit (:func:`run_seconds`). Its time grows about linearly with K and its process's memory
  75 kB a grid point (:data:`RUN_BYTES_PER_POINT`): a network study's first runs (the all-out and
  net-energy runs of the metro line's first segment, fresh process) took 2.3, 5.2, 14.9, 30.2 and
  61.9 CPU s and peaked at 253, 325, 546, 923 and 1 676 MB at K = 1 000, 2 000, 5 000, 10 000 and
  20 000 (busy machine, docs/guards.md); a network study's first runs are :func:`first_runs`. Each
  node's rows carry the train's envelope tables: a TTOBench train with pneumatic brakes (its braking
  an 81-point table, ``io.ttobench``) ran 48.5 km at K = 2001 in 24 s and 880 MB, the metro (a 4-point
  table) at K = 2001 in 3.3 s and 228 MB (busy machine): 3.6 kB more a table point and node
  (:data:`TABLE_BYTES_PER_POINT_NODE`), and ``io.trainschema.SECONDS_PER_POINT_NODE`` of time
  (:func:`run_seconds`, :func:`run_bytes`).
"""
import warnings
import json
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ecostudy.ocp.phases import rspc_modes, sequences
from ecostudy.core.defaults import DAS_TIME_LIMIT_S
from ecostudy.core import kinematics
from ecostudy.core.adhesion import TOP_SPEED, capped
from ecostudy.core.plant import Truth
from ecostudy.core.budget import check_run, duration, how_many, refuse_unless_forced
from ecostudy.core.errors import EcostudyWarning, InfeasibleError, InputError, TooFastError, problem
from ecostudy.core.grid import make_grid, make_segment, node_limits
from ecostudy.io.loaders import track_from_schema, train_from_schema, validate
from ecostudy.io import schemas
from ecostudy.io.loopfile import RspcSettings
from ecostudy.io.trainschema import SECONDS_PER_POINT_NODE
from ecostudy.ocp.problem import check_not_crawling, prepare

LEG_SECONDS_PER_STEP = 0.12
LEG_BYTES_PER_STEP = 72e3
LEG_MEASURED_SLOWNESS = 1.1  # the legs measured ran 10 % over their all-out time (:func:`leg_slowness`)
SAMPLE_SECONDS = {  # [s] a sample, by (kind, variant[, transcription]) or kind
    ("sbpc", "nominal"): 0.8, ("sbpc", "two_step"): 0.39, ("sbpc", "multi"): 0.09,
    ("sbpc", "multi", "condensed"): 0.022, ("sppc", "nominal"): 0.06, ("sppc", "two_step"): 0.15, "rspc": 0.006}
REPLAY_SECONDS = 0.0012
SBPC_PLAIN_SECONDS = 0.13  # [s] an SBPC nominal sample with none of SBPC_HANDLES (SAMPLE_SECONDS' are with them)
SBPC_HANDLES = ("brake_reserve", "terminal_reserve")
# SBPC's FHOCP runs over the k_f samples to the latest arrival (``ocp.blocked``: states on every
# sample, a handle per block of L samples): its constants are at k_f = 200 (76 s at 0.38 s), and a
# sample grows as (k_f / 200)^SBPC_GROWTH (never below the constant), by its transcription (the
# sparse NLP by Ipopt, the dense block handles by SLSQP; :func:`sbpc_scale`)
SBPC_MEASURED_HORIZON = 200
SBPC_GROWTH = {"simultaneous": 0.5, "condensed": 1.5}
RSPC_MEASURED_HORIZON = 3  # RSPC's constant is at its default N = 3 with the six default DAS modes
RSPC_MEASURED_MODES = 6
RSPC_KEPT = 0.8  # of a step's m branches, the share its pruning leaves to enumerate on (:func:`rspc_scale`)
CONVEX_SECONDS = 0.008         # [s] a convex sample's part that does not grow with K (the loop, the estimator)
CONVEX_SECONDS_AT_200 = 0.0045  # [s] its SOCP's part at K = 200, growing as K^CONVEX_GROWTH
CONVEX_GROWTH = 1.7
RUN_SECONDS_PER_POINT = 2.0e-3
DAS_EXTRA_POINT_RUNS = {"round": 0.0, "phases": 2.0, "minlp": 3.0}
RUN_BYTES_PER_POINT = 75e3  # a space run's process grows 75 kB a point (the model, its NL file, Ipopt's factor)
TABLE_BYTES_PER_POINT_NODE = 4e3  # [bytes] an envelope table's point, each node's rows carrying the table


def run_seconds(points, das=None, das_time_limit=DAS_TIME_LIMIT_S, table_points=0):
    """One space-domain run of ``points`` grid nodes, with its DAS advice [s]; ``table_points``: the
    points of the train's envelope tables (:func:`table_points`), each row of a node carrying them."""
    seconds = (points * (RUN_SECONDS_PER_POINT + SECONDS_PER_POINT_NODE * table_points)
               * (1 + DAS_EXTRA_POINT_RUNS.get(das or "round", 0.0)))
    return seconds + (das_time_limit if das == "minlp" else 0.0)


def run_bytes(points, table_points=0):
    """Memory of one space-domain run of ``points`` grid nodes [bytes]: its process's growth."""
    return points * (RUN_BYTES_PER_POINT + TABLE_BYTES_PER_POINT_NODE * table_points)


def table_points(train):
    """The points of a train's traction and braking tables (0 for force-and-power envelopes)."""
    return sum(len(e.speeds or ()) for e in (train.traction, train.braking) if e.kind == "table")


def grid_nodes(track, train, from_stop, to_stop, points):
    """The grid's node count for ``points`` asked (``ocp.problem.prepare``'s grid): more where the
    segment has more profile changes than that, each a node; said in a warning then."""
    nodes = len(make_grid(make_segment(track, train, from_stop, to_stop), points))
    if nodes > points:
        warnings.warn(problem("command line", "--points", f"the track's profile changes between {from_stop} and "
                              f"{to_stop} are each a grid node: K = {nodes}, not the {points} asked (a run that much "
                              f"larger)"), EcostudyWarning, stacklevel=2)
    return nodes


def case_size(case, sizes):
    """(grid nodes, the train's table points) of a study case's run (a dict of
    :func:`ecostudy.studies.cases.expand`), as ``solve`` estimates its own (:func:`grid_nodes`,
    :func:`table_points`), kept in ``sizes`` per scenario (its cases share them)."""
    key = json.dumps([case.get(k) for k in ("train", "track", "from", "to", "points", "scenario")], sort_keys=True,
                     default=str)
    if key not in sizes:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", EcostudyWarning)  # shown once when the study was expanded
            train = train_from_schema(schemas.TrainFile.model_validate(case["train"]), case.get("scenario"))
            track = track_from_schema(schemas.TrackFile.model_validate(case["track"]))
            sizes[key] = (grid_nodes(track, train, case["from"], case["to"], case["points"]), table_points(train))
    return sizes[key]


def check_solve(points, das=None, das_time_limit=DAS_TIME_LIMIT_S, tables=0):
    """Refuse (unless forced) one solve of ``points`` nodes estimated above one run's budget in time
    or memory (``tables``: :func:`table_points`); its MINLP search may take its whole time limit
    (``--das-time-limit 1e308`` searched on past any timeout)."""
    field, what = (("--das-time-limit", f"a run at K = {points} with a MINLP search of up to "
                    f"{duration(das_time_limit)}") if das == "minlp" else ("--points", f"a run at K = {points}"))
    check_run("command line", field, what, run_seconds(points, das, das_time_limit, tables), run_bytes(points, tables))


def sbpc_scale(horizon, transcription="simultaneous"):
    """How much dearer an SBPC sample is with a plan of ``horizon`` samples (k_f: the latest arrival
    over the sample time, :func:`horizon_samples`) than with the k_f = 200 its constants were measured
    at: (k_f / 200)^SBPC_GROWTH of its transcription, never below 1."""
    return max(1.0, horizon / SBPC_MEASURED_HORIZON) ** SBPC_GROWTH[transcription]


def rspc_scale(horizon, modes=RSPC_MEASURED_MODES):
    """How much dearer an RSPC sample is with a horizon of N = ``horizon`` steps over ``modes`` modes
    (``ocp.phases.rspc_modes``) than at the N = 3 and six modes its constant was measured with: the
    ratio of the sequences it enumerates (``ocp.phases.sequences``: modes^N), each step beyond N = 3
    pruned to :data:`RSPC_KEPT` of its branches (a prefix that stops short or rises above a braking
    curve drops every sequence that extends it): m^N / 6^3 x 0.8^(N - 3). Measured, a whole run's
    sample grew from N = 3 to N = 4, 5 and 6 by 3.9-5.3, 19-28 and 94-114 times against this 4.8, 23
    and 111 (the plain m^N / 6^3, 6, 36 and 216, was up to twice the CPU above N = 3; docs/guards.md).
    Never below 1 (a sample's loop, plant and braking do not shrink with N: 0.20 and 0.43 times at N
    = 1 and 2)."""
    pruned = RSPC_KEPT ** max(horizon - RSPC_MEASURED_HORIZON, 0)
    return max(1.0, pruned * sequences(modes, horizon) / sequences(RSPC_MEASURED_MODES, RSPC_MEASURED_HORIZON))


def horizon_samples(latest, sample_time):
    """SBPC's k_f: the samples of ``sample_time`` to the ``latest`` arrival (``core.kinematics.samples``;
    inf where a sample time too small makes their number overflow)."""
    return kinematics.samples(latest, sample_time) if np.isfinite(latest / sample_time) else np.inf


def sample_seconds(kind, points, variant="nominal", transcription="simultaneous", horizon=SBPC_MEASURED_HORIZON):
    """Estimated computing of one closed-loop sample of a controller ``kind`` (its ``variant`` and
    ``transcription`` where it has them) at ``points`` nodes, its set-up spread over its samples [s];
    an SBPC sample scaled to its plan of ``horizon`` samples (:func:`sbpc_scale`)."""
    if kind == "convex":
        return CONVEX_SECONDS + CONVEX_SECONDS_AT_200 * (points / 200) ** CONVEX_GROWTH
    scale = sbpc_scale(horizon, transcription) if kind == "sbpc" else 1.0
    for key in ((kind, variant, transcription), (kind, variant), kind):
        if key in SAMPLE_SECONDS:
            return SAMPLE_SECONDS[key] * scale
    return REPLAY_SECONDS


def spec_seconds(spec, points, horizon=SBPC_MEASURED_HORIZON, modes=RSPC_MEASURED_MODES):
    """:func:`sample_seconds` of a controller spec (a dict as a study file writes it, defaults left
    out, or every field) with a plan of ``horizon`` samples (:func:`horizon_samples`): SBPC nominal
    with blocks of 20 or longer and no reserves or terminal approach at :data:`SBPC_PLAIN_SECONDS`,
    its other constants being measured with those and DAS levels (``metro_terminal.yaml``); RSPC
    scaled to its horizon N over the train's ``modes`` (:func:`rspc_scale`)."""
    kind, variant = spec.get("kind", "convex"), spec.get("variant", "nominal")
    transcription = spec.get("transcription") or "simultaneous"
    if (kind, variant) == ("sbpc", "nominal") and spec.get("block", 20) >= 20 and not any(
            spec.get(handle) for handle in SBPC_HANDLES):
        return SBPC_PLAIN_SECONDS * sbpc_scale(horizon, transcription)
    if kind == "rspc":
        return SAMPLE_SECONDS["rspc"] * rspc_scale(RspcSettings(**spec.get("rspc") or {}).horizon, modes)
    return sample_seconds(kind, points, variant, transcription, horizon)


def first_runs(study):
    """Seconds of each space-domain run that starts a network study's legs (``network.fleet.plan``):
    every segment's net-energy run at K = ``study.points``, after its all-out run where the study
    gives a supplement (not running times)."""
    per_segment = 1 if study.running_times is not None else 2
    return [run_seconds(study.points)] * (per_segment * (len(study.stops) - 1))


def leg_slowness(seconds, fastest):
    """How much dearer a clock step of a leg run in ``seconds`` is than one of the legs the constants
    were measured on, run 10 % over their all-out time ``fastest`` (:data:`LEG_MEASURED_SLOWNESS`):
    in proportion to the running time beyond that (the 2-train study at a 100 % supplement took
    3.2 times the CPU of its 10 % over 1.8 times the steps; at half the step, the same running times,
    2.6 times over twice the steps, which count linearly; docs/guards.md), never below 1."""
    return max(1.0, seconds / fastest / LEG_MEASURED_SLOWNESS)


class Leg(NamedTuple):
    """A network leg's size: its clock steps and their :func:`leg_slowness` (a step's cost over a
    measured leg's step)."""
    steps: int
    slowness: float

    @property
    def weighted(self) -> float:
        """The steps of a measured leg it costs."""
        return self.steps * self.slowness


def check_network(study, path):
    """Refuse a network study whose first runs (:func:`first_runs`) or time-domain legs are estimated
    above one run's budget; returns every leg's :class:`Leg` (one train, one strategy)."""
    check_run(path, "points", f"a segment's first run at K = {study.points:,}", run_seconds(study.points),
              run_bytes(study.points))
    legs = []
    for i, (a, b) in enumerate(zip(study.stops[:-1], study.stops[1:])):
        case = prepare(study.track, study.train, a, b, study.points)
        if study.running_times is not None:
            seconds, field = float(study.running_times[i]), f"running_times_s[{i}]"
            try:  # a leg that crawls is refused before its size is (1e308 s overflowed the step count)
                check_not_crawling(seconds, case)
            except TooFastError as exc:
                raise InputError(problem(path, field, str(exc))) from None
        else:
            seconds, field = case.estimate * (1 + study.supplement), "supplement_percent"
        leg = Leg(int(np.ceil(seconds / study.dt)), leg_slowness(seconds, case.estimate))
        check_run(path, field, f"the leg {a} - {b} of {seconds:g} s is {leg.steps:,} clock steps of {study.dt:g} s "
                  "for each train and strategy", leg.weighted * LEG_SECONDS_PER_STEP, leg.steps * LEG_BYTES_PER_STEP)
        legs.append(leg)
    return legs


def true_train(train, truth):
    """The plant's train of a draw (``core.plant.Truth`` as a dict): the heavier mass, the larger
    resistance and the weaker traction that :class:`~ecostudy.core.plant.Plant` drives; a train
    with an adhesion limit its traction capped at the true train's limit where the plant caps it
    (``Truth.capped``: a stronger or lighter true train)."""
    plant = Truth(**truth)
    traction, limit = train.traction.scaled(truth["traction"]), plant.adhesion(train)
    if limit is not None and plant.capped(train):
        traction, _ = capped(traction, limit, train.max_speed if np.isfinite(train.max_speed) else TOP_SPEED)
    return replace(train, mass=train.mass * truth["mass"], static_mass=train.static_mass * truth["mass"],
                   davis=tuple(c * truth["resistance"] for c in train.davis), traction=traction, adhesion=limit)


def check_closed_loop(cases, path):
    """Refuse a closed-loop study with a run whose true train cannot reach the stop before the
    loop's time cap (it would be simulated to the cap, sample by sample), or estimated above one
    run's budget. ``cases``: :func:`ecostudy.studies.closedloop.expand`'s. Returns every run's
    estimated seconds."""
    seen, runs = {}, []
    for case in cases:
        truth = case["truth"]
        key = (tuple(sorted(truth.items())), case["from"], case["to"])
        if key not in seen:
            seen[key] = _true_all_out(case, truth)
        fastest, cap, message, modes = seen[key]
        label = f"{case['labels']['controller']} draw {case['labels']['draw']}"
        if message is not None or fastest > cap:
            why = message or f"its all-out time is {fastest:.0f} s"
            refuse_unless_forced(path, "deviations", f"{label}: the true train (mass x{truth['mass']:.3g}, resistance "
                                 f"x{truth['resistance']:.3g}, traction x{truth['traction']:.3g}) cannot reach the stop "
                                 f"({why}): the run would be simulated to the loop's cap of {cap:,.0f} s ({duration(cap)})")
        per_sample = spec_seconds(case["controller"], case["points"],
                                  horizon_samples(case["window"][1], case["sample_time"]), modes)
        span = max(fastest, case["window"][1])
        samples = span / case["sample_time"]
        check_run(path, "controllers", f"{label}: {how_many(samples)} samples of {case['sample_time']:g} s", samples * per_sample)
        runs.append(samples * per_sample)
    return runs


def _true_all_out(case, truth):
    """(all-out time of the draw's true train [s], the loop's time cap [s], why it cannot run or None,
    the modes RSPC would switch among: the train's DAS levels, which the draw does not change)."""
    track = track_from_schema(validate(schemas.TrackFile, case["track"], "track"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)  # shown once when the study was expanded
        train = true_train(train_from_schema(validate(schemas.TrainFile, case["train"], "train"), "train"), truth)
    segment, modes = make_segment(track, train, case["from"], case["to"]), len(rspc_modes(train))
    cap = 20 * segment.distance + 600  # control.loop.run_loop's max_time
    nodes = make_grid(segment, case["points"])
    try:
        speeds = kinematics.envelope_speeds(segment, train, nodes, node_limits(segment, nodes))
    except InfeasibleError as exc:
        return np.inf, cap, str(exc).removeprefix("infeasible: "), modes
    return kinematics.running_time(speeds, nodes), cap, None, modes
