"""Feature: driving heuristics scored by the simulator: eco-drive coasting, MARECO-style. Layers 0-3 only."""
