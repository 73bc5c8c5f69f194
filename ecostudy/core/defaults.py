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

SLOWEST = 5.0
"""The longest running time a run is solved for, as a multiple of its fastest envelope's (the
kinematic all-out estimate). Slower, the energy optimum crawls: on the metro case at K = 100, whose
fastest envelope takes 71.6 s, 350 s passed the re-simulation, 450 s missed its arrival tolerance
and 550 s stopped 1 km short of its stop (``ecostudy solve --track tracks/amsterdam_rokin_centraal.yaml
--train trains/amsterdam_metro.yaml --time 550 --points 100``)."""

DAS_TIME_LIMIT_S = 60.0
"""The time limit of each driver-advice MINLP search (``--das minlp``, a study's ``das_time_limit_s``)
[s]: on the default study the search finds the phases' pattern and stops at it (docs/das.md)."""

DRAFT_GEAR_TRAVEL_M = 2 * 3.25 * 0.0254
"""How far a freight coupling closes beyond its free slack before its draft gears go solid [m]: two
gears in series, one at each car's end, each with the 3.25 in of travel of AAR M-901E Group J (Railway
Age, "For Miner, a 'Milestone'"), 0.1651 m. The default of a consist file's
``couplers.draft_gear_travel_m``; a heavy-haul run that closes a coupling further is flagged
(docs/heavyhaul.md, "Run status")."""

MAX_SUPPLEMENT_PERCENT = 200.0
"""The largest running-time supplement over the all-out time a file or an option may give [%]
(a Pareto front's reach too); no timetable asks for more."""
