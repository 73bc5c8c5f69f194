"""Size and time estimates of one run, made before anything is computed: work that would run for
days, fill the memory or simulate a train that never arrives is refused with its estimate
(:func:`ecostudy.core.budget.check_run`), unless the command is given ``--force``.

The constants are measured on this project's shared 2-core machine (so they are pessimistic):

- a network leg (the time-domain NLP of :mod:`ecostudy.ocp.timedomain`) of 200 and 2 000 clock
  steps (the metro's Noord - Station in 100 s) took 28 s and 233 s to build and solve from a cold
  start (286 and 332 Ipopt iterations) and 24 MB and 144 MB of memory: about 0.12 s and 72 kB a step;
- a closed-loop sample: the controllers' mean solve times of the metro Monte Carlo study
  (docs/closed_loop.md): convex 28 ms at K = 200, SBPC 91 ms, SPPC 253 ms, RSPC 22 ms; a replay
  only steps the plant. The convex SOCP grows faster than K: the all-out SOCP of the Amsterdam
  case took 0.17, 0.69, 3.3 and 9.4 s at K = 200, 1000, 2000 and 5000 and over 100 s at 20 000
  (busy machine), so a sample is taken as 28 ms x (K / 200)^1.5 (:func:`sample_seconds`);
- one space-domain run (build, NL write, Ipopt, verification) of the default study (K = 1000):
  1.3 s on a quiet machine, 2.6 s on a busy one: :data:`RUN_SECONDS_PER_POINT`; a DAS ``phases``
  advice adds two NLPs of the same size and ``minlp`` its time limit (:func:`run_seconds`).
"""
from dataclasses import replace

import numpy as np

from ecostudy.core import kinematics
from ecostudy.core.budget import check_run, duration, refuse_unless_forced
from ecostudy.core.errors import InfeasibleError
from ecostudy.core.grid import make_grid, make_segment, node_limits
from ecostudy.io.loaders import track_from_schema, train_from_schema, validate
from ecostudy.io import schemas
from ecostudy.ocp.problem import prepare

LEG_SECONDS_PER_STEP = 0.12
LEG_BYTES_PER_STEP = 72e3
SAMPLE_SECONDS = {"convex": 0.028, "sbpc": 0.091, "sppc": 0.253, "rspc": 0.022}  # convex: at K = 200
REPLAY_SECONDS = 0.001
CONVEX_GROWTH = 1.5   # a convex sample's time grows as K^1.5
RUN_SECONDS_PER_POINT = 2.6e-3
DAS_EXTRA_POINT_RUNS = {"round": 0.0, "phases": 2.0, "minlp": 3.0}
RUN_BYTES_PER_POINT = 20e3        # the space NLP of K points (Ipopt's factor and the model): 20 MB at K = 1000


def run_seconds(points, das=None, das_time_limit=60.0):
    """One space-domain run of ``points`` grid nodes, with its DAS advice [s]."""
    seconds = points * RUN_SECONDS_PER_POINT * (1 + DAS_EXTRA_POINT_RUNS.get(das or "round", 0.0))
    return seconds + (das_time_limit if das == "minlp" else 0.0)


def sample_seconds(kind, points):
    """Estimated computing of one closed-loop sample of a controller ``kind`` at ``points`` nodes [s]."""
    if kind == "convex":
        return SAMPLE_SECONDS["convex"] * (points / 200) ** CONVEX_GROWTH
    return SAMPLE_SECONDS.get(kind, REPLAY_SECONDS)


def check_network(study, path):
    """Refuse a network study whose time-domain legs are estimated above one run's budget; returns
    every leg's clock steps."""
    legs = []
    for i, (a, b) in enumerate(zip(study.stops[:-1], study.stops[1:])):
        if study.running_times is not None:
            seconds, field = float(study.running_times[i]), f"running_times_s[{i}]"
        else:
            case = prepare(study.track, study.train, a, b, study.points)
            seconds, field = case.estimate * (1 + study.supplement), "supplement_percent"
        steps = int(np.ceil(seconds / study.dt))
        check_run(path, field, f"the leg {a} - {b} of {seconds:g} s is {steps:,} clock steps of {study.dt:g} s "
                  "for each train and strategy", steps * LEG_SECONDS_PER_STEP, steps * LEG_BYTES_PER_STEP)
        legs.append(steps)
    return legs


def true_train(train, truth):
    """The plant's train of a draw (``core.plant.Truth`` as a dict): the heavier mass, the larger
    resistance and the weaker traction that :class:`~ecostudy.core.plant.Plant` drives."""
    return replace(train, mass=train.mass * truth["mass"], static_mass=train.static_mass * truth["mass"],
                   davis=tuple(c * truth["resistance"] for c in train.davis),
                   traction=train.traction.scaled(truth["traction"]))


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
        fastest, cap, message = seen[key]
        label = f"{case['labels']['controller']} draw {case['labels']['draw']}"
        if message is not None or fastest > cap:
            why = message or f"its all-out time is {fastest:.0f} s"
            refuse_unless_forced(path, "deviations", f"{label}: the true train (mass x{truth['mass']:.3g}, resistance "
                                 f"x{truth['resistance']:.3g}, traction x{truth['traction']:.3g}) cannot reach the stop "
                                 f"({why}): the run would be simulated to the loop's cap of {cap:,.0f} s ({duration(cap)})")
        per_sample = sample_seconds(case["controller"].get("kind", "convex"), case["points"])
        span = max(fastest, case["window"][1])
        samples = span / case["sample_time"]
        check_run(path, "controllers", f"{label}: {samples:,.0f} samples of {case['sample_time']:g} s", samples * per_sample)
        runs.append(samples * per_sample)
    return runs


def _true_all_out(case, truth):
    """(all-out time of the draw's true train [s], the loop's time cap [s], why it cannot run or None)."""
    track = track_from_schema(validate(schemas.TrackFile, case["track"], "track"))
    train = true_train(train_from_schema(validate(schemas.TrainFile, case["train"], "train"), "train"), truth)
    segment = make_segment(track, train, case["from"], case["to"])
    cap = 20 * segment.distance + 600  # control.loop.run_loop's max_time
    nodes = make_grid(segment, case["points"])
    try:
        speeds = kinematics.envelope_speeds(segment, train, nodes, node_limits(segment, nodes))
    except InfeasibleError as exc:
        return np.inf, cap, str(exc).removeprefix("infeasible: ")
    return kinematics.running_time(speeds, nodes), cap, None
