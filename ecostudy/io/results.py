"""Reading back the output folder of `ecostudy solve`: its inputs, its summary and its profile as
an SI :class:`~ecostudy.core.types.Trajectory` (the display units converted here)."""
import json
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from ecostudy.core.errors import InputError, problem
from ecostudy.core.types import Trajectory
from ecostudy.core.units import KMH, KN


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
