"""The files of a run (``profile.csv``, ``summary.json``, ``speed.<format>``, ``advice.csv``) and of a
journey, each written atomically (a front's: :func:`ecostudy.report.studyfiles.front_files`)."""
import warnings
from functools import partial
from pathlib import Path

from ecostudy.analysis.export import advice_phases, fixed_step, missed_phases
from ecostudy.analysis.saved import rejudged, run_inputs
from ecostudy.core.budget import how_many
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.status import Status
from ecostudy.io.folder import write_summary
from ecostudy.io.results import WRITING, load_result
from ecostudy.io.writers import REPORT, TEMPORARY, check_output_dir, write_csv, write_json
from ecostudy.report import style
from ecostudy.report.drawer import apart
from ecostudy.report.html import write_html


def figures(out_dir, plot, drawings, out=style.Output()):
    """Write every figure of ``drawings`` ({stem: draw(path, fmt=, dpi=)}) as ``stem.<fmt>``
    (``style.write``) when ``plot``, else remove any earlier run's figures of those stems, so a
    folder never mixes the files of two runs. Returns the file names written."""
    if not plot:
        for stem in drawings:
            style.remove(out_dir, stem)
        return []
    return [style.write(out_dir, stem, draw, out) for stem, draw in drawings.items()]


def figures_meanwhile(drawer, out_dir, plot, drawings, out=style.Output()):
    """:func:`figures` drawn by ``drawer`` (a :class:`ecostudy.report.drawer.Drawer`, or None: here
    and now) while the caller goes on, each figure in a process of its own (``drawer.apart``: a
    run's two figures 0.44 CPU s one after the other); returns the function that waits for the file
    names."""
    if drawer is None or not plot:
        names = figures(out_dir, plot, drawings, out)
        return lambda: names
    return drawer.submit(apart, partial(style.write, out_dir), [(stem, draw, out) for stem, draw in drawings.items()])


def later(name, *args, **kwargs):
    """A figure of ``report.plots`` (``report.netplots`` for a network's) drawn as
    ``name(*args, path, ...)`` when it is written: matplotlib loads only in a process that draws.
    It pickles with its data (:mod:`ecostudy.report.drawer` sends it to a figure process)."""
    return partial(_draw, name, args, kwargs)


def _draw(name, args, kwargs, path, **more):
    if name in ("network_plot", "supply_plot"):
        from ecostudy.report import netplots as module
    else:
        from ecostudy.report import plots as module
    return getattr(module, name)(*args, path, **kwargs, **more)


RUN_FIGURES = ("speed", "energy")  # the figures of write_run, by stem
# what `ecostudy check` and `ecostudy export` add to a solve folder, of the run they read: a run
# written into the folder again removes them (a check.json of an 80 s run beside a 78 s profile),
# and its report, which would show the earlier run
DERIVED = (REPORT, "check.json", "profile_every_*.csv", "profile_every_*.json")
JOURNEY_FIGURE = "journey"  # of write_journey
# the status of a solve folder while its files are written (with io.results.WRITING): what it says
# where a write stopped midway (a full disk, a signal)
UNFINISHED = Status("failed", "its files were being written when the write stopped (an interrupted write?): "
                              "solve again")


def run_files(advised, plot, out=style.Output()):
    """The files :func:`write_run` writes besides ``summary.json`` and ``report.html``: what
    ``check_output_dir`` is to find writable, and not a folder."""
    return ("profile.csv", "inputs.json", *(("advice.csv",) if advised else ()), *out.filenames(RUN_FIGURES, plot))


def write_run(result, out_dir, plot=True, out=style.Output(), drawer=None, study=None, das=None):
    """A solve folder: ``inputs.json`` (``analysis.saved.run_inputs``: the files, stops, grid and
    timing, ``study`` and ``das`` as asked), ``profile.csv``, ``summary.json``, ``speed.<format>``,
    ``energy.<format>`` (the energy flow; figures in the format of ``out``, drawn by ``drawer`` while
    the tables are written when one is given), ``advice.csv`` and ``report.html`` of one run into
    ``out_dir``, checked first as ``ecostudy solve`` checks its ``--out`` (``check_output_dir``: not
    a file, writable, no other command's results there).

    All of the run or none of it: ``summary.json`` is first replaced by one marking the folder
    :data:`UNFINISHED` (``io.results.WRITING``), and written whole last, so a write that stops
    midway leaves a folder ``api.load``, ``check`` and ``export`` refuse, never the files of two
    runs read as one. A file that cannot be written (a full disk, a folder in its place) is one line
    naming it (exit status 2)."""
    out_dir = Path(out_dir)
    advised = result.das is not None and result.das.advice is not None  # advice that failed has no table
    inputs = run_inputs(result, study, das)
    check_output_dir(out_dir, run_files(advised, plot, out), "solve")
    facts, state = result.facts, "the folder is as it was"
    case = f"{facts.from_stop}-{facts.to_stop}"
    try:
        write_summary(out_dir, "solve", {case: UNFINISHED}, **{WRITING: True})
        state = "the folder is marked unfinished (api.load, check and export refuse it)"
        for pattern in DERIVED:  # of the run this one replaces
            for path in out_dir.glob(pattern):
                path.unlink(missing_ok=True)
        drawn = figures_meanwhile(drawer, out_dir, plot, dict(zip(RUN_FIGURES, (later("speed_plot", result),
                                                                                later("energy_plot", result)))), out)
        write_json(out_dir / "inputs.json", inputs)
        write_csv(out_dir / "profile.csv", result.profile)
        tables = {"profile": "profile.csv"}
        if advised:
            write_csv(out_dir / "advice.csv", result.das.advice)
            tables["advice"] = "advice.csv"
        write_summary(out_dir, "solve", {case: result.status}, tables, [*drawn(), "inputs.json"], **result.summary)
        state = "the run's tables and summary are written"
        stale(out_dir, advice=not advised, names={"advice": ["advice.csv"]})
        write_html(out_dir)
    except OSError as exc:
        raise InputError(problem(written(exc, out_dir), "", f"cannot write or replace it ({exc.strerror or exc}): "
                                 f"{state}; run again once it can be written")) from exc
    return out_dir


def written(exc, out_dir):
    """The output file an OSError of a write names: the file a temporary one (``.NAME<random>.tmp``,
    ``io.writers.atomic_write``) was to become, else the one named, else the folder."""
    name = exc.filename2 or exc.filename
    if not name:
        return out_dir
    path = Path(name)
    return path.with_name(path.name[1:-12]) if TEMPORARY.fullmatch(path.name) else path  # "." NAME, 8 random, ".tmp"


def stale(out_dir, names, **drop):
    """Remove files an earlier run left that this one does not write (``names[kind]`` where
    ``drop[kind]``), so a folder never mixes the files of two runs."""
    for kind, files in names.items():
        if drop.get(kind):
            for name in files:
                (Path(out_dir) / name).unlink(missing_ok=True)


def write_journey(table, totals, results, out_dir, title, passing=(), plot=True, out=style.Output()):
    """``journey.csv``, ``journey_totals.csv``, ``summary.json`` and ``journey.<format>`` of a journey's
    distributions (every segment's run re-simulated: ``verified``; its ``status`` the run's own: Ipopt's
    end and the re-simulation)."""
    out_dir = Path(out_dir)
    write_csv(out_dir / "journey.csv", table)
    write_csv(out_dir / "journey_totals.csv", totals)
    drawn = figures(out_dir, plot, {JOURNEY_FIGURE: later("journey_plot", results, title=title, passing=passing,
                                                          statuses=dict(zip(totals["distribution"], totals["status"])))},
                    out)
    statuses = {f"{r['distribution']} {r['from']}-{r['to']}": Status.parse(r["status"]) for _, r in table.iterrows()}
    write_summary(out_dir, "journey", statuses, {"segments": "journey.csv", "totals": "journey_totals.csv"},
                  drawn, title=title)
    write_html(out_dir)
    return out_dir


EXPORT_UNITS = {"time_s": "s", "position_m": "m from the departure stop along the run (not the track's kilometrage)", "speed_kmh": "km/h", "speed_mps": "m/s",
                "handle": "-1 (full braking) to 1 (full traction)", "advice_mode": "",
                "advice_handle": "-1 to 1", "advice_target_speed_kmh": "km/h (cruise modes)"}


MAX_EXPORT_ROWS = 1_000_000  # a run every 1 ms for 15 min; a step below was a typo (5.8 TiB asked for at 1e-10 s)


def write_fixed_step(result_dir, time_step_s=None, distance_step_m=None):
    """The run of a solve folder every ``time_step_s`` or ``distance_step_m`` (``analysis.export``),
    as ``profile_every_<step>.csv`` and ``.json`` beside it (the CSV: the rows and the run's status in a
    last column ``status``; the JSON: the run with its status, units, step, rows). Returns (table, csv path, json path, the run's :class:`~ecostudy.core.status.Status`)."""
    saved = load_result(result_dir)
    step = f"{time_step_s:g}s" if time_step_s is not None else f"{distance_step_m:g}m"
    csv, js = (Path(result_dir) / f"profile_every_{step}.{ext}" for ext in ("csv", "json"))
    check_output_dir(result_dir, (csv.name, js.name))
    span, unit = (saved.trajectory.time[-1], "s") if time_step_s is not None else (saved.trajectory.nodes[-1], "m")
    rows = float(span) / (time_step_s if time_step_s is not None else distance_step_m) + 2
    if rows > MAX_EXPORT_ROWS:
        raise InputError(problem("command line", "--every", f"a step of {time_step_s or distance_step_m:g} {unit} over "
                                 f"the run's {span:.0f} {unit} is {how_many(rows)} rows, above the {MAX_EXPORT_ROWS:,} "
                                 f"exported (a step of at least {float(span) / MAX_EXPORT_ROWS:.2g} {unit})"))
    judged = rejudged(saved, result_dir)  # the run's status judged again, not taken from its summary
    table = fixed_step(saved.trajectory, saved.handle, time_step_s, distance_step_m, saved.advice)
    phases = (saved.summary.get("regimes") or {}).get("runs") or []
    if saved.advice is not None and len(saved.advice):  # the advised modes too: what a DAS shows the driver
        phases = [*phases, *advice_phases(saved.advice, float(saved.trajectory.nodes[-1]))]
    missed = missed_phases(phases, table["position_m"].to_numpy())
    if missed:  # the samples are right; an on-board system reading them never sees these phases
        warnings.warn(f"the export every {step} has no row in {len(missed)} of the run's {len(phases)} phases "
                      f"({', '.join(missed[:3])}" + (f" and {len(missed) - 3} more" if len(missed) > 3 else "")
                      + "): a finer step shows them", EcostudyWarning, stacklevel=2)
    status = judged.status
    write_csv(csv, table.assign(status=str(status)))  # the run's status on every row: a reader of the CSV alone sees it
    run = {**{k: saved.summary.get(k) for k in ("track", "train", "from", "to", "running_time_s")}, "status": str(status)}
    write_json(js, {"run": run,
                    "step": {"time_s": time_step_s} if time_step_s is not None else {"distance_m": distance_step_m},
                    "units": {c: u for c, u in EXPORT_UNITS.items() if c in table}, "phases_without_a_row": missed,
                    "rows": table.to_dict("records")})
    return table, csv, js, status
