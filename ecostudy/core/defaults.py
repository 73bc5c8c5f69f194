"""The defaults a user does not have to choose, each named once with its meaning.

Every schema, function, API call and command option that defaults a grid size reads it from
here (``tests/test_defaults.py`` checks the study schemas, the API and the command line against
these). No imports: the command line reads them for its help without loading numpy.
"""

RUN_POINTS = 1000
"""K, the grid nodes of one stop-to-stop run: the default of a study file's ``points``, of
``ecostudy solve`` and ``compare`` and of ``api.solve``. On the metro case the traction energy is
within 0.02 % of its grid-converged value at K = 1000 (0.1 % at about K = 300; docs/single_run.md)."""

FRONT_POINTS = 500
"""K of each run where one command solves many: a Pareto front (``ecostudy pareto`` without a
study file, ``api.pareto``), a journey's segment fronts, a network's per-segment starting runs, a
re-planner (``api.replanner``) and the runs drawn by a calibration's savings estimate. Half of
:data:`RUN_POINTS`: a command that solves many runs trades some grid accuracy for time."""
