"""Feature: closed-loop control. Controllers re-plan on board while the plant (``core.plant``) is
not their model; a loop drives them at a sample time with noise and a mass estimator.
Uses layers 0-3 only. The predictive controllers of the sources live here (SBPC, SPPC, RSPC, the
convex SOCP controller), with their fallback plan (``fallback``) and terminal approach (``terminal``)."""
