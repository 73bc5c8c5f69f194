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
# # Driver advice (DAS) against automatic train operation (ATO)
#
# A driver cannot follow a continuous optimal handle; a driver advisory system (DAS) gives a few
# phases instead. The `compare` command drives one run every way and scores each with the same
# independent simulator: all-out, the ATO optimum, eco-drive coasting, a MARECO-style run, and
# two kinds of DAS advice (Farooqi 2018 §3.1 and Ch. 5). In Python it is `api.compare_folder`,
# with the command's options as arguments: it writes the same output folder and returns it read
# back (an `api.Report`: status, case counts, tables as DataFrames, and the text the command prints).

# %%
# %matplotlib inline
import tempfile
from pathlib import Path

import numpy as np
from IPython.display import Image
from matplotlib.figure import Figure

from ecostudy import api

OUT = Path(tempfile.mkdtemp(prefix="ecostudy-gallery-"))

# %%
result = api.compare_folder(track=api.shipped("tracks/regional_808m.yaml"), train=api.shipped("trains/regional_alstom.yaml"),
                            time=80, points=200, out=OUT / "compare")
print(result.kind, "|", result.status, "|", result.cases)
print("\n".join(result.problems()))
result.table

# %% [markdown]
# A case that is not `ok` carries its reason, and `result.problems()` lists them one a line
# (the command line would exit with 1 so a script notices; the function returns the status).
#
# The energies side by side, from the table (kWh of traction at the wheel and net of
# regeneration):

# %%
table = result.table
fig = Figure(figsize=(8, 3.5))
ax = fig.subplots()
y = np.arange(len(table))
ax.barh(y - 0.2, table["traction_energy_kWh"], height=0.4, label="traction at the wheel")
ax.barh(y + 0.2, table["net_energy_kWh"], height=0.4, label="net of regeneration")
ax.set_yticks(y, table["strategy"])
ax.invert_yaxis()
ax.set_xlabel("energy [kWh]")
ax.legend()
fig.tight_layout()
fig

# %% [markdown]
# The figure the function wrote into the folder: every strategy's speed in its own colour.

# %%
Image(filename=result.folder / "compare.png")
