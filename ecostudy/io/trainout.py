"""A train file with calibrated parameters: the original document with the fitted fields replaced
(SI units written in the file's field names) and its ``source`` extended by the fit's provenance."""
import copy
from pathlib import Path
from os import PathLike
from typing import Any, Collection

import warnings

import yaml

from ecostudy.core import units
from ecostudy.core.errors import EcostudyWarning
from ecostudy.core.types import Train
from ecostudy.io.loaders import train_document
from ecostudy.io.writers import atomic_write


def calibrated_document(path: str | PathLike[str], train: Train, fitted: Collection[str],
                        provenance: str, warning: str = "", reason: str = "") -> dict[str, Any]:
    """The train file at ``path`` (YAML, or TTOBench / OSRD JSON as ecostudy reads it) with the
    parameters named in ``fitted`` taken from ``train`` (SI), ``provenance`` added to its source and
    ``warning`` (a calibration not ok) put before it, where a reader of the file starts; its
    ``calibration`` block (the schema's, read by the loader) the calibration's status: ``ok``, or
    ``flagged`` with ``reason`` when one is given (every run of the train is then flagged with it).

    A fitted efficiency is a constant (the calibration compares it with the logged line power at
    every traction or braking sample, whatever the train file's efficiency map says): the map,
    which the net energy would use instead of the constant, is left out of the file, with a warning
    naming it."""
    data: dict[str, Any] = copy.deepcopy(train_document(path)[0])
    if {"mass", "rotating_mass_factor"} & set(fitted):
        data["mass_t"] = round(train.static_mass / units.TONNE, 6)
        if data.get("effective_mass_t") is not None:
            data["effective_mass_t"] = round(train.mass / units.TONNE, 6)
        else:
            data["rotating_mass_factor"] = round(train.rotating_mass_factor, 6)
    if {"davis_a", "davis_b", "davis_c"} & set(fitted):
        a, b, c = (float(x) for x in train.davis)
        data["davis"] = {"a_N": round(a, 4), "b_N_per_mps": round(b, 6), "c_N_per_mps2": round(c, 6)}
    if "efficiency" in fitted:
        data["traction_efficiency"] = round(float(train.traction_efficiency), 6)
        _drop_map(data, "traction_efficiency_map", "traction_efficiency", path)
    if "regeneration_efficiency" in fitted and data.get("regenerative_braking"):
        data["regenerative_braking"]["efficiency"] = round(float(train.regeneration_efficiency), 6)
        _drop_map(data["regenerative_braking"], "efficiency_map", "regenerative_braking.efficiency", path,
                  "regenerative_braking.")
    data["source"] = f"{warning} {data.get('source', '').strip()} {provenance}".strip()
    data["calibration"] = {"status": "flagged", "reason": reason} if reason else {"status": "ok"}  # the file's own
    return data


def _drop_map(block: dict[str, Any], key: str, constant: str, path: str | PathLike[str], prefix: str = "") -> None:
    """Remove the efficiency map ``key`` from ``block``, warning by name: the fitted constant replaces it."""
    if block.pop(key, None) is not None:
        warnings.warn(f"{Path(path).name}: {prefix}{key}: left out of the calibrated train: the fit measured the "
                      f"constant {constant} (the map was not used by the fit), which the net energy would ignore "
                      "beside a map", EcostudyWarning, stacklevel=3)


def write_train(path: str | Path, data: dict[str, Any]) -> None:
    """Write a train document as YAML."""
    def write(tmp: str) -> None:
        with open(tmp, "w") as fh:
            yaml.safe_dump(data, fh, sort_keys=False, allow_unicode=True)
    atomic_write(path, write)
