"""Feature: trains sharing one DC substation: the circuit, the fleet and its strategies. Layers 0-3 only."""
