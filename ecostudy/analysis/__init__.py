"""Layer 3: what a solved run means: tables, regimes, the Pontryagin check, the summary layout,
and the verified single run (solve, analyse, re-simulate)."""
