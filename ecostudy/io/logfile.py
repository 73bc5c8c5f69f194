"""Logged runs: a CSV with a small YAML header, read into SI arrays and checked like every input.

The file::

    ---
    track: ../tracks/line.yaml        # the files it ran on, relative to the log
    train: ../trains/train.yaml
    source: event recorder of unit 4711, 2026-05-12
    ---
    time_s,position_m,speed_mps,force_kN,power_wheel_kW,power_line_kW
    0.0,1200.0,0.0,0.0,0.0,0.0
    ...

Units are in the column names (:data:`COLUMNS`). Time is required, and position and/or speed;
any of the force at the wheel (traction positive, braking negative), the power at the wheel, the
power at the pantograph (or the line voltage and current) may follow. Positions are track
positions (the track file's kilometrage), in either direction of travel. Powers are the means
over the interval from their row to the next (energy counters differenced) unless the header
says ``power_sampling: instant``; speed, position and force are instantaneous.

A column of a quantity ecostudy does not model, and a header field it does not know, are left out
with a warning naming them; a header field that is a near miss of a known one not given
(:func:`~ecostudy.io.logheader.known_header`) is refused.
Every problem is one line ``file: field: what is wrong`` (exit status 2): a missing header,
unknown units of a known quantity, values that are not finite numbers, time not increasing, gaps, speeds
that do not fit the positions (a unit mix-up), positions that jump (GPS), a wheel power that is not the force times
the speed (:mod:`ecostudy.io.logforce`); once the track is known, positions off
the track (:func:`check_on_track`) and a force or wheel power not positive where the train pulls (a sign flipped,
a dead channel; :func:`check_traction_sign`, beyond what the track's gradient gives).
"""
import csv
import difflib
import io
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from ecostudy.core import units
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.grid import Profile
from ecostudy.core.physics import gradient_force
from ecostudy.core.types import Track
from ecostudy.core.units import FloatArray
from ecostudy.io.documents import Where, named_file, not_a_file, validate
from ecostudy.io.logforce import check_force_power, check_line_power, check_plausible, warn_unused_electric
from ecostudy.io.logheader import COLUMNS, QUANTITIES, LogHeader, known_header, split_header
from ecostudy.io.writers import atomic_write
from ecostudy.io.yamlsafe import MAX_FILE_BYTES

MIN_ROWS = 10
# difflib's similarity (in lower case) at or above which an unknown column is taken for a known one
# misnamed: Speed_MPS 1.0, speed_mp 0.94 are; power_aux_kW 0.72 (against power_line_kW), brake_pipe_bar,
# latitude_deg are not (left out with a warning)
COLUMN_NEAR_MISS = 0.9
START_AGREES_M = 10.0  # [m] start_position_m given beside a position column: at most this from its first row
INTEGRATED = "(start_position_m)"  # the position column's name where there is none: the speeds integrated
GAP_FACTOR = 5.0       # a time step this many times the median step is a gap
MISSING_FACTOR = 1.5   # a time step this many times the median step (up to a gap) is a missing row: warned
DAY = 86400.0          # [s] a clock in seconds from midnight restarts by this
MIN_SPEED = -1.0       # [m/s] below this a negative speed is not sensor noise
MAX_SPEED = 150.0      # [m/s] (540 km/h)
SPEED_DISTANCE = (0.8, 1.25)  # speeds integrated over the positions' travel, outside: a unit mix-up
TRAVEL_STEP = 10.0     # [s] the positions' travel is summed over steps of this length
JUMP = 10.0            # [m] a position step this much (plus half the speeds' distance) off the speeds' is a jump
JUMP_SHARE = 0.1       # jumps in more than this share of the steps: not jumps but a unit mix-up
PULLING = 0.3          # [m/s^2] speed gained faster than this over PULLING_TIME beyond what the gradient gives:
PULLING_TIME = 2.0     # [s]  in traction; the work at the wheel must be positive there
DIGITS = 9             # a column's last written digit is looked for down to 10^-DIGITS of its unit


@dataclass
class LoggedRun:
    """A logged run in SI: arrays per row (None where the log has no such column)."""

    name: str
    header: LogHeader
    t: np.ndarray                       # [s]
    x: np.ndarray                       # track position [m] (integrated from the speed without a column)
    v: np.ndarray | None = None         # [m/s]
    force: np.ndarray | None = None     # at the wheel, traction > 0, braking < 0 [N]
    power_wheel: np.ndarray | None = None  # [W]
    power_line: np.ndarray | None = None   # drawn from the line > 0, fed back < 0 [W]; NaN: left out (check_line_power)
    path: Path | None = None
    columns: tuple[str, ...] = field(default=())  # (position, speed, force, wheel power column) as the file names them
    resolution: dict[str, float] = field(default_factory=dict)  # quantity -> its column's last digit [SI] (last_digit)
    line_column: str = ""  # the line power's column(s) as the file names them

    def named(self, field: str) -> Path:
        """The header's ``track`` or ``train`` file, relative to the log's folder; one not given or not
        there is refused naming the log and the header field."""
        if getattr(self.header, field) is None:
            raise InputError(problem(self.path or self.name, f"header.{field}", f"missing: name the {field} file "
                                     f"the run was logged with, or give --{field}"))
        return named_file(self.path or Path("log"), f"header.{field}", getattr(self.header, field))


def read_table(text: str, path: Where) -> tuple[list[str], FloatArray]:
    """(column names, float rows array) of the CSV part; one line for the first bad cell of each column."""
    rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
    if not rows:
        raise InputError(problem(path, "columns", "no CSV header row after the YAML header"))
    names = [c.strip() for c in rows[0]]
    unknown = [name for name in names if name not in COLUMNS]
    lines = [problem(path, name, f"unknown column (known: {', '.join(COLUMNS)}; the unit is part of the name)")
             for name in unknown if quantity_of(name) in QUANTITIES]
    lines += [problem(path, name, f"unknown column; did you mean {' or '.join(near)}? (names are lower case, the unit "
                      "part of the name)") for name in unknown if quantity_of(name) not in QUANTITIES
              and (near := near_columns(name))]
    ignored = [name for name in unknown if quantity_of(name) not in QUANTITIES]
    if ignored and not lines:
        warnings.warn(problem(path, "columns", f"{', '.join(ignored)} not modelled by ecostudy: left out"),
                      EcostudyWarning, stacklevel=2)
    quantities = [COLUMNS[n][0] for n in names if n in COLUMNS]
    lines += [problem(path, "columns", f"two columns give the {q}") for q in sorted(set(quantities))
              if quantities.count(q) > 1]
    if lines:
        raise InputError(lines)
    data = np.full((len(rows) - 1, len(names)), np.nan)
    bad: dict[str, tuple[int, str]] = {}
    for i, row in enumerate(rows[1:]):
        if len(row) != len(names):
            raise InputError(problem(path, f"row {i + 1}", f"{len(row)} values for {len(names)} columns"))
        for j, cell in enumerate(row):
            if names[j] in ignored:  # left out: not read
                data[i, j] = 0.0
                continue
            try:
                data[i, j] = float(cell)
            except ValueError:
                bad.setdefault(names[j], (i + 1, f"'{cell.strip()}' is not a number"))
        for k in np.nonzero(~np.isfinite(data[i]))[0]:
            bad.setdefault(names[k], (i + 1, f"'{row[k].strip()}' is not a finite number"))
    if bad:
        raise InputError([problem(path, name, f"row {row}: {msg}") for name, (row, msg) in bad.items()])
    kept = [j for j, name in enumerate(names) if name not in ignored]
    return [names[j] for j in kept], data[:, kept]


def near_columns(name: str) -> list[str]:
    """The known columns an unknown column ``name`` is taken for, compared in lower case: a near
    miss (:data:`COLUMN_NEAR_MISS`; ``Speed_MPS``, ``speed_mp``), refused rather than left out (left
    out, a speed column misnamed would leave the speeds taken from the positions)."""
    lower = {c.lower(): c for c in COLUMNS}
    return [lower[c] for c in difflib.get_close_matches(name.lower(), list(lower), n=3, cutoff=COLUMN_NEAR_MISS)]


def quantity_of(name: str) -> str:
    """The quantity a column name gives: its name without the unit (``speed_mph`` -> ``speed``; ``speed`` itself)."""
    return name if name in QUANTITIES else name.rsplit("_", 1)[0]


def last_digit(values: FloatArray) -> float:
    """The step of the last digit a column writes, in its own unit: 10^-d for the fewest decimals d
    that write every value (to a thousandth of that digit: a float's own spacing allowed), else
    10^-:data:`DIGITS`."""
    for d in range(DIGITS + 1):
        scaled = values * 10.0 ** d
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-3):
            return float(10.0 ** -d)
    return float(10.0 ** -DIGITS)


def check_series(log: "LoggedRun", path: Where) -> None:
    """Refuse time that does not increase, gaps, implausible speeds and speeds that do not fit the
    positions (a unit mix-up): one line each."""
    t = log.t
    lines: list[str] = []
    if len(t) < MIN_ROWS:
        raise InputError(problem(path, "time_s", f"{len(t)} rows; a log needs at least {MIN_ROWS}"))
    dt = np.diff(t)
    step = float(np.median(dt))
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0)) + 1
        midnight = 0 < t[i] - t[i - 1] + DAY <= GAP_FACTOR * step  # a clock in seconds from midnight passing it
        raise InputError(problem(path, "time_s", f"row {i + 1}: time {t[i]:g} s does not increase "
                                 f"(previous {t[i - 1]:g} s)" + ("; a clock that passes midnight: add 86400 s "
                                                                 "to the rows after it" if midnight else "")))
    if np.any(dt > GAP_FACTOR * step):
        i = int(np.argmax(dt > GAP_FACTOR * step))
        raise InputError(problem(path, "time_s", f"row {i + 2}: gap of {dt[i]:g} s after {t[i]:g} s (the log "
                                 f"samples every {step:g} s); split the log there"))
    long = np.nonzero((dt > MISSING_FACTOR * step) & (dt <= GAP_FACTOR * step))[0]
    if long.size:
        many = long.size > 1
        warnings.warn(problem(path, "time_s", f"{long.size} step{'s' if many else ''} longer than the log's {step:g} s "
                              f"({'the first ' if many else ''}at row {long[0] + 2}: {dt[long[0]]:g} s): missing "
                              f"row{'s' if many else ''}, read across (a power the mean over its row's whole step)"),
                      EcostudyWarning, stacklevel=2)
    if log.v is not None:
        if log.v.min() < MIN_SPEED or log.v.max() > MAX_SPEED:
            i = int(np.argmax((log.v < MIN_SPEED) | (log.v > MAX_SPEED)))
            lines.append(problem(path, log.columns[1], f"row {i + 1}: speed {log.v[i]:g} m/s is not plausible "
                                 f"({MIN_SPEED:g} to {MAX_SPEED:g} m/s)"))
        elif "position" in log.columns[0]:
            check_jumps(log, path)
            travel, driven = travel_and_driven(log)
            low, high = SPEED_DISTANCE
            if max(travel, driven) > 50.0 and not low * travel <= driven <= high * travel:  # km as m: travel ~ 0
                lines.append(problem(path, log.columns[1], f"the speeds integrate to {driven:.0f} m but the "
                                     f"positions advance {travel:.0f} m: check the units"))
    if lines:
        raise InputError(lines)


def travel_steps(log: "LoggedRun", moving: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """(the positions' travel, the distance the speeds give) [m] of each step of :data:`TRAVEL_STEP`
    seconds (GPS noise does not add up; while the train moves one way it only counts at the ends of
    a stretch), only the steps whose every speed is above ``moving`` [m/s] (a sensor's noise at a
    stand integrates to travel the positions never make)."""
    assert log.v is not None
    k = max(int(round(TRAVEL_STEP / float(np.median(np.diff(log.t))))), 1)
    cuts = np.unique(np.append(np.arange(0, len(log.t), k), len(log.t) - 1))
    keep = np.full(len(cuts) - 1, True)
    if moving > 0:  # each step's samples, its end included
        keep = (np.minimum.reduceat(np.abs(log.v), cuts)[:-1] > moving) & (np.abs(log.v[cuts[1:]]) > moving)
    travel = np.abs(np.diff(log.x[cuts]))
    driven = np.add.reduceat(np.append(speed_steps(log), 0.0), cuts)[:-1]
    return travel[keep], driven[keep]


def travel_and_driven(log: "LoggedRun", moving: float = 0.0) -> tuple[float, float]:
    """The sums of :func:`travel_steps`: (the positions' travel, the distance the speeds give) [m]."""
    travel, driven = travel_steps(log, moving)
    return float(np.sum(travel)), float(np.sum(driven))


def speed_steps(log: "LoggedRun") -> FloatArray:
    """The distance [m] the speeds give over each time step (trapezoidal, either direction)."""
    assert log.v is not None
    steps: FloatArray = 0.5 * (np.abs(log.v[1:]) + np.abs(log.v[:-1])) * np.diff(log.t)
    return steps


def check_jumps(log: "LoggedRun", path: Where) -> None:
    """Refuse positions that jump: a step more than :data:`JUMP` m (or six robust spreads of the
    positions' own noise) plus half the distance the speeds give away from it, in a few rows (a GPS jump or re-fix); in many rows it is a unit mix-up, which
    the travel check names."""
    assert log.v is not None
    by_speed = speed_steps(log)
    off = np.abs(np.abs(np.diff(log.x)) - by_speed)
    noise = 6.0 * 1.4826 * float(np.median(off))  # positions' own noise (GPS): six robust spreads
    jumps = np.nonzero(off > max(JUMP, noise) + 0.5 * by_speed)[0]
    if 0 < jumps.size <= JUMP_SHARE * off.size:
        i = int(jumps[0])
        raise InputError(problem(path, log.columns[0], f"row {i + 2}: the position jumps by {units.signed(log.x[i + 1] - log.x[i], 0)} m "
                                 f"in {log.t[i + 1] - log.t[i]:g} s, the speeds give {by_speed[i]:.1f} m "
                                 f"({jumps.size} such step{'s' if jumps.size > 1 else ''}; a GPS jump, or a distance that "
                                 "restarts: positions are track positions, the track file's)"))


def check_traction_sign(log: "LoggedRun", track: Track) -> None:
    """Refuse a force or wheel power that is not positive in most rows where the train gains speed
    faster than :data:`PULLING` beyond what the gradient gives (traction is positive, braking
    negative: a sign flipped at the logger, or a dead channel reading zero). The gradient's share,
    g times the height lost per metre run along the logged positions over the same
    :data:`PULLING_TIME`, counted as if all the mass weighed: on a steep descent a coasting or
    lightly braked train gains up to that (0.39 m/s^2 at 40 per mille, 0.59 at 60) without traction."""
    if log.v is None:
        return
    t, speed = log.t, np.abs(log.v)
    k = max(int(round(PULLING_TIME / float(np.median(np.diff(t))))), 1)
    height = Profile(track.gradient_positions, track.gradients).integral(log.x)
    grade = (height[k:] - height[:-k]) / np.maximum(np.abs(log.x[k:] - log.x[:-k]), 1e-9)  # along the travel
    gained = (speed[k:] - speed[:-k]) / (t[k:] - t[:-k]) + gradient_force(1.0, grade)
    rows = np.nonzero(gained > PULLING)[0] + k // 2
    for name, values in zip(log.columns[2:], (log.force, log.power_wheel)):
        if values is not None and rows.size >= 5:
            negative = int(np.sum(values[rows] <= 0))
            if negative > rows.size / 2:
                raise InputError(problem(log.path or log.name, name, f"not positive in {negative} of {rows.size} "
                                         f"rows where the train gains more than {PULLING:g} m/s^2 beyond what the "
                                         "gradient gives: traction is positive, braking negative"))


def parse_log(text: str, path: Where, name: str | None = None) -> "LoggedRun":
    """A :class:`LoggedRun` from a log's text (``path`` names it in messages)."""
    fields, table = split_header(text, path)
    header = validate(LogHeader, known_header(fields, path), f"{path}: header")
    names, data = read_table(table, path)
    with np.errstate(over="ignore"):  # a cell past a float in SI: refused below, after the checks that name a unit
        column = {COLUMNS[n][0]: (n, data[:, j] * COLUMNS[n][1]) for j, n in enumerate(names)}
    if "time" not in column:
        raise InputError(problem(path, "columns", "no time column (time_s)"))
    if "position" not in column and "speed" not in column:
        raise InputError(problem(path, "columns", "needs a position column (position_m) or a speed column "
                                 "(speed_mps, speed_kmh)"))
    t = column["time"][1]
    v = column["speed"][1] if "speed" in column else None
    if "position" in column:
        x = column["position"][1]
        if header.start_position_m is not None and x.size and not abs(header.start_position_m - x[0]) <= START_AGREES_M:
            raise InputError(problem(path, "header.start_position_m", f"{header.start_position_m:g} m, but "
                                     f"{column['position'][0]} starts at {x[0]:g} m: give one (the column) or make them agree"))
    elif header.start_position_m is None or v is None:
        raise InputError(problem(path, "header", "start_position_m is needed when there is no position column"))
    else:
        x = header.start_position_m + np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    line = column["power_line"][1] if "power_line" in column else None
    if line is None and "voltage" in column and "current" in column:
        line = column["voltage"][1] * column["current"][1]
    elif "voltage" in column or "current" in column:
        warn_unused_electric(path, column)

    def get(q: str) -> FloatArray | None:
        return column[q][1] if q in column else None

    log = LoggedRun(name or Path(path).stem, header, t, x, v, get("force"), get("power_wheel"), line, Path(path),
                    (column.get("position", (INTEGRATED,))[0], *(column.get(q, ("",))[0]
                                                                  for q in ("speed", "force", "power_wheel"))),
                    {COLUMNS[n][0]: last_digit(data[:, j]) * COLUMNS[n][1] for j, n in enumerate(names)})
    check_series(log, path)
    check_force_power(path, log.columns[1:], v, log.force, log.power_wheel)
    log.line_column = (column["power_line"][0] if "power_line" in column else
                       f"{column['voltage'][0]} x {column['current'][0]}" if line is not None else "")
    log.power_line = check_line_power(path, log.line_column or "line_voltage, line_current", v, log.force,
                                      log.power_wheel, line)
    check_plausible(path, names, data, COLUMNS)
    return log


def load_log(path: Where) -> "LoggedRun":
    """Read a logged run (:func:`parse_log`); a missing, too large or non-UTF-8 file is one line."""
    file = Path(path)
    if not file.is_file():
        raise InputError(problem(file, "", not_a_file(file)))
    if file.stat().st_size > MAX_FILE_BYTES:
        raise InputError(problem(file, "", f"larger than the {MAX_FILE_BYTES / 1e6:.0f} MB ecostudy reads"))
    try:
        text = file.read_bytes().decode("utf-8-sig")  # a byte order mark (a spreadsheet's "CSV UTF-8") is dropped
    except UnicodeDecodeError as exc:
        raise InputError(problem(file, "", f"not UTF-8 text (byte {exc.start}: {exc.reason})"))
    return parse_log(text, file)


def check_on_track(log: "LoggedRun", track: Track) -> None:
    """Every logged position must lie on the track [0, length]: one line naming the first that does not."""
    off = (log.x < -1e-6) | (log.x > track.length + 1e-6)
    if np.any(off):
        i = int(np.argmax(off))
        integrated = log.columns[0] == INTEGRATED
        raise InputError(problem(log.path or log.name, log.columns[1] if integrated else log.columns[0],
                                 f"row {i + 1}: position {log.x[i]:.1f} m is off track '{track.name}' (0 to "
                                 f"{track.length:g} m)" + ("; the positions are the speeds integrated from "
                                                           "start_position_m: check their unit and the start"
                                                           if integrated else "")))


def write_log(path: str | Path, header: Mapping[str, Any], frame: Any) -> None:
    """Write a logged run: ``header`` (a mapping, the fields of :class:`LogHeader`) and ``frame``
    (a table whose columns are names of :data:`COLUMNS`, in those units)."""
    unknown = [c for c in frame.columns if c not in COLUMNS]
    if unknown:
        raise ValueError(f"unknown log columns {unknown}")

    def write(tmp: str) -> None:
        with open(tmp, "w") as fh:
            fh.write("---\n" + yaml.safe_dump(dict(header), sort_keys=False) + "---\n")
            frame.to_csv(fh, index=False, float_format="%.6f")
    atomic_write(path, write)
