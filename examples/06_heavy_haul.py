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
# horizon control of heavy haul trains", eq. 4): K_b weights the wagons' braking effort against the
# locomotives'.
# `api.heavyhaul_folder` (the `heavyhaul` command) sweeps K_b: the study file is written from
# Python, the function runs it into its output folder and returns the folder read back (an
# `api.Report`).
# Two values of K_b on the shipped 45 km representative line keep the example short.

# %%
# %matplotlib inline
import tempfile
from pathlib import Path

import yaml
from IPython.display import Image

from ecostudy import api

OUT = Path(tempfile.mkdtemp(prefix="ecostudy-gallery-"))
study = {
    "name": "gallery_heavy_haul",
    "consist": str(api.shipped("trains/heavyhaul_zhang_zhuan.yaml")),
    "track": str(api.shipped("tracks/heavyhaul_representative_45km.yaml")),
    "reference": {"supplement_percent": 10},
    "sample_time_s": 20,
    "brake_penalty": [1, 80],
    "fence": [10],
    "horizons": [{"np": 4, "nc": 2}],
    "adhesion": True,  # the locomotives' traction and dynamic braking capped at mu(v) m g in the plant
}
(OUT / "heavyhaul.yaml").write_text(yaml.safe_dump(study))
result = api.heavyhaul_folder(OUT / "heavyhaul.yaml", out=OUT / "hh")
print(result.status, result.cases)
print("\n".join(result.problems()))  # each run not ok, with its reason

# %% [markdown]
# One row per K_b: status, the largest in-train force over the run and while braking, the energies
# and where the train stopped. Both runs stop at the stop (a few centimetres either side of the
# mark) and are `ok`; a run that stopped off the mark would be `flagged` with the distance. Without
# `adhesion: true` the plant would not limit the locomotives and both runs would be `flagged`: a
# locomotive asks about 1.5 times its adhesion 100 s into the run. The larger K_b moves braking from
# the wagons' brakes to the locomotives' dynamic brake, and the largest in-train force while braking
# falls to about a quarter; the largest force over the run is reached outside braking and changes
# little.

# %%
result.tables["runs"][["K_b", "status", "reason", "force_max_kN", "force_max_braking_kN", "traction_kWh",
                       "wagon_brake_kWh", "dynamic_brake_kWh", "stop_error_m"]]

# %% [markdown]
# The speed of each run against the reference, each K_b in its own colour:

# %%
Image(filename=result.folder / "tracking.png")

# %% [markdown]
# The trade-off against K_b: each curve in a colour of its own.

# %%
Image(filename=result.folder / "brake_penalty.png")
