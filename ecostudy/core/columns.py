"""How every number a command writes is named: the one rule for the columns of its CSV tables and
the keys of its JSON files (docs/formats.md, "Column names"; ``tests/test_column_names.py`` runs
every command and checks each number it writes against :func:`offence`).

A number with a unit is named ``<quantity>[_<statistic>]_<unit>``: the unit is always the last
part (``force_max_kN``, ``solve_mean_ms``, ``stop_error_m``), a statistic over runs or samples
stands just before it (``stop_error_max_m``; a statistic of a statistic: ``solve_mean_max_ms``,
the largest of the runs' means), and a unit per another is written with ``per``
(``energy_J_per_kg``). A JSON key inside a block whose name ends in a unit (``stages_s``,
``tolerances_pct``) takes that unit, and one whose name ends in ``shares`` holds shares. A number without a unit says so by its name: its last part
(before a statistic) is a word of :data:`DIMENSIONLESS` (``handle_changes``, ``adhesion_use_max``,
``legs_restarted_count``), or it is one of :data:`NAMES` (the symbols of the papers, ``K_b``)."""
import re

# The last part of a name with a unit: what it means.
UNITS = {
    "s": "second", "ms": "millisecond", "m": "metre", "km": "kilometre", "mps": "metre per second",
    "mps2": "metre per second squared", "kmh": "kilometre per hour", "N": "newton", "kN": "kilonewton",
    "W": "watt", "kW": "kilowatt", "J": "joule", "MJ": "megajoule", "kWh": "kilowatt hour (an energy users read)",
    "V": "volt", "A": "ampere", "ohm": "ohm", "kg": "kilogram", "t": "tonne", "pct": "per cent",
    "MB": "megabyte (memory)",
}

# Statistics, written just before the unit (or last, for a number without a unit).
STATISTICS = ("min", "max", "mean", "std", "p95", "sum", "worst")  # worst: the largest in magnitude

# Last words of a number without a unit: counts, shares and ratios, levels.
DIMENSIONLESS = {
    "count": "a count", "samples": "a count of samples", "iterations": "solver iterations",
    "points": "grid points", "changes": "a count of changes", "runs": "a count of runs", "ok": "a count of runs",
    "arrived": "a count of runs", "missing": "a count of runs not computed yet",
    "share": "a share, 0 to 1", "shares": "shares, 0 to 1", "ratio": "a ratio", "use": "a share of a limit",
    "factor": "a multiple of the model's value", "handle": "a handle level, -1 to 1", "damage": "Miner's damage sum",
    "draw": "a draw's number", "sample": "a sample's number", "run": "a run's number", "coupler": "a coupler's number",
    "gap": "a relative duality gap", "residual": "a relative residual", "violation": "a constraint violation",
    "tolerance": "a relative tolerance", "layout": "a file layout's version", "workers": "a count of processes",
    "cars": "a count of cars", "inputs": "a count of QP variables", "states": "a count of QP variables",
    "constraints": "a count of QP constraints", "total": "a count of cases", "flagged": "a count of cases",
    "failed": "a count of cases", "now": "a count of cases", "before": "a count of cases",
    "estimate": "an estimate as a multiple of the model's value", "weight": "an objective weight",
}

# Names from the papers' notation, kept as the papers write them.
NAMES = {"K_b", "f", "Np", "Nc", "J_force", "J_tracking", "J_energy", "J_braking"}

_UNIT = "(?:" + "|".join(sorted(map(re.escape, UNITS), key=len, reverse=True)) + ")"
_WITH_UNIT = re.compile(rf"^(?P<quantity>.+?)(?:_(?P<stat>{'|'.join(STATISTICS)}))*"
                        rf"_(?P<unit>{_UNIT}(?:_{_UNIT})*(?:_per_{_UNIT}(?:_{_UNIT})*)?)$")


def unit_of(name: str) -> str | None:
    """The unit a name ends in (``kWh_per_s`` for ``marginal_saving_kWh_per_s``), None for none."""
    match = _WITH_UNIT.match(name)
    return match["unit"] if match else None


def with_statistic(name: str, statistic: str) -> str:
    """The name of ``statistic`` of the quantity ``name``: before its unit, else last
    (``with_statistic('stop_error_m', 'max')`` is ``stop_error_max_m``)."""
    unit = unit_of(name)
    return f"{name[:-len(unit) - 1]}_{statistic}_{unit}" if unit else f"{name}_{statistic}"


def offence(name: str, block: str | None = None) -> str | None:
    """What is wrong with the name of a number, None when it follows the rule. ``block``: the name
    of the JSON block the key is in (its unit, if it ends in one, is the key's)."""
    if name in NAMES or (block is not None and (unit_of(block) is not None or block.endswith("shares"))):
        return None
    parts = name.split("_")
    if parts[0] in STATISTICS and len(parts) > 1:
        return f"a statistic first ('{parts[0]}'): write it before the unit, '<quantity>_{parts[0]}_<unit>'"
    match = _WITH_UNIT.match(name)
    if match:
        if set(match["quantity"].split("_")) <= set(STATISTICS):
            return "no quantity before the unit"
        return None
    while len(parts) > 1 and parts[-1] in STATISTICS:
        parts = parts[:-1]
    if unit_of("_".join(parts)):
        return "a statistic after the unit: write it before the unit, '<quantity>_<statistic>_<unit>'"
    if parts[-1] in DIMENSIONLESS:
        return None
    return "no unit: end it in a unit of ecostudy.core.columns.UNITS or a word of DIMENSIONLESS"


def table_offences(columns: list[str], numeric: list[str]) -> dict[str, str]:
    """{column: offence} of a table's ``numeric`` columns; none for a table with a ``unit`` column
    (each row names its own unit, as calibrate's parameters do)."""
    if "unit" in columns:
        return {}
    return {c: why for c in numeric if (why := offence(c)) is not None}


def json_offences(data: object, path: str = "", block: str | None = None) -> dict[str, str]:
    """{dotted key: offence} of every number in a JSON document; a block with a ``unit`` key names
    the unit of its own numbers."""
    out: dict[str, str] = {}
    if isinstance(data, list):
        for item in data:
            out.update(json_offences(item, path + "[]", block))
    elif isinstance(data, dict):
        given = "unit" in data
        for key, value in data.items():
            where = f"{path}.{key}" if path else str(key)
            if isinstance(value, (dict, list)):
                inherited = block if block is not None and offence("", block) is None else str(key)
                out.update(json_offences(value, where, inherited))
            elif isinstance(value, (int, float)) and not isinstance(value, bool) and not given:
                why = offence(str(key), block)
                if why is not None:
                    out[where] = why
    return out
