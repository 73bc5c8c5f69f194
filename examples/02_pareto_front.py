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
# # Energy against running time: a Pareto front
#
# How much energy a longer running time saves, from the all-out run to 30 % over it, for the
# Amsterdam metro between the first two stops of the representative 4-stop line. `api.pareto`
# solves the points as one warm-started chain; every point is verified by re-simulation.

# %%
# %matplotlib inline
from ecostudy import api

track = api.load_track(api.shipped("tracks/metro_line_4stops.yaml"))
train = api.load_train(api.shipped("trains/amsterdam_metro.yaml"))

front = api.pareto(track, train, "Noord", "Station", count=6, supplement_max_percent=30.0, points=200)

# %% [markdown]
# The front shows itself as its points with their status (the worst point's, with its reasons, on top):

# %%
front

# %% [markdown]
# `front.table` has more per point: the saving against the all-out run and the marginal saving of
# one more second.

# %%
columns = ["running_time_s", "supplement_pct", "traction_energy_kWh", "net_energy_kWh", "saving_vs_all_out_pct",
           "marginal_saving_kWh_per_s", "status"]
front.table[columns]

# %% [markdown]
# The front and the marginal saving beneath it. The saving per second falls as the running time
# grows: the first seconds of supplement buy the most.

# %%
front.plot()

# %% [markdown]
# The runs themselves are kept: the slowest point's speed profile, for instance.

# %%
slowest = front.runs[-1]  # an api.Solution, as api.solve returns
print(slowest)
slowest.plot()
