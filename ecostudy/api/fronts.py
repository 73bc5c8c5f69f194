"""Studies over one segment or one journey into an output folder: the commands ``pareto``,
``compare`` and ``journey`` as functions (the command line only parses and prints).
"""
import warnings
from pathlib import Path
from time import perf_counter
from typing import Callable, Optional

from ecostudy.api.arguments import spelled
from ecostudy.api.outcome import Report, counts_line, listed, reported, shown
from ecostudy.api.single import timing_source
from ecostudy.core import units
from ecostudy.core.defaults import FRONT_POINTS, RUN_POINTS
from ecostudy.core.errors import EcostudyWarning, FieldError, InfeasibleError, InputError, problem
from ecostudy.io.documents import aliased
from ecostudy.io.loaders import check_fits, check_stop_list, load_track, load_train, read_timetable, timing_from_timetable
from ecostudy.io.timetable import journey_plan, name_stops
from ecostudy.io.store import check_one_study, whole_command
from ecostudy.io.writers import check_output_dir, default_output
from ecostudy.report.files import JOURNEY_FIGURE, write_journey
from ecostudy.report.html import write_html
from ecostudy.report.studyfiles import FRONT_FIGURES, compare_figures, front_files
from ecostudy.report.style import output
from ecostudy.studies.batch import Expanded, run_expanded
from ecostudy.studies.compare import check_timing, compare_cases
from ecostudy.studies.journey import journey
from ecostudy.studies.options import (case_from, check_options, das_limit, no_windows, only_one, output_folder, study_name,
                                      timing_of)
from ecostudy.studies.front import front_cases
from ecostudy.studies.pareto import weighted_points, weighted_statuses
from ecostudy.studies.estimate import grid_nodes, table_points
from ecostudy.studies.sizes import check_front, check_journey
from ecostudy.studies.workers import every_core

FRONT_COLUMNS = ["running_time_s", "supplement_pct", "traction_energy_kWh", "net_energy_kWh", "saving_vs_all_out_pct",
                 "marginal_saving_kWh_per_s", "coasting_share_pct", "regime_sequence"]
Progress = Callable[[int, int, int, int], None]  # progress(done, failed, remaining, total)
DAS_COLUMNS = ["das_traction_energy_kWh", "das_gap_to_ato_on_time_pct", "das_mode_changes"]


def beside(st, suffix: str, default: str) -> Path:
    """The default folder of a study's second command: the study's output with ``suffix``."""
    return st.output.parent / (st.output.name + suffix) if st is not None else default_output(default)


@spelled
@whole_command()
def pareto_folder(study: Optional[Path] = None, track: Optional[Path] = None, train: Optional[Path] = None,
                  from_stop: Optional[str] = None, to_stop: Optional[str] = None, count: int = 20,
                  supplement_max: float = 40.0, points: Optional[int] = None, workers: Optional[int] = None,
                  out: Optional[Path] = None, plot: bool = True, weighted: int = 0, das: Optional[str] = None,
                  das_time_limit: Optional[float] = None, fig_format: str = "png", dpi: Optional[float] = None,
                  dask: Optional[str] = None, retry_failed: bool = False, *,
                  progress: Optional[Progress] = None) -> Report:
    """``ecostudy pareto``: energy against running time, ``count`` points from the all-out run to
    ``supplement_max`` [%] over it (epsilon constraint) and a study file's own running time,
    optionally ``weighted`` weighted-sum points
    (Yazhemsky 2017, eq. 4.1a) and the driver-advice front ``das`` at every point; each point a case
    of the study kind ``pareto`` (:mod:`ecostudy.studies.front`), stored in ``results.sqlite`` and
    resumed, over ``workers`` processes (every core by default) or a Dask scheduler."""
    figures, workers, started = output(fig_format, dpi), every_core(workers), perf_counter()
    check_options(count=count, supplement_max=supplement_max, points=points, workers=workers, weighted=weighted,
                  das_time_limit=das_time_limit, dask=dask)
    trk, trn, f, t, k, st, (train_doc, track_doc) = case_from(study, track, train, from_stop, to_stop, points,
                                                              "pareto")
    no_windows(st, "pareto", study)
    das_time_limit = das_limit(das, das_time_limit)
    cases = front_cases(train_doc, track_doc, f, t, count, supplement_max * units.PERCENT, k or FRONT_POINTS,
                        study_name(st, "pareto", track, train, f, t), das, das_time_limit,
                        timing=st.timing if st is not None else None)
    out_dir = output_folder(out, beside(st, "_pareto", "pareto"))
    asked = ("pareto_weighted.csv",) if weighted else ()
    check_output_dir(out_dir, ("pareto.csv", "pareto.json", "results.sqlite", *asked,
                               *figures.filenames(FRONT_FIGURES, plot)), "pareto")
    check_one_study(out_dir, cases[0]["study"])  # before the weighted points are solved
    check_front("command line", len(cases), grid_nodes(trk, trn, f, t, k or FRONT_POINTS), workers, das, das_time_limit,
                table_points(trn))  # refused (unless --force)
    extra = weighted_points(trk, trn, f, t, count=weighted, points=k or FRONT_POINTS) if weighted else None
    ran = run_expanded("pareto", Expanded(out_dir, cases), study or "command line", workers, dask, retry_failed,
                       progress=progress, draw=front_files(plot, figures, extra, workers, started),
                       more=weighted_statuses(extra) if extra is not None else None)
    write_html(out_dir)
    table, meta = ran.table, ran.table.attrs
    study_col = ["is_study_time"] if table["is_study_time"].any() else []
    lines = [shown(table, FRONT_COLUMNS + study_col + (DAS_COLUMNS if das is not None else []) + ["status"], blank=True)]
    if das is not None:
        d = meta["das"]
        gaps = "no gap read off a run not ok"
        if d["ok"]:
            low, high = (units.number(d[f"{end}_gap_on_time_pct"], ".2f") for end in ("min", "max"))
            gaps = f"gap to ATO on time of the ok ones {low} to {high} %"
        lines.append(f"DAS {d['method']}: {d['solved']} of {d['points']} points solved, {d['ok']} ok; {gaps}; "
                     f"monotone: {d['monotone']}")
    five, ten = (f"saves {units.number(v, '.1f')} %" if v is not None else "not on the front"
                 for v in (meta[f"saving_at_{p}_pct_supplement_pct"] for p in (5, 10)))
    used = table[table["supplement_pct"].round(4).isin([0.0, 5.0, 10.0]) & ~table["is_study_time"]]  # these savings' points
    trusted = "" if used["verified"].eq(True).all() and (used["solver_status"] == "optimal").all() else \
        ": points not ok among them, read their status"
    lines.append(f"all-out {meta['all_out_time_s']:.2f} s; +5 % {five}, +10 % {ten} (of the all-out traction energy"
                 f"{trusted})")
    if "study_running_time_s" in meta:
        lines.append(study_time_line(meta))
    lines.append(f"monotone: {meta['monotone']}, all optimal: {meta['all_optimal']}, all verified: "
                 f"{meta['all_verified']}; {perf_counter() - started:.1f} s")
    return reported(out_dir, lines + [counts_line(ran.counts, "points"), "outputs " + listed(out_dir)])


def study_time_line(meta: dict) -> str:
    """The study's own running time on its front, as the printed summary says it."""
    if meta["study_traction_energy_kWh"] is None:
        return f"the study's running time: {meta['study_status']}"
    return (f"the study's running time {meta['study_running_time_s']:.2f} s: "
            f"{meta['study_traction_energy_kWh']:.3f} kWh traction, saves "
            f"{units.number(meta['study_saving_vs_all_out_pct'], '.1f')} % of the all-out traction energy")


@spelled
@whole_command()
def compare_folder(study: Optional[Path] = None, track: Optional[Path] = None, train: Optional[Path] = None,
                   from_stop: Optional[str] = None, to_stop: Optional[str] = None, time: Optional[float] = None,
                   supplement: Optional[float] = None, points: Optional[int] = None, out: Optional[Path] = None,
                   plot: bool = True, fig_format: str = "png", dpi: Optional[float] = None,
                   workers: Optional[int] = None, dask: Optional[str] = None, retry_failed: bool = False, *,
                   progress: Optional[Progress] = None) -> Report:
    """``ecostudy compare``: the strategies side by side for one running time [s] or supplement [%],
    every one scored by the same independent simulator; each strategy a case of the study kind
    ``compare`` (:mod:`ecostudy.studies.compare`), stored in ``results.sqlite`` and resumed, over
    ``workers`` processes (every core by default) or a Dask scheduler."""
    figures, workers = output(fig_format, dpi), every_core(workers)
    check_options(time=time, supplement=supplement, points=points, workers=workers, dask=dask)
    only_one(time=time, supplement=supplement)
    _, _, f, t, k, st, (train_doc, track_doc) = case_from(study, track, train, from_stop, to_stop, points, "compare")
    no_windows(st, "compare", study)
    if time is not None or supplement is not None:
        timing = timing_of(time, supplement)
    elif st is not None:
        timing = st.timing
    else:
        raise InputError(problem("command line", "--time", "give --time or --supplement"))
    cases = compare_cases(train_doc, track_doc, f, t, timing, k or RUN_POINTS,
                          study_name(st, "compare", track, train, f, t))
    check_timing(cases[0], *timing_source(study, st, time, supplement, None))
    out_dir = output_folder(out, beside(st, "_compare", "compare"))
    ran = run_expanded("compare", Expanded(out_dir, cases), study or "command line", workers, dask, retry_failed,
                       progress=progress, draw=compare_figures(plot, figures))
    write_html(out_dir)
    return reported(out_dir, [shown(ran.table), counts_line(ran.counts, "strategies"), "outputs " + listed(out_dir)])


def associated_track(tt, path: Optional[Path]) -> Path:
    """The track file a timetable names (TTOBench 'associated track'), JSON or YAML, looked for beside
    it, in a sibling ``tracks/`` folder (TTOBench's layout) and in ``../../tracks/`` (this
    repository's: ``studies/timetables/`` beside ``tracks/``)."""
    if tt is None or tt.track is None or path is None:
        raise InputError(problem("command line", "--track", "missing (the timetable names no track)"))
    here = Path(path).resolve().parent
    for folder in (here, here.parent / "tracks", here.parent.parent / "tracks"):
        for candidate in (folder / f"{tt.track}.json", folder / f"{tt.track}.yaml"):
            if candidate.is_file():
                return candidate
    raise InputError(problem(path, "metadata.associated track", f"track '{tt.track}' not found beside the "
                             "timetable, in ../tracks/ or ../../tracks/; give --track"))


@spelled
def journey_folder(train: Path, track: Optional[Path] = None, stops: Optional[str] = None,
                   time: Optional[float] = None, supplement: Optional[float] = None,
                   timetable: Optional[Path] = None, dwell: float = 0.0, points: int = FRONT_POINTS, workers: int = 1,
                   out: Optional[Path] = None, plot: bool = True, fig_format: str = "png",
                   dpi: Optional[float] = None, *, progress: Optional[Progress] = None) -> Report:
    """``ecostudy journey``: a journey's total running time [s] or supplement [%] spread over its
    segments (equal marginal saving against the same percentage), or a timetable's times."""
    figures = output(fig_format, dpi)
    check_options(time=time, supplement=supplement, dwell=dwell, points=points, workers=workers)
    tt, aliases = read_timetable(timetable) if timetable is not None else (None, {})
    trk, trn = load_track(track if track is not None else associated_track(tt, timetable)), load_train(train)
    check_fits(train, trn, trk)
    scheduled, plan = None, None
    listed_in: tuple[str | Path, str] = ("command line", "--stops")  # where the stops came from
    if tt is not None and not tt.stops:  # a timetable of one supplement: the journey's --supplement
        if time is not None or supplement is not None:
            raise InputError(problem("command line", "--timetable", f"{timetable} gives the supplement "
                                     f"({tt.supplement_percent:g} %): no --time or --supplement beside it"))
        supplement, tt = tt.supplement_percent, None
    if tt is not None and timetable is not None:
        if stops or time is not None or supplement is not None:
            raise InputError(problem("command line", "--timetable", "a timetable with stop times replaces --stops, "
                                     "--time and --supplement"))
        tt, trk = name_stops(tt, trk, timetable, aliases)
        names, listed_in = [str(row.stop) for row in tt.stops], (timetable, aliased("stops", aliases))  # named by name_stops
        if tt.windowed:
            plan = journey_plan(tt, trk, timetable, dwell, aliases)
        else:
            scheduled = [timing_from_timetable(tt, a, b, timetable, dwell).running_time
                         for a, b in zip(names, names[1:])]
        time, supplement = None, None
    else:
        if dwell:  # the journey's clock is its running times alone
            warnings.warn(problem("command line", "--dwell", "applies at the stops of a --timetable that give no "
                                  "dwell: unused without one"), EcostudyWarning, stacklevel=2)
        names = list(trk.stops) if stops is None else [n.strip() for n in stops.split(",")]
    check_stop_list(trk, names, *listed_in)
    if scheduled is None and plan is None and (time is None) == (supplement is None):
        raise InputError(problem("command line", "--time/--supplement",
                                 "give one total running time or supplement, or --timetable"))
    check_journey(timetable or "command line", [grid_nodes(trk, trn, a, b, points) for a, b in zip(names, names[1:])],
                  workers, splits=4 + (scheduled is not None) + (plan is not None), whole=1 + (plan is not None),
                  tables=table_points(trn))  # too big: refused (unless --force)
    out_dir = check_output_dir(output_folder(out, default_output("journey")),
                               ("journey.csv", "journey_totals.csv", *figures.filenames([JOURNEY_FIGURE], plot)),
                               "journey")
    try:
        table, totals, results, _ = journey(trk, trn, names, total_time=time,
                                            supplement=None if supplement is None else supplement * units.PERCENT,
                                            points=points, workers=workers, scheduled=scheduled, plan=plan,
                                            progress=progress)
    except FieldError as exc:  # a timetable's times no run keeps: the timetable's fields, by name
        raise exc.in_file(timetable, aliased(exc.field, aliases)) from None
    except InfeasibleError as exc:  # a total time no journey keeps: the option, by name
        if time is None:
            raise
        raise InfeasibleError([problem("command line", "--time", p) for p in exc.problems]) from None
    passing = []
    if plan is not None:  # timing points along the journey (segment lengths from the first split)
        start = 0.0
        for windows, run in zip(plan.windows, next(iter(results.values()), [])):
            passing += [(start + w.distance, None if w.max_speed is None else units.to_kmh(w.max_speed))
                        for w in windows]
            start += run.facts.distance_m
    write_journey(table, totals, results, out_dir, f"{trn.name}: {' - '.join(names)}", passing, plot=plot,
                  out=figures)
    return reported(out_dir, [shown(table), shown(totals), "outputs " + listed(out_dir)])
