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
# # Closed loop: re-planning from the measured state
#
# A controller on the train re-solves the plan from where the train is (its position, speed and
# clock) at every sample. `api.replanner` gives that model: written once, re-solved from any
# state by changing bounds only. The trip is Yazhemsky 2017's simple 1 km trip on a flat line
# (thesis "A real-time capable adaptive optimal controller for a commuter train", §9.1).

# %%
# %matplotlib inline
import tempfile
from pathlib import Path

import numpy as np
import yaml
from IPython.display import Image

from ecostudy import api

track = api.load_track(api.shipped("tracks/yazhemsky2017_flat_1km.yaml"))
train = api.load_train(api.shipped("trains/yazhemsky2017_commuter.yaml"))

planner = api.replanner(track, train, running_time=90.0, points=200)
plan = planner.solve()  # from standstill at the departure, clock 0
print(plan.outcome.status, f"arrives at {plan.time[-1]:.1f} s")

# %% [markdown]
# Halfway, the train is where the plan says but 5 s late. Re-planned from that state for the same
# arrival, the rest of the run needs traction again, which the on-time plan (coasting from there)
# did not:

# %%
x = 500.0
speed, clock = float(np.interp(x, plan.nodes, plan.v)), float(np.interp(x, plan.nodes, plan.time))
for late in (0.0, 5.0):
    again = planner.solve(api.State(position=x, speed=speed, time=clock + late), arrival=90.0)
    print(f"{late:.0f} s late at {x:.0f} m: traction still to do {again.traction_energy / 3.6e6:.3f} kWh, "
          f"top speed ahead {3.6 * again.v.max():.1f} km/h ({again.outcome.status})")

# %% [markdown]
# ## A closed-loop study
#
# The `simulate` command drives a plant that is not the model (here the mass drawn within
# +-10 % per run) with a controller in the loop, and with the controller's own first plan
# replayed open loop for comparison, over a few Monte Carlo draws. In Python it is
# `api.simulate_folder`: the study file is written from Python, the function runs it into its
# output folder and returns the folder read back (an `api.Report`).

# %%
OUT = Path(tempfile.mkdtemp(prefix="ecostudy-gallery-"))
study = {
    "name": "gallery_closed_loop",
    "track": str(api.shipped("tracks/yazhemsky2017_flat_1km.yaml")),
    "train": str(api.shipped("trains/yazhemsky2017_commuter.yaml")),
    "window_s": [0, 100],
    "points": 200,
    "sample_time_s": 0.5,
    "controllers": [{"name": "convex", "kind": "convex"}, {"name": "plan_replayed", "kind": "open_loop"}],
    "deviations": {"mass": {"low": 0.9, "high": 1.1}},
    "draws": 3,
    "seed": 1,
}
(OUT / "closed_loop.yaml").write_text(yaml.safe_dump(study))
result = api.simulate_folder(OUT / "closed_loop.yaml", out=OUT / "loop")
print(result.status, result.cases)
print("\n".join(result.problems()))  # each run not ok, with its reason

# %% [markdown]
# One row per run: its status (with the reason when it is not ok), energy, arrival and where it
# stopped. The open-loop replay does not see the mass it was not told about.

# %%
result.tables["runs"][["controller", "draw", "status", "reason", "traction_energy_kWh", "arrival_s", "stop_error_m"]]

# %% [markdown]
# The speed of the runs per controller (the 5-95 % band and the median), with the speed limit in
# the colour it has in every ecostudy figure:

# %%
Image(filename=result.folder / "bands.png")
