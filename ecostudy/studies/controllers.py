"""The controller kinds of a closed-loop study, registered by name (``io.loopfile.CONTROLLER_KINDS``).

Each kind is a builder ``build(b: Build) -> controller`` (anything with ``plan(state) -> handle``
that ``control.loop.run_loop`` drives) and the controller options it reads besides the common
ones (``uses``); the study file's loader refuses any other option given to that kind. A new kind
is a module with its controller, its builder and one ``CONTROLLER_KINDS.register`` line, imported
here (``from ecostudy.control import NAME  # noqa: F401``) so that a study file may name it; an
option of its own is a field of ``io.loopfile.Controller`` named in its ``uses``
(docs/closed_loop.md, "Adding a controller kind").
"""
import json
from typing import Any, NamedTuple

import numpy as np

from ecostudy.analysis.single import solve_run
from ecostudy.control.controllers import Convex, ForceReplay, OpenLoop
from ecostudy.control.rspc import Rspc
from ecostudy.control.sbpc import Sbpc
from ecostudy.control.sppc import Sppc
from ecostudy.core.errors import InputError
from ecostudy.core.types import State, Timing
from ecostudy.io.loopfile import CONTROLLER_KINDS
from ecostudy.ocp.convex import ConvexProgram, ConvexWeights, trapezoid_grid
from ecostudy.ocp.problem import prepare


class Build(NamedTuple):
    """What a builder gets: the case (``studies.closedloop``), its controller spec with every default
    filled in, the track, segment and model train, the mass estimator (or None), the arrival window
    [s], the grid points, the brake reserve to pass on ({} for the kind's own default) and the
    controller's sample time [s]."""

    case: dict
    spec: dict
    track: Any
    segment: Any
    train: Any
    estimator: Any
    window: tuple
    points: int
    reserve: dict
    sample_time: float


def convex_program(segment, train, points, spec):
    """Yazhemsky 2017's SOCP 6.10 of a controller spec (a ``loopfile.Controller`` as a dict)."""
    s = spec["settings"]
    weights = ConvexWeights(s["time"], s["energy"], s["overspeed"], s["braking"], s["buffer_mps"],
                            s["brake_level_mps2"])
    return ConvexProgram(segment, train, trapezoid_grid(segment, points), weights, scheme=spec["scheme"])


_ATO_RUNS: dict = {}  # the ATO run of each (line, train, stops, arrival, grid) solved in this process


def _ato(b):
    """The nominal train's energy-optimal ATO run at the latest arrival: the same for every draw of a
    study (the draws change the plant, not the model), so solved once per process and shared
    (the controllers only read it)."""
    key = json.dumps([b.case["track"], b.case["train"], b.case["from"], b.case["to"], b.window[1], b.points],
                     sort_keys=True, default=str)
    if key not in _ATO_RUNS:
        _ATO_RUNS[key] = solve_run(b.track, b.train, b.case["from"], b.case["to"], Timing(running_time=b.window[1]),
                                   points=b.points, verify_result=False)
    return _ATO_RUNS[key]


def _from_ato(controller, b):
    """``controller`` with the ATO run it replays or plans from (``plans_from``), whose status is a
    part of each of its runs' (``studies.closedloop``)."""
    controller.plans_from = _ato(b)
    return controller


def convex(b):
    """Yazhemsky 2017's SOCP 6.10 re-solved every sample from the measured state."""
    return Convex(convex_program(b.segment, b.train, b.points, b.spec), b.window, b.estimator, hold=b.sample_time,
                  budget=b.spec["time_budget_s"])


def open_loop(b):
    """The convex controller's own plan from the stand, replayed by position."""
    plan = convex_program(b.segment, b.train, b.points, b.spec).solve(State(), b.window)
    if not plan.usable:
        raise InputError(f"no open-loop plan in the window {b.window}")
    replay = ForceReplay(b.train, plan.nodes, plan.force)
    replay.plan_ended = plan.status  # AlmostSolved: usable, not proven optimal (part of each run's status)
    return replay


def ato(b):
    """The energy-optimal ATO run at the latest arrival, replayed by position."""
    return _from_ato(OpenLoop(_ato(b)), b)


def sbpc(b):
    """Farooqi 2018's shrinking-horizon move-blocking controller (Ch. 4)."""
    prepared = prepare(b.track, b.train, b.case["from"], b.case["to"], b.points)
    reference = _ato(b).trajectory
    speeds = np.interp(prepared.nodes, reference.nodes, reference.v)
    s = b.spec
    return _from_ato(Sbpc(prepared, b.window[1], b.sample_time, s["block"], speeds, s["variant"], s["omega"],
                          transcription=s["transcription"], **b.reserve), b)


def sppc(b):
    """Farooqi 2018's shrinking-horizon parametrised controller (Ch. 5), DAS modes by construction."""
    return _from_ato(Sppc(_ato(b), b.window[1], b.points, b.spec["variant"], **b.reserve), b)


def rspc(b):
    """Farooqi 2018's receding-horizon switched controller (Ch. 6), DAS modes by construction."""
    r = b.spec["rspc"]
    return Rspc(prepare(b.track, b.train, b.case["from"], b.case["to"], b.points), b.window[1], b.sample_time,
                r["horizon"], r["distance_m"], r["gamma"], r["margin_s"], **b.reserve)


CONTROLLER_KINDS.register("convex", convex, uses={"settings", "estimator", "scheme", "time_budget_s"})
CONTROLLER_KINDS.register("open_loop", open_loop, uses={"settings", "scheme"})
CONTROLLER_KINDS.register("ato", ato)
CONTROLLER_KINDS.register("sbpc", sbpc, uses={"block", "variant", "omega", "transcription", "brake_reserve",
                                              "terminal_reserve", "terminal_fit"})
CONTROLLER_KINDS.register("sppc", sppc, uses={"variant", "brake_reserve", "terminal_reserve", "terminal_fit"})
CONTROLLER_KINDS.register("rspc", rspc, uses={"rspc", "brake_reserve"})
