"""`ecostudy calibrate` and `ecostudy validate`: logged runs read and checked, the calibration or the
validation computed (:mod:`ecostudy.calibration`), and their files written.

calibrate writes ``summary.json`` (status, the estimates with their 95 % intervals, the
identifiability report, residual statistics), ``parameters.csv``, ``residuals.csv``,
``<train>_calibrated.yaml`` (the train file with the identified parameters
replaced, its source naming the logs and the fit) and, when asked, ``savings.csv`` (the optimum for
each logged running time against the logged energy, with the calibration's band). validate writes ``validate.csv`` and
``summary.json``. The command line draws ``residuals.<format>`` and ``validate.<format>``
(:mod:`ecostudy.report.calplots`), whose names each is given (``figures``) to check and list them.
"""
import warnings
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd

from ecostudy import __version__
from ecostudy.calibration.estimate import MIN_BOOTSTRAP_LOGS, calibrate_logs
from ecostudy.calibration.fit import DEFAULT_FIT, PARAMETERS
from ecostudy.calibration.savings import savings
from ecostudy.calibration.validate import validate_log
from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.io.documents import split_selector
from ecostudy.io.loaders import check_fits, load_track, load_train
from ecostudy.io.logfile import check_on_track, check_traction_sign, load_log
from ecostudy.io.logoverlap import overlap
from ecostudy.io.trainout import calibrated_document, write_train
from ecostudy.core.status import Status, calibrated, flagged
from ecostudy.io.folder import write_summary
from ecostudy.io.writers import check_output_dir, write_csv

# the files each writes beside its figures (``figures``: their names in the format of ``--format``)
CALIBRATE_FILES = ("summary.json", "parameters.csv", "residuals.csv")
VALIDATE_FILES = ("summary.json", "validate.csv")


def parse_fit(text):
    """The parameter names of ``--fit a,b,c`` (None, the option not given: the default set); unknown
    names, a name given twice and no name at all (``--fit ''``, ``--fit ,``) refused in one line."""
    names = [n.strip() for n in (",".join(DEFAULT_FIT) if text is None else text).split(",") if n.strip()]
    unknown = [n for n in names if n not in PARAMETERS]
    if unknown or not names or len(set(names)) != len(names):
        what = (f"unknown parameter '{unknown[0]}'" if unknown else "no parameter named: name at least one, or leave "
                "--fit out for the default set" if not names else "give each parameter once")
        raise InputError(problem("command line", "--fit", f"{what} (known: {', '.join(PARAMETERS)})"))
    return names


def check_fit_train(names, train, train_path):
    """A parameter in ``names`` that the train file does not have refused in one line: a regeneration
    efficiency without ``regenerative_braking`` (nothing in the logs could inform it, and its prior 0
    leaves no scale to report it against)."""
    if "regeneration_efficiency" in names and train.regeneration is None:
        raise InputError(problem("command line", "--fit", f"regeneration_efficiency: the train file {train_path} has "
                                 "no regenerative_braking, so there is no regeneration efficiency to fit (leave it "
                                 "out of --fit, or add regenerative_braking to the train file)"))


def _loaded(load, path, log, field):
    """``load(path)``; a problem with a file the log's header named (``log``, else None) is said as
    the header's: ``LOG: header: train: FILE: what is wrong``."""
    try:
        return load(path)
    except InputError as exc:
        if log is None:
            raise
        raise InputError([problem(log.path or log.name, f"header.{field}", line) for line in exc.problems]) from None


def _header_file(log, field):
    """The file a log's header names in ``field`` (resolved, relative to the log), or None."""
    name = getattr(log.header, field)
    return None if name is None else split_selector(Path(log.path or ".").parent / name)[0].resolve()


def check_header_file(logs, field, path, given):
    """Logs whose headers name another ``field`` file than ``path`` (the one used): refused when the
    file is the first log's (runs of other trains or lines pooled into one fit, or replayed on
    the first's line); with the file ``given`` on the command line, each such log warned of."""
    used = split_selector(Path(path))[0].resolve()
    for log in logs:
        named = _header_file(log, field)
        if named is None or named == used:
            continue
        if not given:
            raise InputError(problem(log.path or log.name, f"header.{field}", f"names {named}, but the first log's "
                                     f"names {used}: one calibration is one train on one line (give --{field} to "
                                     "replay every log on one)"))
        warnings.warn(problem(log.path or log.name, f"header.{field}", f"names {named}; replayed on --{field} "
                              f"{used} as asked"), EcostudyWarning, stacklevel=2)


def _given_twice(shared, other):
    """The line refusing a log that shares ``shared``'s samples with the log ``other``."""
    clock = (f", its clock {abs(shared.offset):g} s {'later' if shared.offset > 0 else 'earlier'}"
             if shared.offset else "")
    if shared.whole:
        return (f"the same samples as {other}{clock} (time from each log's start, positions and speeds in SI, "
                "within the last digits the files write): one logged run given twice would narrow every "
                "interval as if it were two")
    return (f"its rows {shared.first + 1}-{shared.first + shared.rows} are the samples of {other}'s rows "
            f"{shared.other_first + 1}-{shared.other_first + shared.rows}{clock} (one logged run exported "
            "twice, trimmed): fitted as two, the shared samples would narrow every interval as if they were "
            "two runs")


def load_inputs(log_paths, train_path, track_path):
    """(logs, track, train, track path, train path): the logs read and checked, the track and train
    given, or else the ones the first log's header names; every log's positions on the track and the
    sign of its traction (beyond what the track's gradients give)."""
    logs = [load_log(p) for p in log_paths]
    given_track, given_train = bool(track_path), bool(train_path)
    names = [log.name for log in logs]
    if len(set(names)) != len(names):
        raise InputError(problem("command line", "LOG", "two logs with the same file name: "
                                 + ", ".join(sorted({n for n in names if names.count(n) > 1}))))
    for i, log in enumerate(logs):  # one run given twice narrows every interval as if it were two
        for other in logs[:i]:
            shared = overlap(log, other)
            if shared is not None:
                raise InputError(problem(log.path or log.name, "", _given_twice(shared, other.path or other.name)))
    track_path = Path(track_path) if track_path else logs[0].named("track")
    train_path = Path(train_path) if train_path else logs[0].named("train")
    for field, path, given in (("track", track_path, given_track), ("train", train_path, given_train)):
        check_header_file(logs, field, path, given)
    track = _loaded(load_track, track_path, None if given_track else logs[0], "track")
    train = _loaded(load_train, train_path, None if given_train else logs[0], "train")
    check_fits(train_path, train, track)
    for log in logs:
        check_on_track(log, track)
        check_traction_sign(log, track)
    return logs, track, train, track_path, train_path


def calibrate_study(log_paths, train_path, track_path, fit, out, draws=200, saving_draws=None, figures=()):
    """Calibrate ``fit`` (text, ``a,b,c``) from the logs and write the outputs to ``out``; with
    ``saving_draws`` (a count) also the savings against the logged driving (``savings.csv``)."""
    names = parse_fit(fit)
    logs, track, train, track_path, train_path = load_inputs(log_paths, train_path, track_path)
    check_fit_train(names, train, train_path)
    calibrated = Path(out) / f"{train_path.stem}_calibrated.yaml"
    asked = ("savings.csv",) if saving_draws is not None else ()
    out = check_output_dir(out, (*CALIBRATE_FILES, calibrated.name, *asked, *figures), "calibrate")
    result = calibrate_logs(logs, track, train, names, draws)
    identified = [n for n in names if n not in set(result.table.loc[~result.table["identifiable"], "name"])]
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d")
    estimates = ", ".join(f"{r.name} {r.estimate:.5g} +- {r.high - r.estimate:.2g} {r.unit}"
                          for r in result.table.itertuples() if r.identifiable)
    warning = "" if result.status == "ok" else f"NOT OK, calibration flagged: {result.reason}."
    provenance = (f"Calibrated by ecostudy {__version__} calibrate on {stamp} from {len(logs)} logged run(s) "
                  f"({', '.join(log.name for log in logs)}) on track '{track.name}': {estimates} "
                  f"(95 % intervals); held at this file's values: "
                  f"{', '.join(n for n in names if n not in identified) or 'none'}.")
    write_train(calibrated, calibrated_document(train_path, result.train, identified, provenance, warning,
                                                "" if result.status == "ok" else result.reason))
    try:  # a train file the tool would refuse (a fitted value past its field's bounds) is not left behind
        load_train(calibrated)
        written = [calibrated.name]
    except InputError as exc:
        calibrated.unlink()
        written, refused = [], f"{calibrated.name} not written: {exc.problems[0]}"
    write_csv(out / "parameters.csv", result.table)
    write_csv(out / "residuals.csv", result.residuals)
    summary = {"command": "calibrate", "logs": [str(p) for p in log_paths], "train": str(train_path),
               "track": str(track_path), "fitted": names,
               "method": "least squares (scipy least_squares) on the replayed energy balance, whitened by a scalar "
                         "Kalman filter; 95 % intervals (low, high) from the Jacobian; boot_low, boot_high from a "
                         f"bootstrap over logs ({MIN_BOOTSTRAP_LOGS} logs or more): the spread between logs, not a "
                         "confidence interval",
               "parameters": result.table.replace({np.nan: None}).to_dict("records"),
               "quality": result.quality, "checks": result.checked,
               "calibrated_train": str(calibrated) if written else None,
               "outputs": [*CALIBRATE_FILES, *written]}
    if saving_draws is not None:
        table = pd.concat([savings(log, track, result, saving_draws) for log in logs], ignore_index=True)
        write_csv(out / "savings.csv", table)
        summary["savings"] = table.to_dict("records")
        summary["outputs"].append("savings.csv")
    tables = {"parameters": "parameters.csv", "residuals": "residuals.csv",
              **({"savings": "savings.csv"} if saving_draws is not None else {})}
    statuses = {"calibration": Status.parse(result.status, result.reason or ""),
                **({} if written else {"calibrated train": flagged(refused)}),
                **(savings_statuses(table) if saving_draws is not None else {})}
    write_summary(out, "calibrate", statuses, tables, [*written, *figures], **summary)
    return result, summary


def savings_statuses(table):
    """The status of every row of a savings table (``savings.csv``), named ``savings LOG run N``."""
    return {f"savings {r.log} run {r.run}": Status.parse(r.status) for r in table.itertuples()}


def validate_study(log_path, train_path, track_path, out, energy_tolerance=0.05, time_tolerance=0.05, figures=()):
    """Replay one log on the train file's model and write the differences per run to ``out``."""
    logs, track, train, track_path, train_path = load_inputs([log_path], train_path, track_path)
    out = check_output_dir(out, (*VALIDATE_FILES, *figures), "validate")
    table = validate_log(logs[0], track, train, energy_tolerance, time_tolerance)
    write_csv(out / "validate.csv", table)
    flagged = table[table["status"] != "ok"]
    logged, model = table["logged_traction_kWh"].sum(), table["model_traction_kWh"].sum()
    summary = {"command": "validate", "reason": "; ".join(f"run {r.run}: {r.reason}" for r in flagged.itertuples()),
               "log": str(log_path), "train": str(train_path),
               "track": str(track_path), "runs": table.replace({np.nan: None}).to_dict("records"),
               "logged_traction_kWh": logged, "model_traction_kWh": model,
               "traction_difference_pct": 100 * (model - logged) / logged if logged > 0 else None,
               "tolerances_pct": {"energy": 100 * energy_tolerance, "time": 100 * time_tolerance}}
    statuses = {f"run {r.run}": Status.parse(r.status, r.reason if isinstance(r.reason, str) else "")
                for r in table.itertuples()}
    lent = calibrated(train.calibration_reason)  # a train of a flagged calibration: its replays are not ok either
    if not lent.ok:
        statuses["train"] = lent
        summary["reason"] = "; ".join(filter(None, [summary["reason"], f"train: {lent.reason}"]))
    write_summary(out, "validate", statuses, {"validate": "validate.csv"}, figures, **summary)
    summary["status"] = "flagged" if len(flagged) or not lent.ok else "ok"
    return table, summary
