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
# # Trains on one DC substation
#
# Two metro trains 60 s apart over three stops share one substation. A braking train's
# regeneration can feed the other one if it draws power at the time; otherwise the line's
# receptivity cuts it off. The `network` command drives the trains independently, with the
# receptivity rule of Farooqi 2018 (Ch. 7), and keeping a separation (`following`), solving the
# DC circuit at every step. In Python it is `api.network_folder`: the study file is written from
# Python, the function runs it into its output folder and returns the folder read back (an
# `api.Report`).

# %%
# %matplotlib inline
import tempfile
from pathlib import Path

import yaml
from IPython.display import Image

from ecostudy import api

OUT = Path(tempfile.mkdtemp(prefix="ecostudy-gallery-"))
study = {
    "name": "gallery_network",
    "track": str(api.shipped("tracks/metro_line_4stops.yaml")),
    "train": str(api.shipped("trains/amsterdam_metro.yaml")),
    "stops": ["Noord", "Station", "Centrum"],
    "supplement_percent": 10,
    "dwell_s": 20,
    "time_step_s": 1.0,
    "points": 200,
    "trains": [{"name": "T1", "offset_s": 0}, {"name": "T2", "offset_s": 60}],
    "substation": {"position_m": 1000, "voltage_V": 750, "internal_resistance_ohm": 0.01,
                   "line_resistance_ohm_per_km": 0.025},
    "strategies": ["independent", "receptivity", "following"],
    "buffer_m": 300,
}
(OUT / "network.yaml").write_text(yaml.safe_dump(study))
result = api.network_folder(OUT / "network.yaml", out=OUT / "network")
print(result.status, result.cases)
print("\n".join(result.problems()))  # each strategy not ok, with its reason

# %% [markdown]
# Per strategy: the energy the substation delivers, the saving against independent driving, and
# where the regeneration went (used by the other train, or lost because the line could not take it).

# %%
result.tables["substation"][["strategy", "status", "substation_kWh", "saving_vs_independent_pct", "regen_used_kWh",
                             "regen_lost_kWh", "line_losses_kWh"]]

# %% [markdown]
# The trains' speeds and the substation's power over time, and the line voltage and current;
# every train and strategy in a colour of its own.

# %%
Image(filename=result.folder / "network.png")

# %%
Image(filename=result.folder / "network_supply.png")
