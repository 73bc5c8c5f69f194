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
# # One run: solve, read, plot
#
# The energy-optimal run of an Amsterdam metro train from Rokin to Centraal in 76 s (Farooqi 2018,
# "Design of collaborative eco-drive control algorithms for train networks", §4.4), solved with the
# Python API on a small grid, then the same run for a train built in code 20 % heavier.
#
# The examples read the tracks and trains shipped in the repository (`api.shipped`): found from
# the working directory, a folder above it or the checkout the package is installed from.

# %%
# %matplotlib inline
import yaml

from ecostudy import api

track = api.load_track(api.shipped("tracks/amsterdam_rokin_centraal.yaml"))
train = api.load_train(api.shipped("trains/amsterdam_metro.yaml"))

# %% [markdown]
# `api.solve` builds the space-domain NLP on `points` grid nodes, solves it with Ipopt and
# re-simulates the result with an independent simulator. 300 nodes are enough to see the shape
# (the command's default is 1000).

# %%
run = api.solve(track, train, "Rokin", "Centraal", running_time=76.0, points=300)
run  # one line: the stops, the grid, the running time, the energies and the status

# %% [markdown]
# `run.status` is `ok` when Ipopt proved optimality and an independent re-simulation agrees; else
# `flagged` with the reason (`run.reason`). `run.facts` is the summary typed, units in the names
# (`run.summary`: the dict of summary.json).

# %%
s = run.facts
print(f"status {run.status}; traction energy {s.traction_energy_kWh:.3f} kWh, "
      f"net of regeneration {s.net_energy_kWh:.3f} kWh, running time {s.running_time_s:.1f} s")
print("verified by re-simulation:", s.verification.passed)

# %% [markdown]
# The profile has a row per grid node: the display columns of `profile.csv` beside SI columns.

# %%
run.profile[["position_m", "speed_kmh", "handle", "speed_mps", "traction_force_N"]].iloc[::50]

# %% [markdown]
# `plot()` returns a matplotlib figure: speed with the speed limit, the gradient and the handle.

# %%
run.plot()

# %% [markdown]
# ## A train built in code
#
# `api.train_from_dict` takes the fields of a train file (units in the field names) and validates
# them exactly as a file is validated: a misspelt field is refused with its name.

# %%
fields = yaml.safe_load(api.shipped("trains/amsterdam_metro.yaml").read_text())
fields.update(mass_t=1.2 * fields["mass_t"], effective_mass_t=1.2 * fields["effective_mass_t"])
heavier = api.train_from_dict(fields, "heavier metro train")
run_heavy = api.solve(track, heavier, "Rokin", "Centraal", running_time=76.0, points=300)
ratio = run_heavy.facts.traction_energy_kWh / s.traction_energy_kWh
print(f"20 % more mass: {run_heavy.facts.traction_energy_kWh:.3f} kWh, {ratio:.2f} times the energy")

# %% [markdown]
# More than 1.2 times: the heavier train's fastest run takes longer (74.3 s against 71.7 s at this
# grid), so the same 76 s leave it 2 % of slack instead of 6 %, and the energy rises steeply as the
# slack shrinks (see the Pareto front example).
