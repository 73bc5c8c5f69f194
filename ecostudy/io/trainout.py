"""A train file with calibrated parameters: the original document with the fitted fields replaced
(SI units written in the file's field names) and its ``source`` extended by the fit's provenance."""
import copy
from pathlib import Path
from os import PathLike
from typing import Any, Collection

import yaml

from ecostudy.core import units
from ecostudy.core.types import Train
from ecostudy.io.loaders import train_document
from ecostudy.io.writers import atomic_write


def calibrated_document(path: str | PathLike[str], train: Train, fitted: Collection[str],
                        provenance: str, warning: str = "") -> dict[str, Any]:
    """The train file at ``path`` (YAML, or TTOBench / OSRD JSON as ecostudy reads it) with the
    parameters named in ``fitted`` taken from ``train`` (SI), ``provenance`` added to its source and
    ``warning`` (a calibration not ok) put before it, where a reader of the file starts."""
    data: dict[str, Any] = copy.deepcopy(train_document(path)[0])
    if {"mass", "rotating_mass_factor"} & set(fitted):
        data["mass_t"] = round(train.static_mass / units.TONNE, 6)
        if data.get("effective_mass_t") is not None:
            data["effective_mass_t"] = round(train.mass / units.TONNE, 6)
        else:
            data["rotating_mass_factor"] = round(train.mass / train.static_mass - 1.0, 6)
    if {"davis_a", "davis_b", "davis_c"} & set(fitted):
        a, b, c = (float(x) for x in train.davis)
        data["davis"] = {"a_N": round(a, 4), "b_N_per_mps": round(b, 6), "c_N_per_mps2": round(c, 6)}
    if "efficiency" in fitted:
        data["traction_efficiency"] = round(float(train.traction_efficiency), 6)
    if "regeneration_efficiency" in fitted and data.get("regenerative_braking"):
        data["regenerative_braking"]["efficiency"] = round(float(train.regeneration_efficiency), 6)
    data["source"] = f"{warning} {data.get('source', '').strip()} {provenance}".strip()
    return data


def write_train(path: str | Path, data: dict[str, Any]) -> None:
    """Write a train document as YAML."""
    def write(tmp: str) -> None:
        with open(tmp, "w") as fh:
            yaml.safe_dump(data, fh, sort_keys=False, allow_unicode=True)
    atomic_write(path, write)
