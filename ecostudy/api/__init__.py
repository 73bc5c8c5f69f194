"""ecostudy from Python, for notebooks and scripts (README, "Python API").

Load a train and a track from files, or build them in code from the same fields (units in the
field names, validated as files are); solve a run; sweep a front. Results carry the profile as a
pandas DataFrame with SI and display columns, the summary typed (``facts``; ``summary``: the dict of
``summary.json``), the verification and a ``plot()`` that returns a matplotlib figure (or writes a PNG).

Every command of the command line is a function here too, with the same options as arguments
(``solve_folder``, ``pareto_folder``, ``compare_folder``, ``journey_folder``, ``run_folder``,
``simulate_folder``, ``heavyhaul_folder``, ``network_folder``, ``calibrate_folder``,
``validate_folder``; ``check_folder``, ``export_folder``, ``doctor``): each writes its output
folder and returns it read back (:class:`Report`, a :class:`StudyResult` with the printed report).

Everything is SI inside; the arguments here say their unit in their name where it is not SI.

Every result says whether it can be trusted: ``status`` (a :class:`Status`: ``ok``, ``flagged`` or
``failed``, with its ``reason``) on a run, a front, a re-plan, an output folder and what ``check_folder``,
``export_folder`` and ``doctor`` return (a :class:`Note`). A bad argument, a bad
field of an input (a file, a dict, or a Train or Track built in code) or a request no run can meet raises
:class:`InputError` (an
:class:`EcostudyError`) before anything is solved, one line per problem naming the file (or
``arguments``), the field (the argument, as it is spelled here: ``time`` of ``solve_folder``,
``to_stop``) and what is wrong; within :func:`command_line` the command functions name the command
line's options instead (``command line: --time``), as ``ecostudy`` prints them.
"""
import importlib
from typing import TYPE_CHECKING, Any

from ecostudy.core import startup
from ecostudy.ocp.solver import configure

configure()  # the API is an entry point: set the process up once, before pandas, scipy and Pyomo load

# Each name is imported from its module when first used (PEP 562): a command loads only what it runs
# (``ecostudy solve`` neither matplotlib without plots nor the closed-loop, heavy-haul or network code).
WHERE = {
    "load": "ecostudy.api.outcome", "StudyResult": "ecostudy.io.folder",
    "load_train": "ecostudy.io.loaders", "load_track": "ecostudy.io.loaders",
    "train_from_dict": "ecostudy.io.loaders", "track_from_dict": "ecostudy.io.loaders",
    "Train": "ecostudy.core.types", "Track": "ecostudy.core.types", "State": "ecostudy.core.types",
    "Window": "ecostudy.core.types",
    "solve": "ecostudy.api.python", "pareto": "ecostudy.api.python", "replanner": "ecostudy.api.python",
    "Solution": "ecostudy.api.python", "Front": "ecostudy.api.python",
    "RunSummary": "ecostudy.io.runsummary", "Verification": "ecostudy.io.runsummary",
    "InputError": "ecostudy.core.errors", "EcostudyError": "ecostudy.core.errors", "Status": "ecostudy.core.status",
    "InfeasibleError": "ecostudy.core.errors", "SolverError": "ecostudy.core.errors",
    "Report": "ecostudy.api.outcome", "Note": "ecostudy.api.outcome", "one_line": "ecostudy.api.outcome",
    "solve_folder": "ecostudy.api.single", "check_folder": "ecostudy.api.single",
    "export_folder": "ecostudy.api.single", "doctor": "ecostudy.api.single",
    "pareto_folder": "ecostudy.api.fronts", "compare_folder": "ecostudy.api.fronts",
    "journey_folder": "ecostudy.api.fronts",
    "run_folder": "ecostudy.api.cases", "simulate_folder": "ecostudy.api.cases",
    "heavyhaul_folder": "ecostudy.api.cases", "network_folder": "ecostudy.api.cases",
    "calibrate_folder": "ecostudy.api.cases", "validate_folder": "ecostudy.api.cases",
    "command_line": "ecostudy.api.arguments", "shipped": "ecostudy.io.shipped",
}
__all__ = ["load", "StudyResult", "load_train", "load_track", "train_from_dict", "track_from_dict", "Train", "Track",
           "State", "Window", "solve", "pareto", "replanner", "Solution", "Front", "RunSummary", "Verification", "InputError",
           "EcostudyError", "InfeasibleError", "SolverError", "Status", "Report", "Note", "one_line",
           "solve_folder", "check_folder", "export_folder", "doctor", "pareto_folder", "compare_folder",
           "journey_folder", "run_folder", "simulate_folder", "heavyhaul_folder", "network_folder",
           "calibrate_folder", "validate_folder", "command_line", "shipped"]  # = WHERE's names, written out for the reference's static reader


def __getattr__(name: str) -> Any:
    if name not in WHERE:
        raise AttributeError(f"module 'ecostudy.api' has no attribute {name!r}")
    value = getattr(importlib.import_module(WHERE[name]), name)
    startup.resume()  # the command line paused the collector at its start: what loaded is frozen now
    globals()[name] = value  # found once
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(WHERE))


if TYPE_CHECKING:  # what type checkers and editors see
    from ecostudy.api.arguments import command_line  # noqa: F401
    from ecostudy.api.cases import (calibrate_folder, heavyhaul_folder, network_folder, run_folder,  # noqa: F401
                                    simulate_folder, validate_folder)
    from ecostudy.api.fronts import compare_folder, journey_folder, pareto_folder  # noqa: F401
    from ecostudy.api.outcome import Note, Report, load, one_line  # noqa: F401
    from ecostudy.api.python import Front, Solution, pareto, replanner, solve  # noqa: F401
    from ecostudy.api.single import check_folder, doctor, export_folder, solve_folder  # noqa: F401
    from ecostudy.core.errors import EcostudyError, InfeasibleError, InputError, SolverError  # noqa: F401
    from ecostudy.core.status import Status  # noqa: F401
    from ecostudy.core.types import State, Track, Train, Window  # noqa: F401
    from ecostudy.io.folder import StudyResult  # noqa: F401
    from ecostudy.io.loaders import load_track, load_train, track_from_dict, train_from_dict  # noqa: F401
    from ecostudy.io.runsummary import RunSummary, Verification  # noqa: F401
    from ecostudy.io.shipped import shipped  # noqa: F401
