"""A saved run judged again, not taken on its word: the folder of `ecostudy solve` re-simulated from
its profile against its track and train, as the solve verified it (``core.simulate.verify``).

``ecostudy check`` and ``ecostudy export`` report this status, so a ``summary.json`` that says ok
over a run that does not reach its stop, or a profile edited after the solve, is not passed on as
ok: a run is verified by the independent integrator on the same physics functions, here as at the
solve.
"""
from pathlib import Path
from typing import Any, NamedTuple, Sequence

import numpy as np

from ecostudy.analysis import pontryagin, regimes
from ecostudy.analysis.tables import handles, tabulate
from ecostudy.core.errors import InputError, problem
from ecostudy.core.kinematics import net_force_needed
from ecostudy.core.simulate import missed_points, verify, within_tolerances
from ecostudy.core.status import (EARLY_TOLERANCE_S, LATE_TOLERANCE_S, OVERSPEED_TOLERANCE_KMH, Status, flagged,
                                   past, worst)
from ecostudy.core.types import Timing, Window
from ecostudy.core.units import KMH, KWH, PERCENT
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.results import SavedRun, check_status, check_unchanged, on_grid
from ecostudy.io.runsummary import Verification, current
from ecostudy.ocp.problem import prepare

# the totals summary.json records, which the profile's own must give (the profile's %.6g digits
# sum to within about 1e-6 of the solve's; an edit shows far above)
RECORDED = ("running_time_s", "traction_energy_kWh", "braking_energy_kWh", "regenerated_energy_kWh", "net_energy_kWh",
            "traction_energy_J_per_kg", "top_speed_kmh")
PROFILE_SPEED_KMH = 2.0  # a saved speed this far from its forces' re-simulation is not theirs (K = 10: 1.2 km/h; K >= 200: 0.01)
HANDLE = 1e-3  # the handle column against the forces' handle (the digits written: about 5e-6 apart)
AGREE = 1e-4  # relative, of the larger total (at least 1 s or 1 kWh)
WRITTEN = 5e-6  # relative: half a unit in the sixth significant digit, the precision of profile.csv's numbers
MOTION_SLACK = 10.0  # the profile's equation of motion may miss by this many times what its digits allow
# the saved verification's errors and the re-simulation's from the profile agree to this share of each
# error's tolerance (0.01 m of the stop's 1 m); measured at most 4e-4 of it (the profile's six digits,
# 11 runs of K = 40 and 200 on the shipped tracks and trains)
SAVED_ERROR = 0.01
SIMULATED = ("simulated_running_time_s", "simulated_traction_energy_kWh", "simulated_net_energy_kWh")
REGIME_INTERVALS = 2  # a regime's boundary, share or agreement may move this many intervals (the forces' digits)


class Rejudged(NamedTuple):
    status: Status                 # the saved status and the re-simulation's, the worse
    verification: dict[str, Any]   # the re-simulation's block, as ``summary.json`` records the solve's
    track: Any
    train: Any
    case: Any                      # the run's prepared case (``ocp.problem.prepare``): its grid, limits and windows


def windows_record(windows: Sequence[Window]) -> list[dict[str, Any]]:
    """Timing windows as ``inputs.json`` keeps them (display units), so the run can be judged again."""
    return [{"distance_m": w.distance, "earliest_s": w.earliest, "latest_s": w.latest,
             "min_speed_kmh": None if w.min_speed is None else w.min_speed / KMH,
             "max_speed_kmh": None if w.max_speed is None else w.max_speed / KMH} for w in windows]


def timing_record(timing: Timing) -> dict[str, Any]:
    """A run's timing as ``inputs.json`` keeps it (display units): the running time, supplement or
    window asked, each null when not given (all null: the all-out run)."""
    return {"running_time_s": timing.running_time,
            "supplement_percent": None if timing.supplement is None else timing.supplement / PERCENT,
            "window_s": None if timing.window is None else list(timing.window)}


def run_inputs(result: Any, study: str | Path | None = None, das: str | None = None) -> dict[str, Any]:
    """``inputs.json`` of a run of :func:`~ecostudy.analysis.single.solve_run` (``result``): the
    files of its track and train with their digests as they were read, its stops, grid, timing
    windows, objective, timing and weights, the ``study`` file and the driver advice ``das`` asked
    (``ecostudy solve``'s), all that ``ecostudy check`` needs to judge it again. A run whose track
    or train was built in code names no file to judge it against: refused, naming which."""
    request, summary = result.request, result.summary
    if request is None:
        raise InputError(problem("arguments", "run", "a point a front solved on its shared model, which records no "
                                 "inputs.json: solve its running time with api.solve and save that run"))
    missing = [name for name, file in (("track", request.track_file), ("train", request.train_file)) if file is None]
    if missing:
        raise InputError([problem("arguments", name, "built in code (or changed with dataclasses.replace), not read "
                                  "from a file: a saved run names the files ecostudy check re-simulates it against; "
                                  f"write it to a file and read it with api.load_{name}") for name in missing])
    (track, track_sha), (train, train_sha) = request.track_file, request.train_file
    return {"track": track, "train": train, "track_sha256": track_sha, "train_sha256": train_sha,
            "from": summary["from"], "to": summary["to"], "points": summary["points"],
            "windows": windows_record(result.windows), "study": None if study is None else str(Path(study).resolve()),
            "objective": summary["objective"], "timing": timing_record(request.timing),
            "weights": list(request.weights) if summary["objective"] == "mixed" else None, "das": das}


def asked_times(inputs: dict[str, Any], all_out_s: float | None, where: Path) -> tuple[float, float] | None:
    """(earliest, latest) [s] the saved run was asked to arrive in (``inputs.json``'s ``timing``, a
    supplement over the summary's all-out time ``all_out_s``), or None when it records none."""
    record = inputs.get("timing")
    if record is None:
        return None
    try:
        if record.get("running_time_s") is not None:
            return (float(record["running_time_s"]),) * 2
        if record.get("window_s") is not None:
            earliest, latest = map(float, record["window_s"])
            return earliest, latest
        if record.get("supplement_percent") is not None and all_out_s is not None:
            return (float(all_out_s) * (1 + float(record["supplement_percent"]) * PERCENT),) * 2
    except (AttributeError, TypeError, ValueError) as exc:
        raise InputError(problem(where, "timing", f"not the timing a solve records ({exc!r})"))
    return None


def _missed_time(running_s: float, asked: tuple[float, float] | None) -> list[str]:
    """The reason of a saved run arriving outside what it was asked (:func:`asked_times`)."""
    if asked is None:
        return []
    late, early = running_s - asked[1], asked[0] - running_s
    said = f"{asked[0]:g} s" if asked[0] == asked[1] else f"the window {asked[0]:g}-{asked[1]:g} s"
    if late > LATE_TOLERANCE_S:
        return [f"the saved run arrives {past(late, LATE_TOLERANCE_S, 2, 'f')} s after {said} asked (inputs.json timing)"]
    if early > EARLY_TOLERANCE_S:
        return [f"the saved run arrives {past(early, EARLY_TOLERANCE_S, 2, 'f')} s before {said} asked (inputs.json timing)"]
    return []


def _number(x: Any) -> float | None:
    return None if x is None else float(x)


def _windows(inputs: dict[str, Any], where: Path) -> list[Window]:
    try:
        return [Window(float(w["distance_m"]), _number(w["earliest_s"]), _number(w["latest_s"]),
                       None if w["min_speed_kmh"] is None else float(w["min_speed_kmh"]) * KMH,
                       None if w["max_speed_kmh"] is None else float(w["max_speed_kmh"]) * KMH)
                for w in inputs.get("windows") or ()]
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(problem(where, "windows", f"not the timing windows a solve records ({exc!r})"))


def saved_case(track: Any, train: Any, inputs: dict[str, Any], where: Path) -> Any:
    """The prepared case of a saved run (its stops, grid and timing windows from ``inputs.json``,
    ``where``); a field that names no case of the track and train is one line naming it."""
    stops = getattr(track, "stops", {})
    for name in ("from", "to"):
        if not isinstance(inputs.get(name), str) or inputs[name] not in stops:
            raise InputError(problem(where, name, f"{inputs.get(name)!r} is not a stop of {inputs['track']}: an edited "
                                     "file? solve again"))
    if inputs["from"] == inputs["to"]:
        raise InputError(problem(where, "to", f"'{inputs['to']}' is the stop the run departs from: an edited file? solve again"))
    windows, length = _windows(inputs, where), abs(stops[inputs["to"]] - stops[inputs["from"]])
    for n, w in enumerate(windows):
        if not 0.0 < w.distance < length:
            raise InputError(problem(where, f"windows[{n}].distance_m", f"{w.distance:g} m is not between the stops "
                                     f"({length:g} m apart): an edited file? solve again"))
    return prepare(track, train, inputs["from"], inputs["to"], inputs["points"], windows=windows)


def rejudged(saved: SavedRun, result_dir: Path | str) -> Rejudged:
    """``saved`` (``io.results.load_result``) re-simulated from its profile's handles against its
    track and train, unchanged since the solve (refused otherwise): its totals must be those
    ``summary.json`` records (refused otherwise: an edited file), and the re-simulation must keep
    the stop, the time, the energy, the speed limit, the adhesion limit and the timing windows within
    the solve's tolerances, else the run is flagged whatever its summary says."""
    result_dir = Path(result_dir)
    inputs = saved.inputs
    for name in ("track", "train", "from", "to"):
        if name not in inputs:
            raise InputError(problem(result_dir / "inputs.json", name, "missing: an edited file? solve again"))
    check_unchanged(inputs, result_dir)
    track, train = load_track(inputs["track"]), load_train(inputs["train"])
    check_status(saved.status, saved.summary, result_dir / "summary.json", train.calibration_reason)  # the train's too
    case = saved_case(track, train, inputs, result_dir / "inputs.json")
    on_grid(saved.trajectory, case.nodes, inputs, result_dir / "profile.csv")
    x, v, dt, ft, fb = saved.trajectory
    _, totals = tabulate(train, case.nodes, v, dt, ft, fb)
    u = handles(train, v, ft, fb)
    off = np.flatnonzero(~(np.abs(u - saved.handle) <= HANDLE))
    if off.size:
        raise InputError(problem(result_dir / "profile.csv", f"handle, row {off[0] + 2}", f"{saved.handle[off[0]]:g}, but "
                                 f"the row's forces give {u[off[0]]:.6g}: an edited profile? solve again"))
    motion(train, case, v, ft, fb, result_dir / "profile.csv")
    for name in RECORDED:
        said = saved.summary.get(name)
        if not isinstance(said, (int, float)) or not abs(said - totals[name]) <= AGREE * max(abs(said), abs(totals[name]), 1.0):
            raise InputError(problem(result_dir / "summary.json", name, f"{said!r}, but the profile's run gives "
                                     f"{totals[name]:.6g}: an edited file? solve again"))
    said = saved.summary.get("distance_m")
    if not isinstance(said, (int, float)) or not abs(said - case.segment.distance) <= AGREE * max(said, 1.0):
        raise InputError(problem(result_dir / "summary.json", "distance_m", f"{said!r}, but its stops are "
                                 f"{case.segment.distance:.6g} m apart: an edited file? solve again"))
    block, trace = verify(case.segment, train, case.nodes, u, totals["running_time_s"],
                      totals["traction_energy_kWh"] * KWH, case.windows, net_energy=totals["net_energy_kWh"] * KWH)
    same_verification(saved.summary.get("verification"), block, result_dir / "summary.json")
    same_regimes(saved, train, case.nodes, result_dir)
    errors = Verification.from_dict(block).errors  # the saved status saying these very numbers: not said twice
    reasons = [] if within_tolerances(block) or f"({errors})" in (saved.status.reason or "") else [
        f"re-simulated from the saved profile, outside tolerance ({errors})"]
    reasons += [f"re-simulated from the saved profile, {missed}" for missed in missed_points(block["windows"])]
    reasons += _missed_time(totals["running_time_s"], asked_times(inputs, saved.summary.get("all_out_time_s"),
                                                                   result_dir / "inputs.json"))
    over = (v - case.limits) / KMH
    if np.max(over) > OVERSPEED_TOLERANCE_KMH:
        k = int(np.argmax(over))
        reasons.append(f"the saved profile runs {over[k]:.2f} km/h over the speed limit at {x[k]:.0f} m")
    gap = np.abs(np.interp(x, np.maximum.accumulate(trace.x), trace.v) - v) / KMH
    if np.max(gap) > PROFILE_SPEED_KMH:
        k = int(np.argmax(gap))
        reasons.append(f"the saved profile's speed at {x[k]:.0f} m is {gap[k]:.1f} km/h from what its forces give when "
                       "re-simulated")
    status = worst([saved.status, flagged("; ".join(reasons)) if reasons else saved.status])
    return Rejudged(status, block, track, train, case)



def motion(train: Any, case: Any, v: Any, ft: Any, fb: Any, where: Path) -> None:
    """Refuse a profile whose speeds and forces do not keep the space NLP's equation of motion on
    its grid (``kinematics.net_force_needed``: M (v1^2 - v0^2) / (2 ds) + R(v0, v1) = F_T - F_B per
    interval) to within what its six digits allow (:data:`WRITTEN`, times :data:`MOTION_SLACK`): a
    solved run misses by less than that bound (at most 0.8 of it on the shipped studies and published
    trains), a speed column edited by 0.1 % by 100 times it. The re-simulation alone passed a 2 %
    edit with its clock made to agree (inside its 2 km/h)."""
    ds = np.diff(case.nodes)
    missed = np.abs(net_force_needed(v, case.segment, train, case.nodes) - (ft - fb))
    allowed = (train.mass * 2 * WRITTEN * (v[:-1] ** 2 + v[1:] ** 2) / (2 * ds)
               + WRITTEN * (np.abs(ft) + np.abs(fb)) + 1e-6 * train.traction.peak)
    k = int(np.argmax(missed / allowed))
    if missed[k] > MOTION_SLACK * allowed[k]:
        raise InputError(problem(where, f"speed_kmh, rows {k + 2}-{k + 3}", f"the run's equation of motion misses by "
                                 f"{missed[k]:.3g} N between these rows (their digits allow {allowed[k]:.3g} N): an "
                                 "edited profile? solve again"))


def same_verification(said: Any, block: dict[str, Any], where: Path) -> None:
    """Refuse a saved ``verification`` block (``said``; None: the run was not re-simulated) whose
    numbers are not the re-simulation's ``block`` from the profile: each error within
    :data:`SAVED_ERROR` of its tolerance, each simulated total within :data:`AGREE` (relative), each
    timing window's passing time and speed within :data:`SAVED_ERROR` of their 0.5 s and 0.5 km/h
    (whether it is kept is judged again against inputs.json's window, :func:`rejudged`)."""
    if said is None:
        return
    said = current(said) if isinstance(said, dict) else {}
    limits = {**{key: SAVED_ERROR * tolerance for key, tolerance in block["tolerances"].items()},
              **{key: AGREE * max(abs(block[key]), 1.0) for key in SIMULATED}}
    for key, limit in limits.items():
        value = said.get(key)
        if not (isinstance(value, (int, float)) and abs(value - block[key]) <= limit):
            raise InputError(problem(where, f"verification.{key}", f"{value!r}, but the saved profile re-simulated "
                                     f"gives {block[key]:.6g}: an edited file? solve again"))
    windows = said.get("windows")
    for n, ours in enumerate(block["windows"]):
        theirs = windows[n] if isinstance(windows, list) and n < len(windows) else None
        if not (isinstance(theirs, dict) and all(
                isinstance(theirs.get(k), (int, float)) and abs(theirs[k] - ours[k]) <= SAVED_ERROR * 0.5
                for k in ("simulated_time_s", "simulated_speed_kmh"))):
            raise InputError(problem(where, f"verification.windows[{n}]", f"{theirs!r}, but the saved profile "
                                     f"re-simulated passes at {ours['simulated_time_s']:.6g} s, "
                                     f"{ours['simulated_speed_kmh']:.6g} km/h: an edited file? solve again"))
    if isinstance(windows, list) and len(windows) != len(block["windows"]):
        raise InputError(problem(where, "verification.windows", f"{len(windows)} timing windows where the run has "
                                 f"{len(block['windows'])}: an edited file? solve again"))


def same_regimes(saved: SavedRun, train: Any, nodes: np.ndarray, result_dir: Path) -> None:
    """Refuse a saved run whose ``regimes`` (sequence, runs, distance shares) are not its forces'
    (``regimes.labelled``), or whose ``pontryagin`` agreement is not what its profile's
    ``costate_ratio`` gives against those regimes (``pontryagin.costate_check``): each within
    :data:`REGIME_INTERVALS` intervals."""
    x, v, _, ft, fb = saved.trajectory
    objective = saved.summary.get("objective")
    labels = regimes.labelled(train, v, ft, fb, objective)
    ours, said = regimes.block(labels, nodes), saved.summary.get("regimes")
    step = REGIME_INTERVALS * float(np.max(np.diff(nodes)))
    distance = float(x[-1] - x[0])
    wrong = _wrong_regimes(said if isinstance(said, dict) else {}, ours, step, distance)
    if wrong:
        raise InputError(problem(result_dir / "summary.json", f"regimes.{wrong}", f"not the regimes of the "
                                 f"profile's forces ({ours['sequence']}): an edited file? solve again"))
    recorded = saved.summary.get("pontryagin")
    if saved.costate is None or recorded is None:
        return
    check = pontryagin.costate_check(train, nodes, v, ft, fb, labels, saved.costate, objective)
    for name, slack in (("agreement_pct", 100.0 * step / distance),
                        ("intervals_agreeing_pct", 100.0 * REGIME_INTERVALS / len(ft))):
        value = recorded.get(name) if isinstance(recorded, dict) else None
        if not (isinstance(value, (int, float)) and abs(value - check[name]) <= slack):
            raise InputError(problem(result_dir / "profile.csv", "costate_ratio", f"gives {name} {check[name]:.1f} "
                                     f"against the regimes of the profile's forces, but summary.json's "
                                     f"pontryagin.{name} is {value!r}: an edited profile or summary? solve again"))


def _wrong_regimes(said: dict[str, Any], ours: dict[str, Any], step: float, distance: float) -> str:
    """The first field of a saved ``regimes`` block that is not ``ours`` (boundaries within ``step``
    [m], shares within ``step`` of the ``distance``), '' when none."""
    runs = said.get("runs")
    if said.get("sequence") != ours["sequence"]:
        return "sequence"
    if not isinstance(runs, list) or len(runs) != len(ours["runs"]) or not all(
            isinstance(a, dict) and a.get("regime") == b["regime"] and all(
                isinstance(a.get(k), (int, float)) and abs(a[k] - b[k]) <= step for k in ("start_m", "end_m"))
            for a, b in zip(runs, ours["runs"])):
        return "runs"
    shares = said.get("distance_shares")
    for name, share in ours["distance_shares"].items():
        value = shares.get(name) if isinstance(shares, dict) else None
        if not (isinstance(value, (int, float)) and abs(value - share) <= step / distance):
            return f"distance_shares.{name}"
    return ""
