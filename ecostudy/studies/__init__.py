"""Layer 5: questions over many runs: Pareto fronts, journeys, comparisons, batch studies."""
