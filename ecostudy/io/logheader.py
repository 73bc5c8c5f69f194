"""A logged run's column names and its YAML header: the units each column name gives
(:data:`COLUMNS`), the header's fields (:class:`LogHeader`), how the header is split from the CSV
and which of its fields are read, left out with a warning or refused (:func:`known_header`).
The logged run itself: :mod:`ecostudy.io.logfile`."""
import difflib
import re
import warnings
from typing import Any, Literal, Mapping, Optional

from pydantic import Field

from ecostudy.core import units
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.io.documents import NEAR_MISS, Where
from ecostudy.io.schemabase import Strict
from ecostudy.io.yamlsafe import DocumentError, load_yaml

# column name -> (quantity, [SI] per [unit])
COLUMNS = {
    "time_s": ("time", 1.0),
    "position_m": ("position", 1.0), "position_km": ("position", 1000.0),
    "speed_mps": ("speed", 1.0), "speed_kmh": ("speed", units.KMH),
    "force_N": ("force", 1.0), "force_kN": ("force", units.KN),
    "power_wheel_W": ("power_wheel", 1.0), "power_wheel_kW": ("power_wheel", units.KW),
    "power_line_W": ("power_line", 1.0), "power_line_kW": ("power_line", units.KW),
    "line_voltage_V": ("voltage", 1.0), "line_voltage_kV": ("voltage", 1000.0),
    "line_current_A": ("current", 1.0),
}
QUANTITIES = {name.rsplit("_", 1)[0] for name in COLUMNS}  # time, position, speed, ... (a known one in another unit: refused)


class LogHeader(Strict):
    """The YAML header of a logged run."""

    track: Optional[str] = Field(None, description="Track file the run was logged on, relative to the log.")
    train: Optional[str] = Field(None, description="Train file of the vehicle, relative to the log.")
    source: str = Field("", description="Where the log comes from.")
    start_position_m: Optional[float] = Field(None, description="Track position at the first row; needed "
                                              "when there is no position column.")
    power_sampling: Literal["interval_mean", "instant"] = Field(
        "interval_mean", description="Powers as means over the interval to the next row, or instantaneous.")
    speed_sigma_mps: Optional[float] = Field(None, gt=0, le=10, description="Speed sensor noise, if known [m/s].")
    power_sigma_percent: Optional[float] = Field(None, gt=0, le=100, description="Power noise, if known [%].")


def split_header(text: str, path: Where) -> tuple[dict[str, Any], str]:
    """(header mapping, CSV text) of a log: the header between two '---' lines at the top."""
    lines = text.splitlines(keepends=True)
    if not lines or lines[0].strip() != "---":
        raise InputError(problem(path, "header", "expected a YAML header between two '---' lines before the CSV"))
    try:
        end = next(i for i in range(1, len(lines)) if lines[i].strip() == "---")
    except StopIteration:
        raise InputError(problem(path, "header", "the YAML header has no closing '---' line"))
    try:
        header = load_yaml("".join(lines[1:end]))
    except DocumentError as exc:
        raise InputError(problem(path, "header", str(exc)))
    except Exception as exc:  # a YAML parse error: one line with its reason
        raise InputError(problem(path, "header", f"malformed YAML: {getattr(exc, 'problem', exc)}"))
    if not isinstance(header, dict):
        raise InputError(problem(path, "header", "expected a mapping of fields"))
    return header, "".join(lines[end + 1:])


# words of a header field's name that say how the columns read (speed_unit, units, time_offset_s, force_sign,
# power_scale): left out, the columns would be read otherwise than the file means
DECLARES = {"unit", "units", "scale", "scaling", "factor", "multiplier", "offset", "datum", "sign", "convention",
            "inverted"}


def declares_columns(name: str, value: Any) -> bool:
    """A header field that says how the columns read: a word of :data:`DECLARES` in its name, or a
    mapping whose keys name a column or a quantity (``channels: {speed: km/h}``)."""
    words = set(re.split(r"[^a-z0-9]+", name.lower()))
    keys = {str(k) for k in value} if isinstance(value, dict) else set()
    return bool(words & DECLARES or keys & (set(COLUMNS) | QUANTITIES))


def known_header(fields: Mapping[Any, Any], path: Where) -> dict[str, Any]:
    """The header's fields that :class:`LogHeader` knows. Any other is left out with one warning
    naming it and the file, unless it is a near miss (:data:`NEAR_MISS`) of a known field the header
    does not give: that one is refused naming the field(s) it may be, as every known field changes
    what is computed (a misspelt ``power_sampling: instant`` left out would integrate the powers as
    interval means). A field that says how the columns read (:func:`declares_columns`: a unit, a
    scale, an offset, a sign) is refused too: the units are in the column names and traction is
    positive, and left out it would leave the columns read otherwise than the file means. A field
    without a name (empty, or YAML's null) is refused."""
    known = list(LogHeader.model_fields)
    lines, ignored = [], []
    for key, value in fields.items():
        if key is None or not str(key).strip():  # '': x, null: x: nothing to name in a warning
            lines.append(problem(f"{path}: header", "", f"a field without a name (value {value!r}): name it or "
                                 "remove it"))
    for name, value in ((str(key), value) for key, value in fields.items()
                        if key is not None and str(key).strip() and str(key) not in known):
        near = [k for k in difflib.get_close_matches(name, known, n=3, cutoff=NEAR_MISS) if k not in fields]
        if near:
            lines.append(problem(f"{path}: header", name, f"unknown field; did you mean {' or '.join(near)}?"))
        elif declares_columns(name, value):
            lines.append(problem(f"{path}: header", name, "says how the columns read (a unit, scale, offset or "
                                 "sign), which ecostudy does not apply: the unit is part of each column's name "
                                 "(speed_kmh, position_km, force_kN) and traction is positive; convert or rename "
                                 "the columns and remove this field"))
        else:
            ignored.append(name)
    if lines:
        raise InputError(lines)
    if ignored:
        warnings.warn(problem(path, "header", f"{', '.join(ignored)} not modelled by ecostudy: left out"),
                      EcostudyWarning, stacklevel=2)
    return {str(key): value for key, value in fields.items() if str(key) in known}
