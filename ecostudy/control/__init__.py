"""Feature: closed-loop control. Controllers re-plan on board while the plant (``core.plant``) is
not their model; a loop drives them at a sample time with noise and a mass estimator.
Uses layers 0-3 only (the predictive controllers of the source documents)."""
