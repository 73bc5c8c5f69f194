"""Ipopt through Pyomo's cyipopt interface, with every exit mapped to an outcome.

The glue is ours rather than ``SolverFactory('cyipopt')`` so that the NL write (``PyomoNLP``,
which writes and loads an AMPL NL file through PyNumero's ASL) and the solve are timed apart,
iterations are counted, and the NLP object can be reused.
"""
import subprocess
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence, TypeAlias

import cyipopt
import numpy as np
import pyomo
from pyomo.core.base.suffix import active_import_suffix_generator
from pyomo.common.env import CtypesEnviron
from pyomo.common.gc_manager import PauseGC
from pyomo.opt import WriterFactory
from pyomo.repn.plugins.nl_writer import NLWriter
from pyomo.contrib.pynumero.asl import AmplInterface
from pyomo.contrib.pynumero.interfaces.cyipopt_interface import CyIpoptNLP
from pyomo.contrib.pynumero.interfaces.pyomo_nlp import PyomoNLP

from ecostudy.core.errors import SolverError
from ecostudy.core.interrupt import held as stop_signals_held
from ecostudy.ocp import solver
from ecostudy.ocp.solver import IPOPT, NL_OPTIONS, Model, Var

Options: TypeAlias = Mapping[str, Any]  # Ipopt options by name

DEFAULT_OPTIONS = IPOPT["space"]  # every solve's base; the families' options: ``ocp.solver.IPOPT``
WARM_START = IPOPT["warm_start"]

# Ipopt ApplicationReturnStatus -> our status word
STATUS = {0: "optimal", 1: "acceptable", 2: "infeasible", 3: "search_direction_too_small",
          4: "diverging", 5: "user_stop", 6: "feasible_point_found", -1: "max_iterations",
          -2: "restoration_failed", -3: "step_computation_error", -4: "max_cpu_time",
          -10: "not_enough_degrees_of_freedom", -11: "invalid_problem", -12: "invalid_option",
          -13: "invalid_number"}


@dataclass
class Outcome:
    status: str            # see STATUS
    iterations: int
    seconds: float         # Ipopt wall time
    nl_seconds: float      # NL write and ASL load
    max_violation: float   # largest constraint violation at the returned point

    @property
    def optimal(self) -> bool:
        return self.status == "optimal"

    @property
    def usable(self) -> bool:
        """A point that satisfies the constraints, even if not proven optimal (then flagged)."""
        return self.status in ("optimal", "acceptable") or self.max_violation < 1e-6

    def failure(self, what: str, why: str = "") -> SolverError:
        """The error of a solve of ``what`` that left no usable point: how Ipopt ended it, and
        ``why`` in brackets (e.g. the clock of a time-domain leg)."""
        return SolverError(f"{what}: Ipopt {self.status} after {self.iterations} iterations" + (f" ({why})" if why else ""))


def repeatable() -> None:
    """Every solve repeats bit for bit: the solver chain set up (``ocp.solver.prepare``) and
    Scotch's generator reset, so the solves that follow order their matrices as they did the first
    time (``Session.solve`` calls it; so does a MINLP search whose NLPs Pyomo solves)."""
    solver.prepare(NLWriter, AmplInterface, CtypesEnviron, WriterFactory)
    solver.repeatable()


def _imports() -> tuple[Any, Any]:
    """PyNumero classes, with the solver chain prepared (``ocp.solver.prepare``) and the ASL library
    found even when Pyomo was imported before ecostudy."""
    if not solver.prepare(NLWriter, AmplInterface, CtypesEnviron, WriterFactory):
        raise SolverError("PyNumero's ASL library (libpynumero_ASL.so) is missing: run `make install` "
                          "(scripts/install.sh builds it into .pyomo/)")
    return CyIpoptNLP, PyomoNLP


class Session:
    """The NLP of one model, written once, solved as often as needed with changed variable bounds.

    ``PyomoNLP`` writes the NL file and loads it through ASL (the "NL write" stage); each solve
    wraps it in a fresh ``CyIpoptNLP``, which reads the current bounds, so a sweep over running
    times changes one bound instead of writing the model again.
    """

    def __init__(self, model: Model) -> None:
        CyIpoptNLP, PyomoNLP = _imports()
        self.model = model
        t0 = time.perf_counter()
        with PauseGC():  # the write makes no garbage; a collection would walk every Pyomo object
            self.nlp = PyomoNLP(model, nl_file_options=NL_OPTIONS)  # (0.39 -> 0.29 s, metro K = 1000)
        self.nl_seconds = time.perf_counter() - t0
        self.x = np.array(self.nlp.init_primals(), dtype=float)
        # the model's variables in the NLP's order, and each one's place: PyNumero rebuilds the list
        # and looks each variable up in a ComponentMap on every call (SPPC re-plans: 2.6 + 1.3 of
        # 58 CPU s per run under cProfile; docs/closed_loop.md)
        self.variables = self.nlp.get_pyomo_variables()
        self._place = {id(var): i for i, var in enumerate(self.variables)}
        # (constraints, lower bounds, upper bounds) of the last solve
        self.multipliers: tuple[Any, Any, Any] | None = None
        self._problem_class = CyIpoptNLP

    def indices(self, variables: Sequence[Var]) -> np.ndarray:
        """The places of model variables in the NLP's primal vector (``PyomoNLP.get_primal_indices``)."""
        place = self._place
        return np.fromiter((place[id(var)] for var in variables), dtype=int, count=len(variables))

    def set_bounds(self, var: Var, lower: float | None, upper: float | None) -> None:
        """Change the bounds of one model variable (``None`` for none) before the next solve.

        Both the NLP's bound arrays and the Pyomo variable change, so the model stays consistent.
        """
        self.set_many_bounds([var], [lower], [upper])

    def set_many_bounds(self, variables: Sequence[Var], lowers: Sequence[float | None],
                        uppers: Sequence[float | None]) -> None:
        """:meth:`set_bounds` for many variables at once (one copy of the bound arrays)."""
        index = self.indices(variables)
        arrays: dict[str, np.ndarray] = {}
        changed = np.zeros(len(index), dtype=bool)
        for name, values, default in (("_primals_lb", lowers, -np.inf), ("_primals_ub", uppers, np.inf)):
            arr = np.array(getattr(self.nlp, name), dtype=float)  # PyNumero keeps them read-only
            new = np.array([default if v is None else float(v) for v in values], dtype=float)
            changed |= arr[index] != new
            arr[index] = new
            arr.flags.writeable = False
            setattr(self.nlp, name, arr)
            arrays[name] = arr
        # the Pyomo variables whose bounds move (the others hold these bounds already: an SBPC
        # re-plan at L = 1 sets about 1 200 bounds and moves a few; Pyomo's setters were a quarter
        # of its Python time)
        for j in map(int, np.flatnonzero(changed)):
            lo, hi = lowers[j], uppers[j]
            variables[j].setlb(None if lo is None else float(lo))
            variables[j].setub(None if hi is None else float(hi))
        self.x[index] = np.clip(self.x[index], arrays["_primals_lb"][index], arrays["_primals_ub"][index])

    def set_row_uppers(self, constraints: Sequence[Any], upper: float) -> None:
        """Change the upper bound of some inequality rows of the NLP before the next solve, as a model
        written with that bound would hold it (the caller keeps the Pyomo rows alike)."""
        index = np.asarray(self.nlp.get_constraint_indices(list(constraints)), dtype=int)
        nlp = self.nlp
        bound = np.array(nlp.constraints_ub(), dtype=float)  # PyNumero keeps it read-only
        bound[index] = upper
        inequalities = np.compress(nlp._con_full_ineq_mask, bound)
        for array in (bound, inequalities):
            array.flags.writeable = False
        nlp._con_full_ub, nlp._con_ineq_ub = bound, inequalities

    def set_start_values(self, variables: Sequence[Var], values: Sequence[float] | np.ndarray,
                         clip: bool = True) -> None:
        """Set the starting point of some variables for the next solve, clipped to their bounds
        unless ``clip`` is False (then Ipopt moves them inside, as it does a new model's start)."""
        index = self.indices(variables)
        start = np.asarray(values, dtype=float)
        self.x[index] = np.clip(start, self.nlp.primals_lb()[index], self.nlp.primals_ub()[index]) if clip else start

    def solve(self, options: Options | None = None, x0: Sequence[float] | np.ndarray | None = None) -> Outcome:
        """Solve from ``x0`` (default: the last solution); loads the point into the model."""
        iterations = [0]

        # a Ctrl-C, SIGTERM or SIGHUP that arrived during the solve is held (raised inside one of cyipopt's
        # callbacks it was swallowed there and the solve went on: a K = 1000 Amsterdam solve sent
        # SIGINT 1.5 s in returned its optimum); Ipopt stops at its next iteration, then it is raised
        held: list[bool] = []

        base: Any = self._problem_class

        class Counting(base):  # type: ignore[misc]  # cyipopt's problem class: untyped third-party code
            def intermediate(self, alg_mod: int, iter_count: int, *args: Any) -> bool:
                iterations[0] = iter_count
                return not held

        problem = Counting(self.nlp)
        for key, value in {**DEFAULT_OPTIONS, **(options or {})}.items():
            problem.add_option(key, value)
        start = self.x if x0 is None else np.asarray(x0, dtype=float)
        duals: dict[str, Any] = {}
        if (options or {}).get("warm_start_init_point") == "yes" and self.multipliers is not None:
            duals = dict(zip(("lagrange", "zl", "zu"), self.multipliers))
        repeatable()  # the same ordering for the same matrix, every solve
        t1 = time.perf_counter()
        try:
            with stop_signals_held(held):
                x, info = problem.solve(start, **duals)
        except Exception as exc:  # cyipopt raises on evaluation errors it cannot recover from
            raise SolverError(f"Ipopt stopped with an error: {exc}") from exc
        seconds = time.perf_counter() - t1
        # Ipopt relaxes bounds by ~1e-8 (bound_relax_factor); clip so Pyomo gets in-bounds values
        self.x = np.clip(np.array(x, dtype=float), self.nlp.primals_lb(), self.nlp.primals_ub())
        self.nlp.set_primals(self.x)
        self.nlp.set_duals(info["mult_g"])
        with PauseGC():  # the load makes a tuple per constraint: a collection would walk every Pyomo object
            self._load(info["mult_g"], info["mult_x_L"], info["mult_x_U"])
        self.multipliers = (info["mult_g"], info["mult_x_L"], info["mult_x_U"])
        g = np.asarray(info["g"])
        viol = np.maximum(self.nlp.constraints_lb() - g, g - self.nlp.constraints_ub())
        problem.close()
        return Outcome(STATUS.get(int(info["status"]), f"ipopt_{info['status']}"), int(iterations[0]),
                       seconds, 0.0, float(np.max(viol, initial=0.0)))


    def _load(self, duals: Any, lower: Any, upper: Any) -> None:
        """``PyomoNLP.load_state_into_pyomo`` without its per-call lookups: the primal point into the
        variables (in their bounds already, so Pyomo's domain and bound checks, which only warn,
        are skipped: 9.2 of 58 CPU s of an SPPC run under cProfile went into the load), the
        multipliers into the model's import suffixes as before."""
        for var, value in zip(self.variables, self.x):
            var.set_value(value, skip_validation=True)
        suffixes = dict(active_import_suffix_generator(self.model))
        if "dual" in suffixes:
            suffixes["dual"].clear()
            suffixes["dual"].update(zip(self.nlp.get_pyomo_constraints(), duals))
        for name, values in (("ipopt_zL_out", lower), ("ipopt_zU_out", upper)):
            if name in suffixes:
                suffixes[name].clear()
                suffixes[name].update(zip(self.variables, values))


def solve(model: Model, options: Options | None = None) -> Outcome:
    """Solve ``model`` once, in place; returns an :class:`Outcome` (never raises on non-optimal)."""
    session = Session(model)
    outcome = session.solve(options)
    outcome.nl_seconds = session.nl_seconds
    return outcome


def versions() -> dict[str, str]:
    """Versions of the solver chain: Pyomo, cyipopt, Ipopt, MUMPS (as Ipopt's package reports them)."""


    def pkg(name: str) -> str:
        try:
            return subprocess.run(["dpkg-query", "-W", "-f=${Version}", name], capture_output=True,
                                  text=True, timeout=5).stdout.strip() or "unknown"
        except (OSError, subprocess.SubprocessError):
            return "unknown"

    return {"pyomo": pyomo.__version__, "cyipopt": cyipopt.__version__,
            "ipopt": pkg("coinor-libipopt-dev"), "mumps": pkg("libmumps-seq-dev")}
