"""Reading back the output folder of `ecostudy solve`: its inputs, its summary and its profile as
an SI :class:`~ecostudy.core.types.Trajectory` (the display units converted here)."""
import json
from os import PathLike
from pathlib import Path
from typing import Any, NamedTuple, Optional

import numpy as np
import pandas as pd

from ecostudy.core.errors import InputError, problem
from ecostudy.core.status import ADHESION_USE, CALIBRATED, TOLERANCES, Status
from ecostudy.core.kinematics import cumulative_work, interval_power, interval_time
from ecostudy.core.simulate import within_tolerances
from ecostudy.core.modes import mode_name, names_mode
from ecostudy.core.types import Trajectory
from ecostudy.core.units import KMH, KN, KW, KWH
from ecostudy.io.documents import file_digest as file_digest  # re-exported: inputs.json's digests
from ecostudy.io.runsummary import current, status_parts
from ecostudy.io.tables import number_columns
from ecostudy.io.writers import check_name_length


def check_unchanged(inputs: dict[str, Any], result_dir: str | PathLike[str],
                    names: tuple[str, ...] = ("track", "train")) -> None:
    """Refuse a saved run whose track or train file (``names``) changed since it was solved
    (``inputs.json`` keeps their digests): checking it against the edited file would check another problem."""
    for name in names:
        digest = inputs.get(f"{name}_sha256")
        if digest is None:
            raise InputError(problem(Path(result_dir) / "inputs.json", f"{name}_sha256", "missing: solved by an older "
                                     "ecostudy, whose inputs cannot be told unchanged; solve again"))
        try:
            now = file_digest(inputs[name])
        except OSError:
            raise InputError(problem(inputs[name], "", f"the {name} file of this result is gone"))
        if now != digest:
            raise InputError(problem(inputs[name], "", f"the {name} file changed since this result was solved; "
                                     "solve again"))


class SavedRun(NamedTuple):
    inputs: dict[str, Any]  # inputs.json: track and train paths, stops, grid size
    summary: dict[str, Any]  # summary.json
    trajectory: Trajectory
    handle: np.ndarray    # the handle per interval (profile.csv's handle on the interval's first row)
    advice: Optional[pd.DataFrame] = None  # advice.csv, when the run has driver advice
    costate: Optional[np.ndarray] = None  # psi per interval (costate_ratio), of a run of objective energy or net_energy

    @property
    def status(self) -> Status:
        """The run's status as it was saved (``failed`` for a folder that recorded none)."""
        return Status.parse(str(self.summary.get("status") or "failed: no status recorded"))


def load_result(result_dir: str | PathLike[str]) -> SavedRun:
    """The :class:`SavedRun` of a result folder; a folder that is not one, or whose profile is cut
    short or holds anything but finite numbers, is one clear line."""
    result_dir = Path(result_dir)
    check_name_length(result_dir)
    if not result_dir.is_dir():
        raise InputError(problem(result_dir, "", "a file, not a result folder of `ecostudy solve`"
                                 if result_dir.exists() else "no such folder"))
    for name in ("inputs.json", "summary.json"):
        if not (result_dir / name).is_file():
            raise InputError(problem(result_dir, "", f"not a result folder of `ecostudy solve`: it has no {name}"))
    try:
        inputs = json.loads((result_dir / "inputs.json").read_text())
        summary = json.loads((result_dir / "summary.json").read_text())
    except (OSError, ValueError) as exc:
        raise InputError(problem(result_dir, "", f"not a result folder of `ecostudy solve` ({exc})"))
    points = inputs.get("points") if isinstance(inputs, dict) else None
    if not isinstance(points, int) or isinstance(points, bool):
        raise InputError(problem(result_dir / "inputs.json", "points", "not a result folder of `ecostudy solve` "
                                 "(no grid size)"))
    if not isinstance(summary, dict):
        raise InputError(problem(result_dir / "summary.json", "", "not a result folder of `ecostudy solve` "
                                 "(expected a mapping of fields)"))
    if summary.get(WRITING):  # the marker write_run puts first and replaces last
        raise InputError(problem(result_dir, "", "not a result folder of `ecostudy solve`: its files were being "
                                 "written when the write stopped (an interrupted write?): solve again"))
    _check_record(inputs, summary, result_dir)
    try:  # a status outside the vocabulary: an edited summary (one its parts contradict: check_status)
        status = Status.parse(str(summary.get("status") or "failed: no status recorded"))
    except ValueError as exc:
        raise InputError(problem(result_dir / "summary.json", "status", f"{exc} (ok, flagged: <reason> or failed: <reason>)"))
    costate = ("costate_ratio",) if summary.get("objective") in COSTATE_OBJECTIVES else ()
    p = number_columns(result_dir / "profile.csv", (*PROFILE_COLUMNS, *DERIVED_COLUMNS, *costate), rows=points,
                       open_last=("traction_force_kN", "braking_force_kN", "handle", "power_kW", *costate))
    for column, strictly in (("position_m", True), ("time_s", False)):  # rows out of order: a run read backwards
        steps = np.diff(p[column])
        back = np.flatnonzero(steps <= 0 if strictly else steps < 0)
        if back.size:
            raise InputError(problem(result_dir / "profile.csv", f"{column}, row {back[0] + 3}", f"{p[column][back[0] + 1]:g} "
                                     f"after {p[column][back[0]]:g}: the rows must {'increase' if strictly else 'not decrease'}"))
    for column in ("speed_kmh", "traction_force_kN", "braking_force_kN"):  # the solver's noise is far smaller
        below = np.flatnonzero(p[column] < -NOISE)
        if below.size:
            raise InputError(problem(result_dir / "profile.csv", f"{column}, row {below[0] + 2}",
                                     f"{p[column][below[0]]:g} is below 0 (a speed and each force are >= 0)"))
    _check_clock(p, result_dir / "profile.csv")
    _check_derived(p, result_dir / "profile.csv")
    _check_totals(p, summary, result_dir / "summary.json")
    _check_verification(summary, result_dir / "summary.json")
    check_status(status, summary, result_dir / "summary.json")
    trajectory = Trajectory(p["position_m"], p["speed_kmh"] * KMH, np.diff(p["time_s"]),
                            p["traction_force_kN"][:-1] * KN, p["braking_force_kN"][:-1] * KN)
    advice: pd.DataFrame | None = None
    if (result_dir / "advice.csv").is_file():
        try:
            advice = pd.read_csv(result_dir / "advice.csv")
        except (OSError, ValueError) as exc:
            raise InputError(problem(result_dir / "advice.csv", "", f"cannot be read ({exc})"))
        missing = [c for c in ("start_position_m", "mode", "handle", "target_speed_kmh") if c not in advice]
        if missing:
            raise InputError(problem(result_dir / "advice.csv", ", ".join(missing), "missing"))
        handle = pd.to_numeric(advice["handle"], errors="coerce").to_numpy(float)
        target = pd.to_numeric(advice["target_speed_kmh"], errors="coerce").to_numpy(float)
        cruise = advice["handle"].isna().to_numpy() & (target >= 0.0)  # a cruise row: a target, no handle
        bad = np.flatnonzero(~(np.abs(handle) <= 1.0 + NOISE) & ~cruise
                             | (advice["target_speed_kmh"].notna().to_numpy() & ~(target >= 0.0)))
        if bad.size:
            raise InputError(problem(result_dir / "advice.csv", f"handle, target_speed_kmh, row {bad[0] + 2}",
                                     f"'{advice['handle'].iloc[bad[0]]}', '{advice['target_speed_kmh'].iloc[bad[0]]}': "
                                     "a handle is a number from -1 to 1 and a target speed a number >= 0 (a cruise "
                                     "row: a target speed and no handle)"))
        wrong = [i for i, (text, h, v) in enumerate(zip(advice["mode"], handle, target)) if not names_mode(text, h, v)]
        if wrong:  # export hands the mode to on-board systems: it must be the handle's
            i = wrong[0]
            raise InputError(problem(result_dir / "advice.csv", f"mode, row {i + 2}",
                                     f"'{advice['mode'].iloc[i]}' is not the mode of handle {handle[i]:g}"
                                     + (f" and target {target[i]:g} km/h" if np.isfinite(target[i]) else "")
                                     + f" ('{mode_name(handle[i], target[i] * KMH)}')"))
        starts = pd.to_numeric(advice["start_position_m"], errors="coerce").to_numpy(float)
        bad = np.flatnonzero(~np.isfinite(starts) | (np.diff(starts, prepend=-np.inf) < 0))
        if bad.size:
            raise InputError(problem(result_dir / "advice.csv", f"start_position_m, row {bad[0] + 2}",
                                     f"'{advice['start_position_m'].iloc[bad[0]]}' is not a finite number at least "
                                     "the row's before"))
        advice = advice.assign(start_position_m=starts)
    return SavedRun(inputs, summary, trajectory, p["handle"][:-1], advice,
                    p["costate_ratio"][:-1] if costate else None)


def _half_digit(x: np.ndarray) -> np.ndarray:
    """Half a unit of the 6th significant digit of each value: the rounding of ``%.6g``, as the profile is written."""
    magnitude = np.floor(np.log10(np.maximum(np.abs(x), 1e-300)))
    return np.where(x == 0.0, 0.0, 0.5 * 10.0 ** (magnitude - 5))


def _check_clock(p: dict[str, np.ndarray], where: Path) -> None:
    """Refuse a profile whose clock does not follow from its positions and speeds: a solved run takes
    2 ds / (v0 + v1) over each interval (Farooqi 2018, eq. 2.16; ``kinematics.interval_time``),
    so a speed or a time edited after the solve shows, beyond the rounding of the digits written."""
    x, t, v = p["position_m"], p["time_s"], p["speed_kmh"] * KMH
    pair = np.maximum(v[:-1] + v[1:], 0.0)
    moving = pair > 0.0
    took = np.where(moving, interval_time(0.0, np.where(moving, pair, 1.0), np.diff(x)), np.inf)
    hx, ht, hv = _half_digit(x), _half_digit(t), _half_digit(p["speed_kmh"]) * KMH
    rounding = (ht[:-1] + ht[1:] + 2.0 * (hx[:-1] + hx[1:]) / np.where(moving, pair, 1.0)
                + took * (hv[:-1] + hv[1:]) / np.where(moving, pair, 1.0))
    off = np.flatnonzero(~(np.abs(np.diff(t) - took) <= 2.0 * rounding + 1e-9))
    if off.size:
        k = off[0]
        raise InputError(problem(where, f"position_m, time_s, speed_kmh, rows {k + 2}-{k + 3}", f"{np.diff(x)[k]:g} m at "
                                 f"{p['speed_kmh'][k]:g} -> {p['speed_kmh'][k + 1]:g} km/h takes {took[k]:.6g} s, not "
                                 f"the {np.diff(t)[k]:.6g} s written: an edited profile? solve again"))


def _check_record(inputs: dict[str, Any], summary: dict[str, Any], result_dir: Path) -> None:
    """Refuse a folder whose inputs.json and summary.json say different things of the same run (the
    stops, the grid size, the objective), whose summary records a marginal energy of the wrong sign
    or for a run that has none (objective time or mixed), or an all-out run (objective time) whose
    all-out time is not its own running time: one of them was edited (a check would judge the run
    as one and report it as the other)."""
    for field in ("from", "to", "points", "objective"):
        if field in inputs and inputs[field] != summary.get(field):
            raise InputError(problem(result_dir / "inputs.json", field, f"{inputs[field]!r}, but summary.json "
                                     f"records {summary.get(field)!r}: an edited record? solve again"))
    objective, marginal = summary.get("objective"), summary.get("marginal_energy_kWh_per_s")
    if objective == "time":  # the all-out run is its own: its time is the all-out time it records
        said, took = summary.get("all_out_time_s"), summary.get("running_time_s")
        if not (isinstance(said, (int, float)) and isinstance(took, (int, float))
                and abs(said - took) <= 1e-9 * max(abs(took), 1.0)):
            raise InputError(problem(result_dir / "summary.json", "all_out_time_s", f"{said!r}, but the all-out run "
                                     f"(objective time) records its own running time ({took!r}) there: an edited "
                                     "record? solve again"))
    if objective not in COSTATE_OBJECTIVES:  # what an energy optimum alone has: dE/dT and the costate check
        for field, what in (("marginal_energy_kWh_per_s", "a marginal energy"), ("pontryagin", "a costate check")):
            if summary.get(field) is not None:
                raise InputError(problem(result_dir / "summary.json", field, f"{what}, but a run of objective "
                                         f"{objective!r} has none: an edited record? solve again"))
    if marginal is not None and not (isinstance(marginal, (int, float)) and marginal <= MARGINAL_NOISE):
        raise InputError(problem(result_dir / "summary.json", "marginal_energy_kWh_per_s", f"{marginal!r}: a "
                                 "second more saves energy on an energy-optimal run (dE/dT <= 0): an edited file? "
                                 "solve again"))


def _check_derived(p: dict[str, np.ndarray], where: Path) -> None:
    """Refuse a profile whose power and cumulative energy columns are not what its traction forces,
    speeds and positions give (``kinematics.interval_power``, ``kinematics.cumulative_work``), beyond
    twice the rounding of the digits written: a column edited after the solve."""
    x, v, ft = p["position_m"], p["speed_kmh"] * KMH, p["traction_force_kN"][:-1] * KN
    hx, hv, hf = _half_digit(x), _half_digit(p["speed_kmh"]) * KMH, _half_digit(ft)
    power, said = interval_power(ft, v) / KW, p["power_kW"][:-1]
    rounding = (_half_digit(said) + (hf * 0.5 * (v[:-1] + v[1:]) + np.abs(ft) * 0.5 * (hv[:-1] + hv[1:])) / KW)
    _refuse_off(said, power, rounding, where, "power_kW", "kW", "the traction force times the interval's mean speed")
    work, said = cumulative_work(ft, x) / KWH, p["cumulative_energy_kWh"]
    rounding = _half_digit(said) + cumulative_work(hf, x) / KWH + np.concatenate(
        [[0.0], np.cumsum(np.abs(ft) * (hx[:-1] + hx[1:]))]) / KWH
    _refuse_off(said, work, rounding, where, "cumulative_energy_kWh", "kWh", "the traction work summed from the start")


def _refuse_off(said: np.ndarray, given: np.ndarray, rounding: np.ndarray, where: Path, column: str, unit: str,
                what: str) -> None:
    off = np.flatnonzero(~(np.abs(said - given) <= 2.0 * rounding + 1e-9 * np.max(np.abs(given), initial=1.0)))
    if off.size:
        k = off[0]
        raise InputError(problem(where, f"{column}, row {k + 2}", f"{said[k]:g} {unit}, but the row's forces, speeds "
                                 f"and positions give {given[k]:.6g} ({what}): an edited profile? solve again"))


def _check_totals(p: dict[str, np.ndarray], summary: dict[str, Any], where: Path) -> None:
    """Refuse a summary whose running time, traction energy, top speed or distance is not what its
    profile gives (to the profile's six digits): one of them was edited."""
    for field, value in (("running_time_s", p["time_s"][-1]), ("traction_energy_kWh", p["cumulative_energy_kWh"][-1]),
                         ("top_speed_kmh", np.max(p["speed_kmh"])),
                         ("distance_m", p["position_m"][-1] - p["position_m"][0])):
        said = summary.get(field)
        if not (isinstance(said, (int, float)) and abs(said - value) <= 2.0 * _half_digit(np.array([value]))[0] + 1e-9):
            raise InputError(problem(where, field, f"{said!r}, but the profile gives {value:.6g}: an edited file? "
                                     "solve again"))


def _check_verification(summary: dict[str, Any], where: Path) -> None:
    """Refuse a verification block that contradicts itself: tolerances other than ecostudy's,
    ``passed`` other than what its own errors and timing windows say, an arrival error other than
    the simulated arrival less the running time. Whether its numbers are the re-simulation's own,
    ``ecostudy check`` and ``export`` see (``analysis.saved.rejudged``)."""
    block = summary.get("verification")
    if block is None:
        return
    try:
        block = current(block)
        tolerances = dict(TOLERANCES, **({"adhesion_use_max": ADHESION_USE} if "adhesion_use_max" in block else {}))
        if block["tolerances"] != tolerances:
            raise InputError(problem(where, "verification.tolerances", f"{block['tolerances']!r}, not the "
                                     f"re-simulation's {tolerances!r}: an edited file? solve again"))
        passed = within_tolerances(block) and all(w["kept"] for w in block["windows"])
        arrival = float(block["simulated_running_time_s"]) - float(summary["running_time_s"])
        off = abs(float(block["arrival_time_error_s"]) - arrival) > 1e-6 * max(abs(arrival), 1.0)
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise InputError(problem(where, "verification", f"not the block a solve writes ({exc!r}): an edited file? "
                                 "solve again"))
    if block["passed"] is not passed:
        raise InputError(problem(where, "verification.passed", f"{block['passed']!r}, but its errors and timing "
                                 f"windows say {passed!r}: an edited file? solve again"))
    if off:
        raise InputError(problem(where, "verification.arrival_time_error_s", f"{block['arrival_time_error_s']!r}, "
                                 f"but it arrives {arrival:.6g} s after the running time: an edited file? solve again"))


def check_status(status: Status, summary: dict[str, Any], where: Path, calibration_reason: str | None = None) -> None:
    """Refuse a summary whose ``status`` (already read: ``status``) is not the one the parts it is made
    of give (:func:`~ecostudy.io.runsummary.status_parts`: ``solver.status``, ``verification``,
    ``all_out_solver_status``, ``das.status`` and the train's calibration), or whose ``cases`` and
    ``not_ok`` do not count it: the status alone was edited. ``calibration_reason``: the train's
    (None: not known here, so a flagged status with every other part ok is taken for a
    calibration's, :data:`~ecostudy.core.status.CALIBRATED`; ``analysis.saved.rejudged`` knows it)."""
    das = summary.get("das")
    try:
        parts = status_parts(summary, das, calibration_reason or "")
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise InputError(problem(where, "solver, verification, das", f"not the blocks a solve writes ({exc!r}): an "
                                 "edited file? solve again"))
    made = [(field, part) for field, part in parts.items() if not part.ok]
    if status.ok and made:
        field, part = made[0]
        raise InputError(problem(where, "status", f"ok, but its part {field} makes it {part}: an edited file? solve again"))
    calibration = (calibration_reason is None and status.kind == "flagged" and status.reason.startswith(CALIBRATED))
    if not status.ok and not made and not calibration:
        raise InputError(problem(where, "status", f"{status}, but every part of the run is ok ({', '.join(parts)}): "
                                 "an edited file? solve again"))
    if made and status.kind != "flagged":
        raise InputError(problem(where, "status", f"{status}, but its parts say flagged ({made[0][0]}): an edited "
                                 "file? solve again"))
    cases, not_ok = summary.get("cases"), summary.get("not_ok")
    counted = isinstance(cases, dict) and cases.get("total") == 1 and all(
        cases.get(kind) == int(kind == status.kind) for kind in ("ok", "flagged", "failed"))
    listed = isinstance(not_ok, list) and [str(c.get("status")) if isinstance(c, dict) else c
                                           for c in not_ok] == ([] if status.ok else [str(status)])
    if not counted or not listed:
        raise InputError(problem(where, "cases" if not counted else "not_ok", f"{cases if not counted else not_ok!r}, "
                                 f"but the run's status is {status}: an edited file? solve again"))


def on_grid(trajectory: Trajectory, nodes: np.ndarray, inputs: dict[str, Any], where: str | PathLike[str]) -> None:
    """Refuse a profile whose positions are not the grid ``inputs.json`` names."""
    x = trajectory.nodes
    if len(x) != len(nodes) or not np.allclose(x, nodes, atol=1e-3):
        raise InputError(problem(where, "position_m", f"{len(x)} positions that differ from the grid of "
                                 f"inputs.json ({len(nodes)} nodes from '{inputs['from']}' to '{inputs['to']}'): "
                                 "an edited profile"))


NOISE = 1e-3  # [km/h, kN] below -NOISE a saved speed or force is an edit, not the solver's rounding
PROFILE_COLUMNS = ("position_m", "time_s", "speed_kmh", "traction_force_kN", "braking_force_kN", "handle")
DERIVED_COLUMNS = ("power_kW", "cumulative_energy_kWh")  # checked against the forces, speeds and positions
# [kWh/s] above 0, a marginal energy is no solver's noise (3.5e-7 measured on a run whose timing window
# binds on the way, where the arrival's multiplier is near 0; the shipped runs' are -0.08 to -1.6)
MARGINAL_NOISE = 1e-4
COSTATE_OBJECTIVES = ("energy", "net_energy")  # whose profile has costate_ratio (the Pontryagin check's psi)
# summary.json's field while a run's files are being written (``report.files.write_run`` writes it
# first, as the folder's status, and replaces the whole summary last): a folder that has it is no result
WRITING = "writing"
