"""ecostudy: batch studies of energy-efficient train control (EETC).

Layers (docs/architecture.md): files -> SI objects (``io``, ``core``) -> Pyomo models and Ipopt
(``ocp``) -> analysed, re-simulated runs (``analysis``) -> features (``das``, ``heuristics``,
``network``) -> studies -> report -> the command line (``cli``) and the Python API (``api``).
"""
import os
from pathlib import Path

__version__ = "0.2.0"

# PyNumero's ASL library is built into <repo>/.pyomo by scripts/install.sh; Pyomo reads
# PYOMO_CONFIG_DIR when it is first imported, so this must run before any pyomo import.
_repo_config = Path(__file__).resolve().parent.parent / ".pyomo"
if "PYOMO_CONFIG_DIR" not in os.environ and (_repo_config / "lib").is_dir():
    os.environ["PYOMO_CONFIG_DIR"] = str(_repo_config)


def _light_pyomo_imports():
    """Keep Pyomo from importing what ecostudy never uses when scipy or matplotlib is first imported.

    ``pyomo.common.dependencies`` hooks the import of scipy to import ``scipy.stats`` (about 1.2 s
    here) and of matplotlib to import ``pyplot`` and ``pylab`` (about 0.9 s). ecostudy needs only
    ``scipy.sparse``/``scipy.integrate`` (imported where used) and draws on ``matplotlib.figure``.
    The hooks are registered when Pyomo is first imported and fire whether scipy comes before or
    after it, so they are replaced here, before anything imports either (issue 15's start-up).
    """
    for name in ("scipy", "matplotlib"):
        for indicator in DeferredImportCallbackFinder._callbacks.get(name, ()):
            indicator._callback = None


from pyomo.common.dependencies import DeferredImportCallbackFinder  # noqa: E402 (after PYOMO_CONFIG_DIR)

_light_pyomo_imports()
