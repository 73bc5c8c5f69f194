"""Running a study's cases: serially, in local processes, or on a Dask cluster; resumable.

Cases already in the store are skipped; the others run as pure tasks (:func:`run_case`) and
their results are stored by this process as they arrive. Failures are results too: an
infeasible or failed case is stored with its reason and the study goes on.
"""
import time
import warnings
from concurrent.futures import as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, NamedTuple, Optional

import pandas as pd

from ecostudy.core.defaults import DAS_TIME_LIMIT_S
from ecostudy.analysis.single import ALL_OUT_SOLVER, solve_run, with_all_out
from ecostudy.core.budget import check_study
from ecostudy.core.registry import Registry
from ecostudy.core.interrupt import Interrupted, held
from ecostudy.core.errors import EcostudyError, EcostudyWarning, InfeasibleError, InputError, problem
from ecostudy.core.types import Timing
from ecostudy.das.methods import advice_status, das_columns
from ecostudy.io.loaders import track_from_schema, train_from_schema
from ecostudy.io.schemas import TrackFile, TrainFile
from ecostudy.io.store import Store, check_one_study, stored_counts
from ecostudy.core.status import flagged, worst
from ecostudy.io.folder import files_listed, mark_stopped, remove_unlisted, write_summary
from ecostudy.io.writers import check_output_dir, write_csv
from ecostudy.ocp.problem import Written
from ecostudy.studies.cases import case_key, expand
from ecostudy.studies.options import check_options
from ecostudy.studies.studytable import NOT_COMPUTED, case_names, case_statuses, study_table
from ecostudy.studies.estimate import case_size, run_bytes, run_seconds
from ecostudy.studies.workers import arriving, worker_pool

_ALL_OUT: dict = {}  # all-out time per (train, track, stops, grid), per process: shared by a scenario's cases
_WRITTEN = Written()  # written NLPs per process: cases that differ only in timing re-use one NL file
_SCENARIO = ("train", "track", "from", "to", "points")


def _all_out_time(case, track, train):
    """(the all-out time [s] of the case's scenario, how Ipopt ended it), solved once per process
    (a supplement's base)."""
    key = case_key({k: case[k] for k in _SCENARIO})
    if key not in _ALL_OUT:
        r = solve_run(track, train, case["from"], case["to"], Timing(), objective="time",
                      points=case["points"], verify_result=False)
        _ALL_OUT[key] = (r.facts.running_time_s, r.facts.solver.status)
    return _ALL_OUT[key]


def outcome(case, compute):
    """The stored result of one case: ``compute()`` returns (status, error, summary); an infeasible
    or failed case becomes a result with its reason (one failing case never stops a study)."""
    t0 = time.perf_counter()
    try:
        status, error, summary = compute()
    except InfeasibleError as exc:
        status, error, summary = "infeasible", str(exc), None
    except EcostudyError as exc:
        status, error, summary = "failed", str(exc), None
    except Exception as exc:  # a bug in one case must not stop the study
        status, error, summary = "failed", f"{type(exc).__name__}: {exc}", None
    return {"key": case["key"], "status": status, "error": error, "summary": summary,
            "seconds": time.perf_counter() - t0}


def run_case(case):
    """Solve one case (a dict from :func:`ecostudy.study.expand`); never raises."""
    return outcome(case, lambda: _solve_case(case))


def _solve_case(case):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EcostudyWarning)  # shown once when the study was expanded
        train = train_from_schema(TrainFile.model_validate(case["train"]), case["scenario"])
    track = track_from_schema(TrackFile.model_validate(case["track"]))
    running_time, t_allout, fastest = case["running_time_s"], None, "optimal"
    if case["supplement_percent"] is not None and case["objective"] != "time":
        t_allout, fastest = _all_out_time(case, track, train)
        running_time = t_allout * (1 + case["supplement_percent"] / 100)
    timing = Timing(running_time=running_time, window=tuple(case["window_s"]) if case["window_s"] else None)
    structure = case_key({**{k: case[k] for k in _SCENARIO}, "weights": case["weights"]})
    r = solve_run(track, train, case["from"], case["to"], timing, objective=case["objective"],
                  points=case["points"], weights=tuple(case["weights"]), written=_WRITTEN, structure=structure)
    if fastest != "optimal":  # its running time is a supplement over an all-out run Ipopt did not prove
        r.summary[ALL_OUT_SOLVER] = fastest
    summary, status = r.summary, r.status
    if case["objective"] == "time" and not case["window_s"]:  # the scenario's all-out time: kept for its supplements
        _ALL_OUT[case_key({k: case[k] for k in _SCENARIO})] = (r.facts.running_time_s, r.facts.solver.status)
    if case.get("das"):
        summary["das"] = das_columns(r, case["das"], case["points"], case.get("das_time_limit_s", DAS_TIME_LIMIT_S))
        status = worst([status, advice_status(summary["das"])])
    with_all_out(summary, t_allout)
    if case.get("profile"):  # the speed profile, for a figure drawn from the store (a front's)
        summary["profile"] = {k: r.profile[k].tolist() for k in ("position_m", "speed_kmh")}
    return status.kind, status.reason or None, summary


def _serial(todo, task, arrived):
    yield from ((case, task(case)) for case in todo)


def _processes(todo, workers, task, arrived):
    """The cases in ``workers`` processes (interrupted: the workers stopped at once, their running
    cases lost). A worker that dies (killed for memory, a crash in a library) breaks its pool: the
    cases not finished run again in a new pool, and after a second break each alone, one after
    another, so that a case that kills its own worker is a failed result and the study goes on."""
    left = list(todo)
    for _ in range(2):
        if left:
            left = yield from _pooled(left, workers, task, arrived)
    for case in left:
        if (yield from _pooled([case], 1, task, arrived)):
            yield case, died(case)


def _pooled(cases, workers, task, arrived):
    """(case, result) of ``cases`` run in a pool of ``workers`` as they finish; returns the cases
    not finished when a worker died and broke the pool (none: every case finished)."""
    finished = set()
    with worker_pool(workers) as pool:
        futures = {pool.submit(task, case): case for case in cases}
        with arriving(futures, arrived):
            try:
                for future in as_completed(futures):
                    result = future.result()
                    finished.add(future)
                    yield futures[future], result
            except BrokenProcessPool:  # every case not finished by then failed with it
                for future in [f for f in futures if f not in finished and f.done() and f.exception() is None]:
                    finished.add(future)
                    yield futures[future], future.result()
    return [case for future, case in futures.items() if future not in finished]


def died(case):
    """The result of a case whose worker process died while it alone ran in it."""
    return outcome(case, lambda: ("failed", "its worker process died (killed by the system, e.g. out of memory, or a "
                                  "crash in a library): computed alone after two broken pools, it killed its own "
                                  "worker too", None))


def _dask(todo, address, task, arrived):
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise EcostudyError("--dask needs Dask: pip install 'ecostudy[dask]'") from None
    check_options(dask=address)
    try:
        client = Client(address, timeout=15)
    except (OSError, TimeoutError) as exc:
        raise InputError(problem("command line", "--dask", f"cannot reach the Dask scheduler at {address} ({exc})"))
    with client:
        futures = {client.submit(task, case, key=f"ecostudy-{case['key']}", pure=False): case
                   for case in todo}
        try:
            for future in dask_completed(futures):
                yield futures[future], future.result()
        except BaseException:  # interrupted: the cases finished on the cluster kept, the others cancelled
            arrived.extend((case, f.result()) for f, case in futures.items() if f.status == "finished")
            client.cancel(list(futures))
            raise


def execute(cases, store, task=run_case, workers=1, dask=None, retry_failed=False, progress=None, spread=None):
    """Run ``task`` (a pure function of a case dict returning a result dict, never raising) on every
    case not in ``store`` yet, serially, in ``workers`` processes or on a Dask scheduler, storing
    each result as it arrives; returns the counts. ``progress(done, failed, remaining, total)``.
    ``spread(todo, workers, task, arrived)``: how ``workers`` local processes run the cases (even one
    case) when not one case per process (:attr:`StudyKind.spread`).

    Interrupted (KeyboardInterrupt: SIGINT or SIGTERM, :mod:`ecostudy.core.interrupt`), the workers
    are stopped at once and every result that reached this process is stored (a case a worker
    finished whose result had not reached it yet is lost, and computed by the next run); raises
    :class:`~ecostudy.core.interrupt.Interrupted` with the counts."""
    finished = store.finished_keys(retry_failed=retry_failed)
    todo = [c for c in cases if c["key"] not in finished]
    counts = {"total": len(cases), "stored_before": len(cases) - len(todo), "computed": 0, "failed": 0}
    if workers < 1:
        raise EcostudyError("--workers must be at least 1")
    arrived = []  # the sources' (case, result) pairs that reached this process when interrupted
    if dask:
        source = _dask(todo, dask, task, arrived)
    elif workers > 1 and todo and (spread is not None or len(todo) > 1):
        source = (spread or _processes)(todo, workers, task, arrived)
    else:
        source = _serial(todo, task, arrived)
    stored = set()

    def keep(case, result):
        with held([]):  # a signal now is raised once the case is stored
            store.put(case, result)
            stored.add(case["key"])
            counts["computed"] += 1
            counts["failed"] += result["status"] in ("failed", "infeasible")
    try:
        for case, result in source:
            keep(case, result)
            if progress:
                progress(counts["computed"], counts["failed"], len(todo) - counts["computed"], len(todo))
    except KeyboardInterrupt:
        with held([]):
            source.close()  # interrupted here rather than in the source: it stops its workers and lists what arrived
            for case, result in arrived:
                if case["key"] not in stored:
                    keep(case, result)
        raise Interrupted(counts) from None
    finally:
        source.close()  # any other error: the workers stopped now, not when the source is collected
    return counts


def stored_rows(cases, path, task, workers=1, dask=None, retry_failed=False, progress=None, compute=None,
                spread=None):
    """Run ``task`` on the cases not in the store at ``path`` yet (:func:`execute`; only those of
    ``compute`` when given); returns (counts, the stored row of every case by key). ``stored_other``
    counts the results in the store under keys of no case of the study: other inputs, or other code
    (:func:`~ecostudy.studies.cases.code_version`), never reused."""
    store = Store(path)
    try:
        counts = execute(cases if compute is None else compute, store, task, workers, dask, retry_failed, progress,
                         spread)
        keys = [c["key"] for c in cases]
        counts["stored_other"] = len(store.keys() - set(keys))
        return counts, store.get(keys)
    finally:
        store.close()


class Expanded(NamedTuple):
    """A study file expanded by its kind: the output folder, the cases (dicts, each with its
    ``key`` (:func:`~ecostudy.studies.cases.case_key` of what changes the answer), ``study`` and
    ``scenario`` names and ``labels`` (the columns naming it in the table)) and tables of the expansion
    itself written beside the results (file name -> table, e.g. a library's ``skipped.csv``)."""

    output: Path
    cases: list
    inputs: dict = {}


@dataclass(frozen=True)
class StudyKind:
    """What makes a kind of study: ``expand(path)`` -> :class:`Expanded` (validated, before anything
    runs), ``task(case)`` -> a result dict (pure, picklable, never raising: wrap the work in
    :func:`outcome`), ``table(cases, rows)`` -> one row per case with ``status`` and ``reason``
    from the stored ``rows`` by case key (its ``attrs``, if any, go into ``summary.json``),
    optionally ``size`` (below), the table's file and its name in ``summary.json``."""

    expand: Callable[[Path], Expanded]
    task: Callable[[dict], dict]
    table: Callable[[list, dict], pd.DataFrame]
    size: Optional[Callable[[Path, list, int], None]] = None
    """``size(path, cases, workers)``: refuse (unless forced) a study estimated too big for one
    command (:func:`~ecostudy.core.budget.check_study`), after ``expand`` and before anything
    runs; None: unchecked as a whole (its runs still meet ``check_run`` where they build a model)."""
    table_file: str = "results.csv"
    table_name: str = "results"
    """The table's name in ``summary.json`` (``api.load(folder).tables[table_name]``)."""
    spread: Optional[Callable] = None
    """``spread(todo, workers, task, arrived)`` -> (case, result) pairs: how local worker processes run the
    cases instead of one case per process (a network study's strategies share one pool for their
    legs: :mod:`ecostudy.studies.legpool`); Dask still runs one case per task."""
    expand_into: Optional[Callable[[Path, Optional[Path]], Expanded]] = None
    """``expand_into(path, out)``, for a kind whose expansion computes something long (a reference
    or all-out run, a fleet's first runs): ``expand`` with ``out``, the output folder the command
    was given (None: the study's own), checked first (:func:`~ecostudy.io.writers.check_output_dir`);
    :func:`run_kind` calls it instead of ``expand``."""
    verdict: Optional[Callable[[pd.DataFrame], dict]] = None
    """``verdict(table)``: statuses of the study as a whole beside its cases' ({name: Status}; a
    front whose energy does not fall as the running time grows is flagged)."""


STUDY_KINDS: Registry[StudyKind] = Registry("study kind")


def _none(cases):
    return ()


class Draw(NamedTuple):
    """A kind's files beside its table (:func:`run_expanded`): ``write(output, cases, rows, table)``
    writes them and returns (file names, {table name: file name}); ``names(cases)``: the files it
    will write as far as they are known before any case is computed (its figures in the format
    asked), checked in the output folder with the table's."""

    write: Callable
    names: Callable[[list], Iterable[str]] = _none


class StudyRun(NamedTuple):
    """A study run by :func:`run_expanded`: its table, counts (``total``, ``stored_before``,
    ``computed``, ``failed``, ``not_ok``), output folder, cases and stored rows by case key."""

    table: pd.DataFrame
    counts: dict
    output: Path
    cases: list
    rows: dict


def run_kind(kind, path, workers=1, dask=None, retry_failed=False, out=None, progress=None, draw=None):
    """The one study engine: a study file of ``kind`` expanded into cases, then
    :func:`run_expanded` (``draw``: its files beside the table). Returns (table, counts, output folder)."""
    spec = kind_named(kind)
    expanded = spec.expand(Path(path)) if spec.expand_into is None else spec.expand_into(Path(path), out)
    return run_expanded(kind, expanded, path, workers, dask, retry_failed, out, progress, draw)[:3]


def kind_named(kind):
    """The registered :class:`StudyKind` ``kind``; an unknown one is one line (exit status 2)."""
    try:
        return STUDY_KINDS.get(kind)
    except KeyError as exc:
        raise InputError(problem("command line", "--kind", exc.args[0]))


def run_expanded(kind, expanded, where, workers=1, dask=None, retry_failed=False, out=None, progress=None,
                 draw=None, compute=None, spec=None, more=None):
    """A study of ``kind`` already expanded (from a study file, or from a command's options: ``where``
    names it): the cases not stored yet run (serially, in ``workers`` processes or on ``dask``,
    :func:`execute`), each stored as it arrives; the table of every stored case; the table's file
    and summary.json written, with the files and tables ``draw`` (a :class:`Draw`) writes and returns
    as (file names, {table name: file name}) (figures, a kind's other files); the files an
    earlier ``summary.json`` of the folder listed that this run did not write removed.
    ``progress(done, failed, remaining, total)`` after each case; ``compute``: only these cases
    computed now (the others' stored results still in the table; a case neither stored nor computed
    is ``missing`` there, and no result in ``summary.json``); ``spec``: the :class:`StudyKind` itself
    (default: the one registered as ``kind``); ``more``: statuses of runs the command made beside the
    cases (by name), part of the folder's status. Returns a :class:`StudyRun`."""
    spec = spec or kind_named(kind)
    if spec.size is not None and compute is None:  # too big: refused with its estimate (unless --force); a part
        # computed now (``compute``) is checked by its caller
        spec.size(Path(where), expanded.cases, workers)
    output = check_output_dir(out or expanded.output, (spec.table_file, "results.sqlite", *expanded.inputs,
                                                       *(draw.names(expanded.cases) if draw is not None else ())), kind)
    if expanded.cases:  # a folder holds one study's results: its tables and summary.json are the study's own
        check_one_study(output, expanded.cases[0]["study"])
    Store(output / "results.sqlite").close()  # the folder taken before a file is written (to the end: store.whole_command)
    for name, frame in expanded.inputs.items():
        write_csv(output / name, frame)
    def stopped(when, counts):  # an earlier run's summary.json (ok, N cases) would speak for a study not finished
        mark_stopped(output, f"stopped {when}; run the command again to finish", stored_counts(output / "results.sqlite", [
            c["key"] for c in expanded.cases]), study=str(where), computed_now=counts["computed"], stored_before=counts["stored_before"])
    try:
        counts, rows = stored_rows(expanded.cases, output / "results.sqlite", spec.task, workers, dask, retry_failed,
                                   progress, compute, spec.spread)
    except Interrupted as exc:
        stopped("before every case was computed", exc.counts)
        raise
    table = spec.table(expanded.cases, rows)
    stopped("while its files were written", counts)  # until this run's summary.json is: the tables are half rewritten
    write_csv(output / spec.table_file, table)
    drawn, tables = draw.write(output, expanded.cases, rows, table) if draw is not None else ([], {})
    results = [compute is None or k in rows for k in (c["key"] for c in expanded.cases)]  # left out: not results
    # a kind's table may list its cases in another order (a front's by running time), its index their order
    in_order = table.sort_index() if sorted(table.index) == list(range(len(table))) else table
    left = case_names([c for c, r in zip(expanded.cases, results) if not r])  # no result: the folder is not whole
    statuses = {**case_statuses([c for c, r in zip(expanded.cases, results) if r], in_order[results]),
                **{name: flagged(NOT_COMPUTED) for name in left},
                **(spec.verdict(table) if spec.verdict else {}), **(more or {})}
    earlier = files_listed(output)  # an earlier run's (this command's or `run --kind`'s): removed below if not this one's
    write_summary(output, kind, statuses, {spec.table_name: spec.table_file, **tables, **{
                  Path(name).stem: name for name in expanded.inputs}}, ["results.sqlite", *drawn], study=str(where),
                  computed_now=counts["computed"], stored_before=counts["stored_before"], **table.attrs)
    remove_unlisted(output, earlier)
    beside = more or {}  # runs the command made beside the cases (a front's weighted points): counted apart
    counts["not_ok"] = sum(not s.ok for k, s in statuses.items() if k not in beside)
    counts.update(beside=len(beside), beside_not_ok=sum(not s.ok for s in beside.values()))
    return StudyRun(table, counts, output, expanded.cases, rows)


def run_study(path, workers=1, dask=None, retry_failed=False, out=None, progress=None):
    """Run the cases of a study file that are not stored yet (:func:`run_kind` of ``run``);
    returns (table, counts, output folder)."""
    return run_kind("run", path, workers, dask, retry_failed, out, progress)


def expand_study(path):
    """A study file's cases (:func:`~ecostudy.studies.cases.expand`), a library's pairs left out
    beside them as ``skipped.csv``."""
    skipped = []
    _, output, cases = expand(path, skipped)
    return Expanded(output, cases, {"skipped.csv": pd.DataFrame(skipped)} if skipped else {})


def run_study_size(path, cases, workers=1):
    """Refuse (unless forced) a ``run`` study whose cases, shared among ``workers``, are estimated above the
    command's budget: each as ``solve`` (:func:`~ecostudy.studies.estimate.case_size`: its grid, its train's tables)."""
    sizes: dict = {}
    each = [(c, *case_size(c, sizes)) for c in cases]
    runs = [run_seconds(n, c.get("das"), c.get("das_time_limit_s", DAS_TIME_LIMIT_S), t) for c, n, t in each]
    check_study(path, "the study's cases", runs, workers, max((run_bytes(n, t) for _, n, t in each), default=0))


STUDY_KINDS.register("run", StudyKind(expand_study, run_case, study_table, run_study_size),
                     doc="single runs: a study file's scenarios x sweep, or a TTOBench library")
