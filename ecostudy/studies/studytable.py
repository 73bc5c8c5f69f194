"""A run study's table and its cases' statuses: one row per case (labels, status, reason, key
results), the names a folder's summary gives its cases."""
import pandas as pd

from ecostudy.core.status import cells, parsed


def case_statuses(cases, table):
    """Every case's :class:`~ecostudy.core.status.Status`, by :func:`case_names`, from a study table's columns."""
    return parsed(case_names(cases), table["status"], table["reason"] if "reason" in table else [None] * len(table))


def case_names(cases):
    """Each case's name in a folder's summary: its ``name``, else its labels, else its key."""
    return [c.get("name") or ", ".join(f"{k}={v}" for k, v in c["labels"].items()) or c["key"] for c in cases]


NOT_COMPUTED = "not computed yet: left out of this run (--only); run the command without it to compute it"
RESULT_COLUMNS = {"running_time_s", "points", "status", "key", "reason", "wall_s", "verified"}  # never labels
OUTPUT_NAMES = {"supplement_percent": "supplement_pct"}  # a swept field as the tables name it (core.columns)


def study_table(cases, rows):
    """One row per case of the study, in study order: labels, status, reason and key results
    (``rows``: the stored results by case key)."""
    out = []
    for case in cases:
        row = rows.get(case["key"])
        s = (row or {}).get("summary") or {}
        ver = s.get("verification") or {}
        labels = {f"swept_{k}" if k in RESULT_COLUMNS else OUTPUT_NAMES.get(k, k): v for k, v in case["labels"].items()}
        status, reason = cells((row or {}).get("status"), (row or {}).get("error"))
        out.append({**labels, "key": case["key"], "status": status, "reason": reason,
                    "running_time_s": s.get("running_time_s"), "all_out_time_s": s.get("all_out_time_s"),
                    "traction_energy_kWh": s.get("traction_energy_kWh"), "net_energy_kWh": s.get("net_energy_kWh"),
                    "regenerated_energy_kWh": s.get("regenerated_energy_kWh"), "top_speed_kmh": s.get("top_speed_kmh"),
                    "regime_sequence": (s.get("regimes") or {}).get("sequence"), "points": s.get("points"),
                    "solver_status": (s.get("solver") or {}).get("status"), "verified": ver.get("passed"),
                    "stop_error_m": ver.get("stop_error_m"), "wall_s": (row or {}).get("seconds")})
        if any(c.get("das") for c in cases):
            out[-1].update(s.get("das") or {})
    table = pd.DataFrame(out)
    table.attrs.update(study_inputs(cases))
    return table


def study_inputs(cases):
    """What a run study was asked (``summary.json``, report.html's Inputs beside the study file):
    its track, train, stops and K, each its cases' one value, or their values in study order,
    joined (a library's tracks and trains, a sweep of K)."""
    def one(values):
        distinct = list(dict.fromkeys(values))
        return distinct[0] if len(distinct) == 1 else ", ".join(map(str, distinct))
    return {"track": one(c["track"].get("name", "track") for c in cases),
            "train": one(c["train"].get("name", "train") for c in cases),
            "from": one(c["from"] for c in cases), "to": one(c["to"] for c in cases),
            "points": one(c["points"] for c in cases)} if cases else {}
