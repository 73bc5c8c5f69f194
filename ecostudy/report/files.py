"""The files of a run (``profile.csv``, ``summary.json``, ``speed.<format>``, ``advice.csv``) and of a
journey, each written atomically (a front's: :func:`ecostudy.report.studyfiles.front_files`)."""
import warnings
from functools import partial
from pathlib import Path

from ecostudy.analysis.export import advice_phases, fixed_step, missed_phases
from ecostudy.analysis.saved import rejudged
from ecostudy.core.budget import how_many
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.status import Status
from ecostudy.io.folder import write_summary
from ecostudy.io.results import load_result
from ecostudy.io.writers import REPORT, check_output_dir, write_csv, write_json
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
# written into the folder again removes them (a check.json of an 80 s run beside a 78 s profile)
# of the run a new one replaces, gone before its profile is written: what was read off it (its check,
# its exports) and its report, which would show the earlier run beside a part of the new one's files
# if a write fails midway (a full disk)
DERIVED = ("check.json", "profile_every_*.csv", "profile_every_*.json", REPORT)
JOURNEY_FIGURE = "journey"  # of write_journey


def write_run(result, out_dir, plot=True, out=style.Output(), drawer=None, files=()):
    """``profile.csv``, ``summary.json``, ``speed.<format>``, ``energy.<format>`` (the energy flow; figures in
    the format of ``out``, drawn by ``drawer`` while the tables are written when one is given) and
    ``advice.csv`` of one run into ``out_dir``; ``files``: others the caller wrote there, listed too."""
    out_dir = Path(out_dir)
    for pattern in DERIVED:  # of the run this one replaces: gone before its profile is
        for path in out_dir.glob(pattern):
            path.unlink(missing_ok=True)
    drawn = figures_meanwhile(drawer, out_dir, plot, dict(zip(RUN_FIGURES, (later("speed_plot", result),
                                                                            later("energy_plot", result)))), out)
    write_csv(out_dir / "profile.csv", result.profile)
    tables = {"profile": "profile.csv"}
    advised = result.das is not None and result.das.advice is not None  # advice that failed has no table
    if advised:
        write_csv(out_dir / "advice.csv", result.das.advice)
        tables["advice"] = "advice.csv"
    facts = result.facts
    write_summary(out_dir, "solve", {f"{facts.from_stop}-{facts.to_stop}": result.status}, tables,
                  [*drawn(), *files], **result.summary)
    stale(out_dir, advice=not advised, names={"advice": ["advice.csv"]})
    write_html(out_dir)
    return out_dir


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
