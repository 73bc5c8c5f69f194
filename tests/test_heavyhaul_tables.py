"""The shipped flat-piece references of the sags and rolling lines (docs/heavyhaul.md, "A line whose
descents pass the dynamic brakes") are what bench/heavyhaul_sags_reference.py writes, and keep its rates;
every runs.csv column is documented."""
from pathlib import Path

import numpy as np
import pytest

from bench.heavyhaul_sags_reference import DROP, RISE, TABLES, sags_reference

from .conftest import STUDIES


@pytest.mark.parametrize("name", sorted(TABLES))
def test_the_shipped_table_is_the_scripts(name):
    table = np.loadtxt(STUDIES / name, delimiter=",", skiprows=1)
    x, v = sags_reference(TABLES[name])
    assert np.array_equal(table[:, 0], x)
    assert np.max(np.abs(table[:, 1] - v * 3.6)) <= 0.005 + 1e-9  # written to 0.01 km/h


def test_pieces_are_reached_at_the_rates_and_drops_by_their_start():
    pieces = [(0.0, 50.0), (3000.0, 70.0), (8000.0, 40.0)]
    x, v = sags_reference(pieces, length=11000.0)
    assert v[0] == 0.0 and v[-1] == 0.0
    accel = np.diff(v ** 2) / (2 * np.diff(x))  # constant acceleration in time: v^2 linear in distance
    assert accel.max() <= RISE + 1e-9 and accel.min() >= -DROP - 1e-9
    assert v[x == 7950.0][0] == pytest.approx(40 / 3.6)  # the drop done a step before its piece
    assert v[x == 7900.0][0] > 40 / 3.6  # and not earlier
    assert v[(x >= 2000) & (x < 3000)].max() == pytest.approx(50 / 3.6)  # a piece's speed, never above it
    assert v.max() == pytest.approx(70 / 3.6)


def test_every_runs_csv_column_is_documented():
    """Every column a heavy-haul study writes to runs.csv is named in docs/heavyhaul.md's column table."""
    from ecostudy.studies.heavyhaul import COLUMNS
    text = (Path(__file__).resolve().parent.parent / "docs" / "heavyhaul.md").read_text()
    table = text[text.index("**runs.csv, column by column**"):text.index("## Bad input")]
    assert [c for c in (*COLUMNS, "K_b", "f", "Np", "Nc", "status", "reason", "wall_s") if f"`{c}`" not in table] == []
