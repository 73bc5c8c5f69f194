"""Calibrating a train from logged runs and validating a model against them (a feature: layers
0-3 only): test logs from the plant, the replayed dynamics, the least-squares fit with its
intervals and identifiability, and the replay of a log on a model."""
