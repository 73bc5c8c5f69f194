# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---
# %% [markdown]
# # Heavy haul: braking-penalised receding-horizon control
#
# A long heavy-haul train as coupled masses, driven by a receding-horizon controller whose
# objective penalises braking with a weight K_b (Zhang & Zhuan, "Braking penalized receding
# horizon control of heavy haul trains"). A larger K_b trades wagon braking for in-train forces.
# The `heavyhaul` command sweeps K_b; it has no function of its own in `ecostudy.api` yet, so the
# study file is written from Python, the command runs it and `api.load` reads the folder back.
# Two values of K_b on the shipped 45 km representative line keep the example short.

# %%
# %matplotlib inline
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml
from IPython.display import Image

from ecostudy import api

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents, Path(api.__file__).parents[1]) if (p / "tracks").is_dir())
OUT = Path(tempfile.mkdtemp(prefix="ecostudy-gallery-"))
study = {
    "name": "gallery_heavy_haul",
    "consist": str(ROOT / "trains" / "heavyhaul_paper002.yaml"),
    "track": str(ROOT / "tracks" / "heavyhaul_representative_45km.yaml"),
    "reference": {"supplement_percent": 10},
    "sample_time_s": 20,
    "brake_penalty": [1, 80],
    "fence": [10],
    "horizons": [{"np": 4, "nc": 2}],
}
(OUT / "heavyhaul.yaml").write_text(yaml.safe_dump(study))
done = subprocess.run([sys.executable, "-m", "ecostudy", "heavyhaul", OUT / "heavyhaul.yaml", "--out", OUT / "hh"],
                      capture_output=True, text=True)
assert done.returncode in (0, 1), done.stderr  # 1: a run flagged or failed, listed in the folder
result = api.load(OUT / "hh")
print(result.status, result.cases)

# %% [markdown]
# One row per K_b: status (a run that stops short of the mark is flagged, with the distance), the
# largest in-train force over the run and while braking, and the energies.

# %%
result.tables["runs"][["K_b", "status", "reason", "force_max_kN", "force_max_braking_kN", "traction_kWh",
                       "wagon_brake_kWh", "dynamic_brake_kWh", "stop_error_m"]]

# %% [markdown]
# The speed of each run against the reference, each K_b in its own colour:

# %%
Image(filename=OUT / "hh" / "tracking.png")

# %% [markdown]
# The trade-off against K_b: each curve in a colour of its own.

# %%
Image(filename=OUT / "hh" / "brake_penalty.png")
