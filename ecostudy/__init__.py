"""ecostudy: batch studies of energy-efficient train control (EETC).

Layers (docs/architecture.md): files -> SI objects (``io``, ``core``) -> Pyomo models and Ipopt
(``ocp``) -> analysed, re-simulated runs (``analysis``) -> features (``das``, ``heuristics``,
``network``, ``control``, ``heavyhaul``) -> studies -> report -> the command line (``cli``) and the
Python API (``api``).

Importing the package changes nothing in the process: the entry points call
``ecostudy.ocp.solver.configure()`` once (the command line, ``ecostudy.api``, the test suite).
"""
__version__ = "0.2.0"
