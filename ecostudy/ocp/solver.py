"""Process-wide setup of the solver chain, done explicitly: nothing here runs at import.

Two steps, both idempotent:

- :func:`configure`, called once by every entry point (the command line before any command, the
  Python API ``ecostudy.api``, the test suite) before the heavy libraries are imported: it keeps
  Pyomo from importing what ecostudy never uses and pins MUMPS's ordering to one thread.
- :func:`prepare`, called by the solver glue (``ocp.session``) before the first NL file is written
  or the first solve, in any process (worker processes and Dask workers included): the NL writer's
  defaults, the ASL library, the Scotch handle that makes every solve repeat bit for bit.

What each setting is for is said where it is set.
"""
import ctypes
import os
from pathlib import Path
from typing import Any, Optional, TypeAlias

from pyomo.common.dependencies import DeferredImportCallbackFinder

# PyNumero's ASL library as scripts/install.sh builds it (used when Pyomo's own search finds none)
REPO_ASL = Path(__file__).resolve().parents[2] / ".pyomo" / "lib" / "libpynumero_ASL.so"

# Pyomo 6.10's NL writer exports named Expressions as AMPL defined variables; with a fixed variable
# inside one that several named Expressions share (a leg's mean speed at its fixed end speed, used
# by its traction and regeneration power), the constraint that uses their sum reached Ipopt with
# other values and derivatives than Pyomo's (the joint network optimum's power balance at the last
# step of each leg, 74 kW apart; tests/test_session.py). Written inline instead, at a cost on the
# default study's space NLP (which the bug did not hit): NL write unchanged, Ipopt about 12 % longer
# (quiet machine, alternating: 1.40-1.58 s against 1.22-1.36 s; energy equal to 4e-9).
NL_OPTIONS = {"export_defined_variables": False}

# Pyomo and PyNumero ship no type information: a model, its components and expressions are Any
Model: TypeAlias = Any   # a pyomo ConcreteModel
Var: TypeAlias = Any     # a Pyomo variable (scalar, or an element of an indexed one)
# Ipopt's options per problem family, in one place; each family's measurement is said beside it.
# ``ocp.session.Session.solve`` starts from "space" (Ipopt's defaults but for these) and a caller adds
# its family's options on top; the modules named keep them under their old names.
IPOPT: dict[str, dict[str, Any]] = {
    # every NLP: the space NLP of one run, and the base of the others; MUMPS's own defaults here: no
    # ordering, scaling or memory option was faster on it (long case, K = 1000: Scotch, the automatic
    # choice, and METIS equal, AMD, PORD and QAMD 4-5x slower; docs/speed.md)
    "space": {"tol": 1e-8, "acceptable_tol": 1e-6, "max_iter": 3000, "print_level": 0, "mu_strategy": "adaptive",
              "sb": "yes"},
    # a re-solve from the previous solve's primal and dual point (Session keeps the multipliers) with
    # a small barrier parameter: SBPC 14.1 -> 4.9 and SPPC 38.6 -> 18.4 Ipopt iterations per sample
    # (ocp.session.WARM_START, control/sbpc.py, control/sppc.py)
    "warm_start": {"warm_start_init_point": "yes", "mu_init": 1e-5, "warm_start_bound_push": 1e-6,
                   "warm_start_mult_bound_push": 1e-6},
    # the predictive controllers' re-plans, on top of "warm_start" (docs/closed_loop.md)
    "receding": {"max_iter": 500, "tol": 1e-7, "acceptable_tol": 1e-5},
    # SPPC's re-plans, on top of "receding": the warm start's point and multipliers pushed 1e-10 instead
    # of 1e-6 inside their bounds (Ipopt's two warm_start_*bound_push options): 10.0 -> 8.3 Ipopt
    # iterations per phases NLP over the 388 NLPs of draw 0 of studies/metro_monte_carlo.yaml replayed
    # from their recorded starts (1e-9: 7.4, 1e-8 and 1e-12: 8.0), draws 0-3 of that study 27 against
    # 32 CPU s a run; 1e-8, 1e-9 and 1e-12 turned draw 1 to a neighbouring plan stopping 2.1-2.3 m past
    # the mark (+0.76 m as before with 1e-10). docs/closed_loop.md; control/sppc.py
    "sppc": {"warm_start_bound_push": 1e-10, "warm_start_mult_bound_push": 1e-10},
    # a closed-loop re-plan that needs more has no plan worth waiting for (control/controllers.py)
    "replan": {"max_iter": 300},
    # a Pareto chain after its first point, from the previous point's primal and dual solution
    # (bench/bench_pareto.py: 27-56 % fewer iterations than a primal-only start, fronts equal or lower
    # by up to 5e-5; the primal-only chain took 204 s instead of 14 s on the Yazhemsky 2017 advanced trip at
    # K = 1000; studies/pareto.py)
    "pareto_warm": {"warm_start_init_point": "yes", "mu_init": 1e-4, "warm_start_bound_push": 1e-6,
                    "warm_start_mult_bound_push": 1e-6, "warm_start_slack_bound_push": 1e-6},
    # a network leg: MUMPS without its own row and column scaling (a leg's KKT matrix is small and
    # banded; the scaling took about a fifth of Ipopt's time: `python bench/bench_leg_options.py
    # studies/network_metro_3trains.yaml`, six legs 4.85 -> 3.82 s, the same iterations; slower on the
    # joint NLP, 18.9 / 19.2 against 16.9 / 15.8 s; network/legs.py KKT), and PORD's ordering instead of
    # MUMPS's automatic choice (first-round legs: metro 2 trains 2.83 -> 2.17 s, 3 trains 5.12 -> 3.40 s,
    # regional 20 stops 6.14 -> 3.71 s, costs within 5e-9; the whole 2-train study's Ipopt 44.9 -> 41.0 s,
    # substation energies equal to 1e-4 kWh; docs/speed.md). On the space NLP the automatic choice is the
    # fastest (metro K = 1000: 0.71 s; Scotch 0.84, AMD and PORD 1.63 s), so it stays there.
    "leg": {"mumps_scaling": 0, "mumps_pivot_order": 4},
    # a solve from a feasible run (a warm leg, the joint NLP): stay near it instead of pushing every
    # variable 1 % inside its bounds (the 2-train joint NLP: adaptive barrier 3000 iterations, monotone
    # from mu 1e-3 730; network/legs.py NEAR_START)
    "near_start": {"bound_push": 1e-8, "bound_frac": 1e-8, "mu_strategy": "monotone", "mu_init": 1e-3},
    # the NLP subproblems of the DAS mode choice's MINLP search (MindtPy through Pyomo's cyipopt;
    # ocp/modechoice.py)
    "mode_choice": {"print_level": 0, "max_iter": 1500, "tol": 1e-7},
    # the joint network NLP: MUMPS's METIS ordering instead of its automatic choice (3 trains: 35 -> 26 s
    # for the same 105 iterations; SCOTCH was as fast but not deterministic, runs differed by 38 kW in a
    # step's power along a flat direction; on the legs and the space NLP neither bought anything
    # measurable). Both go through Scotch here, which :func:`repeatable` makes repeat exactly
    # (network/joint.py ORDERING)
    "joint": {"mumps_pivot_order": 5},
}

_state: dict[str, Any] = {"configured": False, "prepared": False, "scotch": None}


def configure() -> None:
    """Set up this process for ecostudy; call it once, first thing, from an entry point.

    - Pyomo hooks the import of scipy to import ``scipy.stats`` (about 1.2 s here) and of
      matplotlib to import ``pyplot`` and ``pylab`` (about 0.9 s). ecostudy needs only
      ``scipy.sparse``/``scipy.integrate`` and draws on ``matplotlib.figure``; the hooks fire
      whether scipy comes before or after Pyomo, so they are switched off here.
    - MUMPS's automatic ordering here is Scotch's (Debian's MUMPS has no METIS of its own), and
      Scotch 7 orders with threads and a random generator whose state runs on from call to call:
      the same NLP solved twice, in one process or two, ended 1e-15 apart, and the rounds of a
      network study amplified that to 1 %. One thread (read at each call) here, and the generator
      reset before each solve (:func:`repeatable`), make every solve repeat bit for bit.
    - glibc's allocator keeps the memory a factorization frees for the next one (:func:`keep_freed_memory`).
    """
    if _state["configured"]:
        return
    for name in ("scipy", "matplotlib"):
        for indicator in DeferredImportCallbackFinder._callbacks.get(name, ()):
            indicator._callback = None
    os.environ.setdefault("SCOTCH_PTHREAD_NUMBER", "1")
    if "OPENBLAS_NUM_THREADS" not in os.environ:  # a user's own setting is kept
        os.environ["OPENBLAS_NUM_THREADS"] = "1"
        _state["blas_threads"] = True
    single_blas_thread()
    keep_freed_memory()
    _state["configured"] = True


def prepare(nl_writer: Any, ampl_interface: Any, environ: Any = None, writers: Any = None) -> bool:
    """Make the solver chain ready in this process (idempotent; ``ocp.session`` calls it with
    Pyomo's ``NLWriter``, PyNumero's ``AmplInterface``, Pyomo's ``CtypesEnviron`` and ``WriterFactory``).
    Returns whether PyNumero's ASL library is available.

    - the NL writer registered as Pyomo's ``nl`` writer, which ``PyomoNLP`` asks ``writers`` for.
      ``import pyomo.environ`` would register it, with every other plugin of Pyomo and its contrib
      packages (solvers, GDP, DAE, MindtPy, APPSI, ...): 0.15-0.21 CPU s of the default study's
      imports (busy machine, 5 fresh processes; ``docs/speed.md``). The modules on a solve's path
      import ``pyomo.core``, and only this one plugin is registered, as ``pyomo.environ`` registers
      it (the same class: a later ``import pyomo.environ``, for MindtPy, registers it again);
    - the NL writer's defaults (:data:`NL_OPTIONS`) for every NL file written in this process,
      also by Pyomo's own cyipopt interface (MindtPy's NLP subproblems of the DAS mode choice);
    - the ASL library built into the repository's ``.pyomo`` when Pyomo's search finds none
      (Pyomo reads PYOMO_CONFIG_DIR once, when it is first imported);
    - the Scotch library that Ipopt's MUMPS loaded, for :func:`repeatable`;
    - off Windows, Pyomo's ``CtypesEnviron`` (which every NL file load enters) told that Windows'
      C runtimes are absent: it otherwise looks for eleven of them with ``ctypes.util.find_library``,
      which runs gcc and ld for each, once per process (0.67-1.67 s for the first ``CtypesEnviron()``
      in a fresh process here, three runs on a busy machine; 0.2 ms after).
    """
    configure()
    if not _state["prepared"]:
        if environ is not None and os.name != "nt":
            for dll in environ.DLLs:
                if dll._loaded is None:  # not probed yet: Pyomo's own "absent" state, as for a None name
                    dll._loaded = False
        if writers is not None and "nl" not in writers:
            writers.register("nl", "Generate the corresponding AMPL NL file.")(nl_writer)
        for key, value in NL_OPTIONS.items():
            setattr(nl_writer.CONFIG, key, value)
        if REPO_ASL.is_file() and ("PYOMO_CONFIG_DIR" not in os.environ or not ampl_interface.available()):
            ampl_interface.libname = str(REPO_ASL)  # also spares Pyomo's library search (a compiler probe)
        _state["scotch"] = _scotch()
        single_blas_thread()  # the libraries loaded since ``configure``
        _state["prepared"] = True
    return bool(ampl_interface.available())


def single_blas_thread() -> None:
    """One thread for every OpenBLAS loaded in this process (numpy's and scipy's each bring one),
    unless the user set OPENBLAS_NUM_THREADS. The environment variable, set by :func:`configure`,
    reaches only the libraries loaded after it; the ones already loaded are told through their
    own ``*_set_num_threads``. The work here is small matrices (SLSQP's subproblems in the
    condensed SBPC program): threads only wait for one another, and a study's workers already use
    every core. Measured on this 2-core machine under load: an SLSQP iteration's C call 8.0 ->
    0.16 ms (50 constraints) and 8.0 -> 1.7 ms (400); docs/closed_loop.md. Ipopt's MUMPS calls the
    reference BLAS and is not concerned."""
    if not _state.get("blas_threads"):
        return
    for path in _loaded("openblas"):
        library = ctypes.CDLL(path)
        for name in ("openblas_set_num_threads", "scipy_openblas_set_num_threads",
                     "scipy_openblas_set_num_threads64_", "openblas_set_num_threads64_"):
            if hasattr(library, name):
                getattr(library, name)(1)
                break


# glibc's malloc: blocks up to 1 GiB come from the heap (not mmap), and up to 1 GiB freed at its top stays
# with the process (mallopt's M_MMAP_THRESHOLD and M_TRIM_THRESHOLD)
MALLOC = {-3: 1 << 30, -1: 1 << 30}  # mallopt takes a C int
MALLOC_VARIABLES = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_TOP_PAD_", "GLIBC_TUNABLES")


def keep_freed_memory() -> None:
    """Tell glibc's allocator to keep freed memory for the next allocation, unless the user set
    its thresholds. Ipopt's linear solver (MUMPS) allocates its workspace again for each
    factorization; at long K = 5000 it is larger than glibc's largest automatic mmap threshold
    (32 MiB), so each one was mapped afresh and every page faulted in and zeroed by the kernel
    (strace: blocks of 153 and 36 MB mapped 55 times each in a solve of 49 iterations; Ipopt's
    timers put 0.65 of the solve's 0.71 s system time in the linear system, against 0.01 s at
    K = 1000). A process solving long K = 5000 once: 313 000 page faults and 0.9-1.0 s
    system time; kept, 81 000 and 0.4 s, build + write + solve 8.80 -> 7.33 CPU s (medians of four
    alternated pairs), the same iterations and a bit-identical result (docs/speed.md "What was
    cut, and what each cut bought"). The cost: a process keeps its peak heap (that
    solve peaks at about 320 MB). A user's own MALLOC_* or GLIBC_TUNABLES setting is left alone.
    """
    if any(name in os.environ for name in MALLOC_VARIABLES):
        return
    try:
        libc = ctypes.CDLL("libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl, macOS, Windows)
        return
    for parameter, value in MALLOC.items():
        mallopt(parameter, value)


def _loaded(fragment: str) -> list[str]:
    """The paths of the shared libraries loaded in this process whose path holds ``fragment``."""
    try:
        with open("/proc/self/maps") as maps:
            return sorted({path for path in (line.split()[-1] for line in maps) if fragment in path})
    except OSError:
        return []


def _scotch() -> Optional[ctypes.CDLL]:
    """The Scotch library loaded in this process (through Ipopt's MUMPS), or None."""
    paths = _loaded("/libscotch-")
    return ctypes.CDLL(paths[0]) if paths else None


def repeatable() -> None:
    """Reset Scotch's generator: the solves that follow order their matrices as they did the
    first time (``Session.solve`` calls it; so does a MINLP search whose NLPs Pyomo solves)."""
    if _state["scotch"] is not None:
        _state["scotch"].SCOTCH_randomReset()
