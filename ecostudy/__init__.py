"""ecostudy: batch studies of energy-efficient train control (EETC).

Layers (docs/architecture.md): files -> SI objects (``io``, ``core``) -> Pyomo models and Ipopt
(``ocp``) -> analysed, re-simulated runs (``analysis``) -> features (``das``, ``heuristics``,
``network``) -> studies -> report -> the command line (``cli``) and the Python API (``api``).
"""
import os
from pathlib import Path

__version__ = "0.1.0"

# PyNumero's ASL library is built into <repo>/.pyomo by scripts/install.sh; Pyomo reads
# PYOMO_CONFIG_DIR when it is first imported, so this must run before any pyomo import.
_repo_config = Path(__file__).resolve().parent.parent / ".pyomo"
if "PYOMO_CONFIG_DIR" not in os.environ and (_repo_config / "lib").is_dir():
    os.environ["PYOMO_CONFIG_DIR"] = str(_repo_config)
