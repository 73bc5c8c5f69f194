"""A logged run's force at the wheel against its wheel power: where the train pulls, P = F v.

Both columns are read in the units their names give (``force_kN``, ``power_wheel_kW``); a channel
written in another unit than its name says (a force in daN under ``force_kN``: a hundred times too
large) is not caught by either column alone. Calibration fits the wheel power; validation and the
replay read the force where there is no power: the two must be the same traction.
"""
import warnings
from typing import Any

import numpy as np

from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.units import FloatArray
from ecostudy.io.documents import Where

# median of P / (F v) over the rows where the train pulls: outside, one channel is in another unit.
# 43 generated logs (calibration.generate: the point-mass trains on the calibration, metro, regional,
# thesis and 40/60 per mille test lines, 10 and 1 Hz, 1 % noise) lie within 0.992-1.037 (the powers
# interval means, the force sampled: at 1 Hz they part while the speed rises); a unit slip is a factor
# 3.6 or more off (daN under force_kN: 0.01; W under power_wheel_kW: 1000; km/h under speed_mps: 0.28)
FORCE_POWER = (0.8, 1.25)
# within the units, a channel off in scale: outside this band (around 0.992-1.037 with margin) the fit
# takes the wheel power, and the mass and resistance absorb the difference (10 % high: the mass 10 % high)
FORCE_POWER_AGREE = (0.95, 1.06)
# median of the wheel power over the line power where the train pulls (the traction chain's efficiency,
# auxiliaries drawn from the line lowering it): above 1 the wheel gets more than the line gives; a unit
# slip is a factor 1000 off (W or MW under power_line_kW, kV under line_voltage_V)
LINE_WHEEL = (0.3, 1.05)
PULLING_SPEED = 3.0   # [m/s] rows above this only: near standstill F v is small and its noise is not
PULLING_ROWS = 10     # fewer rows where the train pulls than this: too few to judge, not checked
# [SI] the largest magnitude a logged train's channel can plausibly read: a heavy-haul train's several
# locomotives exert about 3-4 MN and draw about 20 MW, a 25 kV line's train some 1000 A; a value past
# these is a unit slip or a logger's overflow (1e308 read as an infinite energy and a NaN difference)
PLAUSIBLE = {"force": 1e7, "power_wheel": 1e8, "power_line": 1e8, "voltage": 1e5, "current": 1e5}


def check_plausible(path: Where, names: list[str], data: FloatArray, units: dict[str, tuple[str, float]]) -> None:
    """Refuse, in one line naming ``path``, the column and the first row, a force, power, voltage or
    current beyond :data:`PLAUSIBLE`, read in the column's own unit before any conversion (``data``:
    the rows, a column per name; ``units``: column name -> (quantity, SI per the column's unit))."""
    for j, name in enumerate(names):
        quantity, factor = units[name]
        if quantity in PLAUSIBLE:
            top = PLAUSIBLE[quantity] / factor
            over = np.nonzero(np.abs(data[:, j]) > top)[0]
            if over.size:
                i, unit = int(over[0]), name.rsplit("_", 1)[1]
                raise InputError(problem(path, name, f"row {i + 1}: {data[i, j]:g} {unit} is not plausible for "
                                         f"a train (up to {top:g} {unit}; {over.size} such "
                                         f"row{'s' if over.size > 1 else ''})"))


def pulling(v: FloatArray, power: FloatArray) -> "np.ndarray[Any, np.dtype[np.bool_]]":
    """The rows where ``power`` is positive and the speed above :data:`PULLING_SPEED`: the train pulls."""
    return (power > 0) & (np.abs(v) > PULLING_SPEED)


def pulling_ratio(v: FloatArray, top: FloatArray, bottom: FloatArray) -> tuple[float, int]:
    """(median of ``top`` / ``bottom``, rows) over the rows where both are positive and the speed is
    above :data:`PULLING_SPEED`, the train pulling (NaN and 0 rows when there are none): the one
    comparison of two of a log's traction channels."""
    rows = pulling(v, top) & (bottom > 0)
    if not rows.any():
        return float("nan"), 0
    return float(np.median(top[rows] / bottom[rows])), int(rows.sum())


def force_power_ratio(v: FloatArray, force: FloatArray, power: FloatArray) -> tuple[float, int]:
    """(median of P / (F |v|), rows) where the train pulls (:func:`pulling_ratio`)."""
    return pulling_ratio(v, power, force * np.abs(v))


def check_force_power(path: Where, columns: tuple[str, ...], v: FloatArray | None, force: FloatArray | None,
                      power: FloatArray | None) -> None:
    """Refuse, in one line naming ``path``, the force and wheel power columns and the median ratio
    (``columns``: the speed's, the force's, the wheel power's names), a log whose wheel power is not
    its force times its speed where the train pulls (median of P / (F v) outside :data:`FORCE_POWER`).
    Not checked without all three, or with fewer than :data:`PULLING_ROWS` such rows."""
    if v is None or force is None or power is None:
        return
    ratio, rows = force_power_ratio(v, force, power)
    lo, hi = FORCE_POWER
    if rows >= PULLING_ROWS and not lo <= ratio <= hi:
        speed, force_name, power_name = columns[:3]
        raise InputError(problem(path, f"{force_name}, {power_name}",
                                 f"the wheel power is {ratio:.3g} times the force times the speed (median over "
                                 f"{rows} rows where the train pulls above {PULLING_SPEED:g} m/s; it must be "
                                 f"{lo:g}-{hi:g}): one of them (or {speed}) is in another unit than its name says"))


def force_power_agreement(log: Any) -> tuple[float, int] | None:
    """(median of P / (F v), rows) where the train pulls (:func:`force_power_ratio`), where a log gives a
    speed, a force and a wheel power and pulls in :data:`PULLING_ROWS` rows or more; else None (not
    compared; ``log``: a :class:`~ecostudy.io.logfile.LoggedRun`)."""
    if log.v is None or log.force is None or log.power_wheel is None:
        return None
    ratio, rows = force_power_ratio(log.v, log.force, log.power_wheel)
    return (ratio, rows) if rows >= PULLING_ROWS else None


def force_power_problem(log: Any) -> str:
    """Why a log's wheel power and force times speed disagree beyond what sampling leaves (their
    median ratio where the train pulls outside :data:`FORCE_POWER_AGREE`, within the units
    :func:`check_force_power` allows), "" where they agree or cannot be compared
    (:func:`force_power_agreement`)."""
    agreement = force_power_agreement(log)
    lo, hi = FORCE_POWER_AGREE
    if agreement is None or lo <= agreement[0] <= hi:
        return ""
    ratio, rows = agreement
    speed, force_name, power_name = log.columns[1:4]
    return (f"{power_name} is {ratio:.4g} times {force_name} times {speed} (median over {rows} rows where the train "
            f"pulls above {PULLING_SPEED:g} m/s; sampling leaves {lo:g}-{hi:g}): one channel is off in scale, and the "
            "fit, which takes the wheel power, puts the difference into the mass and resistance")


def check_line_power(path: Where, line_name: str, v: FloatArray | None, force: FloatArray | None,
                     wheel: FloatArray | None, line: FloatArray | None) -> FloatArray | None:
    """The line power to use (``line``, or NaN where it is left out). Refused, in one line naming
    ``path``, the line power's column(s) (``line_name``) and the median ratio, a log whose wheel power
    (else force times speed) is not :data:`LINE_WHEEL` of its line power where the train pulls: more
    at the wheel than the line gives cannot be, and less than 0.3 is no traction chain (a power in W
    under a kW name, a voltage in kV under a V name). Where the wheel pulls in :data:`PULLING_ROWS`
    rows or more but the line power is positive in fewer of them (a sign flipped, a dead channel
    reading zero), the ratio cannot be judged and the line power would be a wrong number: it is left
    out (NaN: no efficiency fitted from it, no logged line energy), warned in one line. Not checked
    without a line power and a wheel power or force, or on fewer than :data:`PULLING_ROWS` such rows."""
    if line is None or v is None or (wheel is None and force is None):
        return line
    power = wheel if wheel is not None else force * np.abs(v)
    traction = int(pulling(v, power).sum())
    ratio, rows = pulling_ratio(v, power, line)
    if traction >= PULLING_ROWS and rows < PULLING_ROWS:
        warnings.warn(problem(path, line_name, f"positive in {rows} of the {traction} rows where the wheel power is positive "
                              f"above {PULLING_SPEED:g} m/s (the train pulls; {PULLING_ROWS} needed): a sign flipped "
                              "(drawn is positive) or a dead channel: left out (no efficiency fitted from it, no "
                              "logged line energy)"), EcostudyWarning, stacklevel=2)
        return np.full_like(line, np.nan)
    lo, hi = LINE_WHEEL
    if rows >= PULLING_ROWS and not lo <= ratio <= hi:
        raise InputError(problem(path, line_name, f"the wheel power is {ratio:.3g} times the line power (median over "
                                 f"{rows} rows where the train pulls above {PULLING_SPEED:g} m/s; a traction "
                                 f"chain gives {lo:g}-{hi:g}): the line power, voltage or current is in another "
                                 "unit or scale than its name says"))
    return line


def warn_unused_electric(path: Where, column: dict[str, tuple[str, FloatArray]]) -> None:
    """Warn of a line voltage or current the line power is not made of: one without the other, or
    both beside a line power column (which is used)."""
    given = [column[q][0] for q in ("voltage", "current") if q in column]
    why = (f"left out: the line power column {column['power_line'][0]} is used" if "power_line" in column else
           f"left out: the line power needs both a line voltage and a line current "
           f"(no {'line_current_A' if 'voltage' in column else 'line_voltage_V or line_voltage_kV'} column), "
           "so this log has no line power")
    warnings.warn(problem(path, ", ".join(given), why), EcostudyWarning, stacklevel=3)
