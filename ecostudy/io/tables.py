"""CSV tables of numbers read back (a saved profile, a reference speed table): every cell that is
not a finite number, a missing column or a file cut short is one line naming the file, the column
and the row, never an internal error further on."""
from os import PathLike
from pathlib import Path
from typing import Any, Collection, Sequence

import numpy as np
import pandas as pd

from ecostudy.core.errors import InputError, problem
from ecostudy.core.units import FloatArray


def number_columns(path: str | PathLike[str], columns: Sequence[str], min_rows: int = 2, rows: int | None = None,
                   open_last: Collection[str] = ()) -> dict[str, FloatArray]:
    """{column: float array} of the named columns of a CSV file.

    Refused by name, in one line: a file that cannot be read, a missing column, the first cell
    (by row, as a spreadsheet numbers it: the header is row 1) that is text, empty, NaN or
    infinite, fewer than ``min_rows`` rows, or not exactly ``rows`` rows when given (a file cut
    short). Columns in ``open_last`` may leave their last cell empty (an interval's value sits on
    its first node): it is read as NaN."""
    path = Path(path)
    try:
        table = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise InputError(problem(path, "", f"not a readable CSV table ({str(exc).splitlines()[0]})"))
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise InputError(problem(path, ", ".join(missing), f"missing column (the file has {', '.join(table.columns)})"))
    out: dict[str, FloatArray] = {}
    first: tuple[int, str, Any] | None = None
    for column in columns:
        cells = table[column]
        values = pd.to_numeric(cells, errors="coerce").to_numpy(float)
        bad = ~np.isfinite(values)
        if column in open_last and len(cells) and cells.iloc[-1] == "":
            bad[-1] = False
        if bad.any():
            row = int(np.argmax(bad))
            if first is None or row < first[0]:
                first = (row, column, cells.iloc[row])
        out[column] = values
    if first is not None:
        row, column, cell = first
        raise InputError(problem(path, f"{column}, row {row + 2}", f"'{cell}' is not a finite number"))
    if len(table) < min_rows:
        raise InputError(problem(path, "", f"{len(table)} rows: need at least {min_rows}"))
    if rows is not None and len(table) != rows:
        raise InputError(problem(path, "", f"{len(table)} rows where the run has {rows} (a file cut short or edited?)"))
    return out
