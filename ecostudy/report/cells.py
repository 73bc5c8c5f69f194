"""Numbers as report.html shows them: a table column's precision (:func:`decimals`), a cell
(:func:`numeric_cell`) and a single value (:func:`fmt_scalar`)."""
import math
from numbers import Number
from typing import Any, Optional

import pandas as pd

from ecostudy.core.units import number


def is_missing(v: Any) -> bool:
    if v is None:
        return True
    try:
        return bool(pd.isna(v))
    except (TypeError, ValueError):
        return False


def decimals(col: pd.Series) -> int:
    """Decimal places for a numeric column: four significant digits of its typical value (the
    median size of its values, leaving out zeros and solver noise below a millionth of its
    largest), 0 to 6; none for a column of whole numbers."""
    size = col.dropna().astype(float).abs()
    size = size[size.map(math.isfinite)]
    if size.empty or (size == size.round()).all():
        return 0
    size = size[size > 1e-6 * size.max()]
    return int(min(6, max(0, 3 - math.floor(math.log10(size.median()))))) if not size.empty else 0


def numeric_cell(value: Any, places: int, largest: Optional[float] = None) -> str:
    """A number to its column's ``places``; in a table (``largest``: the column's largest size) more
    where the value itself needs them for four significant digits (a column of parameters in
    different units: a mass and an efficiency), as many as it has (0.5, not 0.5000), except solver
    noise: below a millionth, and below a millionth of ``largest``."""
    if is_missing(value):
        return "<td></td>"
    x = float(value)
    if largest is not None and math.isfinite(x) and (abs(x) > 1e-6 * largest or abs(x) >= 1e-6) and x != round(x):
        own = min(6, 3 - math.floor(math.log10(abs(x))))
        if "e" not in repr(x):
            own = min(own, len(repr(x).partition(".")[2]))
        places = max(places, own)
    text = number(x, f",.{places}f").replace(",", "\u2009")  # thin space between thousands; no '-0.00'
    return f'<td class="n" data-v="{x!r}">{text}</td>'


def fmt_scalar(v: Any) -> str:
    """One value as a reader wants it: four significant digits, no exponent between 1e-3 and 1e9; a
    record as its fields given (``running_time_s 78``: those not given left out, ``none`` when no
    field is), a list as its items (``none`` when empty), not as Python writes them."""
    if isinstance(v, dict):
        return ", ".join(f"{k} {fmt_scalar(x)}" for k, x in v.items() if not is_missing(x)) or "none"
    if isinstance(v, (list, tuple)):
        return "; ".join(fmt_scalar(x) for x in v) or "none"
    if is_missing(v):
        return "\u2014"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, Number) and not isinstance(v, bool):
        x = float(v)  # type: ignore[arg-type]
        if x == round(x) and abs(x) < 1e15:
            return f"{int(round(x)):,}".replace(",", "\u2009")
        if abs(x) < 1e-3 or abs(x) >= 1e9:
            return f"{x:.3e}"
        places = min(6, max(0, 3 - math.floor(math.log10(abs(x)))))
        text = f"{x:,.{places}f}"
        if len(repr(x)) < len(text) and "e" not in repr(x):
            text = f"{x:,}"  # a short exact value as given (a tolerance of 0.5, not 0.5000)
        return text.replace(",", "\u2009")
    return str(v)
