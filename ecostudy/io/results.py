"""Reading back the output folder of `ecostudy solve`: its inputs, its summary and its profile as
an SI :class:`~ecostudy.core.types.Trajectory` (the display units converted here)."""
import hashlib
import json
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from ecostudy.core.errors import InputError, problem
from ecostudy.core.types import Trajectory
from ecostudy.core.units import KMH, KN


def file_digest(path):
    """SHA-256 of a file's bytes (of ``file#selector``: of the file), to tell whether it changed."""
    text = str(path)
    path = Path(text.rsplit("#", 1)[0] if "#" in text and not Path(text).is_file() else text)
    return hashlib.sha256(path.read_bytes()).hexdigest()


def check_unchanged(inputs, result_dir):
    """Refuse a saved run whose track or train file changed since it was solved (``inputs.json``
    keeps their digests): checking it against the edited file would check another problem."""
    for name in ("track", "train"):
        digest = inputs.get(f"{name}_sha256")
        if digest is None:
            raise InputError(problem(Path(result_dir) / "inputs.json", f"{name}_sha256", "missing: solved by an older "
                                     "ecostudy, whose inputs cannot be told unchanged; solve again"))
        try:
            now = file_digest(inputs[name])
        except OSError:
            raise InputError(problem(inputs[name], "", f"the {name} file of this result is gone"))
        if now != digest:
            raise InputError(problem(inputs[name], "", f"the {name} file changed since this result was solved; "
                                     "solve again"))


class SavedRun(NamedTuple):
    inputs: dict          # inputs.json: track and train paths, stops, grid size
    summary: dict         # summary.json
    trajectory: Trajectory


def load_result(result_dir):
    """The :class:`SavedRun` of a result folder; a folder that is not one is one clear line."""
    result_dir = Path(result_dir)
    try:
        inputs = json.loads((result_dir / "inputs.json").read_text())
        summary = json.loads((result_dir / "summary.json").read_text())
        profile = pd.read_csv(result_dir / "profile.csv")
        trajectory = Trajectory(profile["position_m"].to_numpy(), profile["speed_kmh"].to_numpy() * KMH,
                                np.diff(profile["time_s"].to_numpy()),
                                profile["traction_force_kN"].to_numpy()[:-1] * KN,
                                profile["braking_force_kN"].to_numpy()[:-1] * KN)
    except (OSError, ValueError, KeyError) as exc:
        raise InputError(problem(result_dir, "", f"not a result folder of `ecostudy solve` ({exc})"))
    return SavedRun(inputs, summary, trajectory)
