"""A calibration of a train from logged runs: the fit (:mod:`ecostudy.calibration.fit`), its table of
estimates and intervals, the residuals and their checks, and the status.

Status: ``ok``; ``flagged`` when a requested parameter is not identifiable from the logs (held at
its prior) or the residuals are bad: the replayed speed off the logged one by more than
:data:`MAX_RMS_SPEED` RMS, or the filter's innovations not white (their moving average over
:data:`WINDOW` seconds :data:`MAX_STRUCTURE` times larger than white noise leaves: the model misses
something the logs show), or a logged run broke the line's speed limit
(:func:`~ecostudy.calibration.replay.over_limit`: a driver keeps to it, so the log is not a driven run
of this line as the track file gives it), or a log pulled beyond the train file's traction envelope
(:func:`~ecostudy.calibration.replay.over_envelope`), or a fitted efficiency is above 1, or a fitted
efficiency absorbs auxiliary power (:func:`~ecostudy.calibration.replay.auxiliary_power`), or a log's
speeds and positions disagree in scale by more than the mass's interval allows
(:func:`~ecostudy.io.logscale.scale_problem`), or its wheel power is off the force times the speed
(:func:`~ecostudy.io.logforce.force_power_problem`), or a parameter held at the train file's value
is excluded by the logs (:func:`held_against_logs`). An ok status lists every check run
(:func:`checks_run`).
"""
import warnings
from math import comb
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from ecostudy.calibration.replay import (LIMIT_TOLERANCE_KMH, auxiliary_power, coefficients, idle_line_power, over_envelope,
                                         over_limit)
from ecostudy.core.errors import EcostudyWarning
from ecostudy.core.progress import stage
from ecostudy.io.logscale import SCALE_TOLERANCE, measured_scale, scale_problem
from ecostudy.io.logforce import FORCE_POWER_AGREE, force_power_agreement, force_power_problem
from ecostudy.calibration.fit import (
    PARAMETERS, Z95, Problem, badness, bootstrap, fitted_free, half_width_text, identify, informing, scales,
    train_with,
)

MAX_RMS_SPEED = 0.3    # [m/s]
MAX_STRUCTURE = 2.0    # moving-average innovations over white-noise expectation (1.3 at most on 200 generated logs)
WINDOW = 5.0           # [s]
# a fitted mass this many times the train file's, or less than its share, is a unit slip in the log
# rather than a train (power in MW or W under kW names: 1000 x; force in daN under kN: 10 x); a
# loaded freight train against its empty file is at most about 3-4 x, a passenger train within 1.5 x
MASS_RATIO = 3.0
BOOTSTRAP_DRAWS = 200
# logs (the bootstrap's resampling unit: a log is drawn whole, its runs with it) a bootstrap over logs
# needs, in all and informing a parameter: n logs have C(2n - 1, n) distinct resamples (2: 3, 3: 10,
# 4: 35, 5: 126), and the draws of resamples of at most two distinct logs are 100 % of them with 2 logs,
# 78 % with 3, 34 % with 4 and 10 % with 5; with 2 logs the 2.5 and 97.5 percentiles are the fits on
# each log alone, not an interval. Fewer: boot_low and boot_high are left NaN, the note says why
MIN_BOOTSTRAP_LOGS = 5
# under a printed table with bootstrap bounds: what they are, so that nobody reads them as a confidence interval
BOOTSTRAP_NOTE = ("boot_low, boot_high: the spread of refits over the logs resampled whole, how far the logs disagree "
                  "with each other; not a confidence interval: the noise within each log is not in it, and it can be "
                  "far narrower (the mass's a sixth of its 95 % interval on five logs); the 95 % interval is low to high")
# a parameter held at the train file's value (not asked for) that the logs identify is fitted beside the
# others: the held value more than this many 95 % half-widths from the value they give is flagged
HELD_EXCLUDED = 2.0
MOTION = ("mass", "davis_a", "davis_b", "davis_c")  # the parameters the replayed speed follows (the efficiencies do not move it)


@dataclass
class Calibration:
    """The result of :func:`calibrate_logs`."""

    table: pd.DataFrame      # one row per requested parameter (SI): prior, estimate, std, 95 % bounds
    status: str              # ok | flagged
    reason: str
    residuals: pd.DataFrame  # per sample: log, run, time_s, position_m, speed_mps, model_speed_mps
    quality: dict            # residual statistics and noise levels
    theta: dict              # every parameter's value after the fit (SI)
    train: object            # the calibrated :class:`~ecostudy.core.types.Train`
    free: list               # the parameters fitted (identified)
    covariance: np.ndarray   # of ``free`` (SI)
    footnotes: list = field(default_factory=list)  # lines for under the printed table (name: what its row leaves out)
    checked: list = field(default_factory=list)    # every check run (:func:`checks_run`): what an ok status passed


def structure(residual, t):
    """Drift of residuals: the RMS of their moving average over WINDOW seconds against what white
    noise of the same spread leaves (1 for white noise)."""
    step = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    w = max(int(round(WINDOW / step)), 1)
    if len(residual) < 2 * w or np.std(residual) == 0:
        return 1.0
    mean = np.convolve(residual, np.ones(w) / w, mode="valid")
    return float(np.sqrt(np.mean(mean ** 2)) * np.sqrt(w) / np.std(residual))


def drifts(problem, theta):
    """The :func:`structure` of each run's standardised innovations at the parameters ``theta`` (SI), in
    the order of ``problem.ordered_runs()``."""
    weights = coefficients(*motion(theta))
    return [structure(whitened @ weights, run.t[run.used]) for run, whitened in problem.ordered_runs()]


def fitted_drifts(problem, names=MOTION):
    """:func:`drifts` at the fit of ``names`` to ``problem``'s logs (:func:`~ecostudy.calibration.fit.identify`,
    as calibrate fits them): above :data:`MAX_STRUCTURE`, no train of the model replays the logged
    speed from the logged work along the logged positions. A run whose replay is not finite (an
    infinite logged work, from the API) is left out of the fit, its drift NaN."""
    finite = [bool(np.all(np.isfinite(whitened))) for whitened in problem.gains]
    kept = replace(problem, runs=[r for r, f in zip(problem.runs, finite) if f],
                   gains=[g for g, f in zip(problem.gains, finite) if f])
    if not kept.runs:
        return [np.nan] * len(finite)
    free, p, *_ = identify(kept, list(names))
    values = iter(drifts(kept, kept.theta(free, p)))
    return [next(values) if f else np.nan for f in finite]


def drift_reason(ratio):
    """What a drift ``ratio`` above :data:`MAX_STRUCTURE` says, for a status reason."""
    return f"residuals drift ({ratio:.1f} times white noise over {WINDOW:g} s, more than {MAX_STRUCTURE:g})"


def motion(theta):
    """(effective mass, static mass [kg], (A, B, C)) of the parameters ``theta`` (SI)."""
    return (theta["mass"] * (1.0 + theta["rotating_mass_factor"]), theta["mass"],
            (theta["davis_a"], theta["davis_b"], theta["davis_c"]))


def resamples(units):
    """The distinct resamples with replacement of ``units`` resampling units: C(2n - 1, n)."""
    return comb(2 * units - 1, units) if units > 0 else 0


def too_few_logs(logs):
    """Why a bootstrap over ``logs`` (a count) gives no interval ('' from :data:`MIN_BOOTSTRAP_LOGS` on)."""
    if logs >= MIN_BOOTSTRAP_LOGS:
        return ""
    return (f"boot_low, boot_high NaN: {logs} log{'s' if logs != 1 else ''} give{'' if logs != 1 else 's'} a bootstrap "
            f"over logs only {resamples(logs)} distinct resample{'s' if resamples(logs) != 1 else ''}; it needs at least "
            f"{MIN_BOOTSTRAP_LOGS} logs ({resamples(MIN_BOOTSTRAP_LOGS)} resamples): give "
            f"{MIN_BOOTSTRAP_LOGS - logs} more; the 95 % interval is low to high")


def too_few_informing(seen, logs):
    """Why a parameter only the logs ``seen`` (names) inform, of ``logs`` (a count), has no bootstrap
    interval ('' when :data:`MIN_BOOTSTRAP_LOGS` or more inform it)."""
    if len(seen) >= MIN_BOOTSTRAP_LOGS:
        return ""
    k = len(seen)
    return (f"boot_low, boot_high NaN: only {k} of the {logs} logs ({', '.join(seen) or 'none'}) "
            f"inform{'s' if k == 1 else ''} it, so the resamples of the logs give it only {resamples(k)} distinct "
            f"value{'s' if resamples(k) != 1 else ''}; a bootstrap over logs needs at least {MIN_BOOTSTRAP_LOGS} that "
            "inform it; its 95 % interval is low to high")


def checks_run(logs, free, bootstrapped, held):
    """What the calibration of ``logs`` checked (fitting ``free``; ``bootstrapped``: a bootstrap ran;
    ``held``: the held parameters checked against the logs), each a phrase: the checks every
    calibration runs, then those that ran on some logs only (of a log without a position column, or
    without a force and a wheel power, or with an efficiency not fitted, nothing is judged), with how
    many logs. An ok status line lists them: each is a reason of a flagged one."""
    def on(test, what):
        count = sum(test(log) is not None for log in logs)
        return [f"{what} ({count} of {len(logs)} logs)" if count < len(logs) else what] if count else []
    lo, hi = FORCE_POWER_AGREE
    out = ["every parameter fitted identifiable and none at its bound 0",
           "the least-squares fit converged" + (" and so did every bootstrap refit" if bootstrapped else "")]
    if {"efficiency", "regeneration_efficiency"} & set(free):
        out.append("fitted efficiencies at most 1")
    if "mass" in free:
        out.append(f"the mass within 1/{MASS_RATIO:g} to {MASS_RATIO:g} times the train file's")
    out += [f"replayed speed within {MAX_RMS_SPEED:g} m/s RMS",
            f"innovations within {MAX_STRUCTURE:g} times white noise over {WINDOW:g} s",
            f"logged speeds within {LIMIT_TOLERANCE_KMH:g} km/h of the line's limits",
            "logged traction within the train file's envelope"]
    out += on(measured_scale, "speeds and positions on one scale (the mass bias a mismatch implies within the "
              "mass's 95 % interval)" if "mass" in free else
              f"speeds and positions within {100 * SCALE_TOLERANCE:g} % of one scale")
    out += on(force_power_agreement, f"the wheel power {lo:g}-{hi:g} times the force times the speed")
    if {"efficiency", "regeneration_efficiency"} & set(free):
        out += on(idle_line_power, "no auxiliary power in the line power while the wheels draw none")
    if held:
        out.append(f"held {', '.join(held)} within {HELD_EXCLUDED:g} half-widths of the values the logs give")
    return out


def held_against_logs(problem, names, free, p):
    """({name: (every parameter's value, its 95 % half-width [SI], '' or why the fit did not converge)
    with it fitted beside ``free`` from ``p`` (:func:`~ecostudy.calibration.fit.fitted_free`)},
    {name: (held value, the value the logs give, its 95 % half-width) [SI]}) of each parameter not in
    ``names``, held at the train file's value; the second for those the logs identify (a converged fit,
    :func:`~ecostudy.calibration.fit.badness` at most 1), so that a held value the logs exclude is not
    passed over (the other parameters absorb it, their intervals then missing the truth)."""
    fits = {n: fitted_free(problem, free, p, n) for n in PARAMETERS if n not in names}
    return fits, {n: (problem.prior[n], theta[n], half) for n, (theta, half, unconverged) in fits.items()
                  if not unconverged and badness(problem, theta, n, half) <= 1.0}


def held_excluded(name, held, value, half):
    """Why ``name``, held at ``held``, is excluded by the logs, which give ``value`` +- ``half`` [SI]
    (more than :data:`HELD_EXCLUDED` half-widths apart); '' where it is not."""
    if abs(value - held) <= HELD_EXCLUDED * half:
        return ""
    unit = "" if PARAMETERS[name][0] == "-" else f" {PARAMETERS[name][0]}"
    return (f"held {name} = {held:.4g}{unit} is excluded by the logs (they give {value:.4g} +- {half:.2g}{unit}, "
            f"{abs(value - held) / half:.1f} half-widths of their 95 % interval away); fit it (--fit ...,{name}) or "
            "check the train file")


def residual_table(problem, theta):
    frames = []
    for run in problem.runs:
        model = run.speed(*motion(theta))
        frames.append(pd.DataFrame({"log": run.log, "run": run.index, "time_s": run.t, "position_m": run.x,
                                    "speed_mps": run.v, "model_speed_mps": model, "used": run.used}))
    out = pd.concat(frames, ignore_index=True)
    out["residual_mps"] = out["model_speed_mps"] - out["speed_mps"]
    return out


def calibrate_logs(logs, track, train, names, draws=BOOTSTRAP_DRAWS, seed=0):
    """Fit ``names`` (of :data:`~ecostudy.calibration.fit.PARAMETERS`) to ``logs`` on ``track``,
    starting from and regularised by nothing but the ``train``'s values (the prior)."""
    stage("least-squares fit, identifiability")
    problem = Problem.from_logs(logs, track, train)
    free, p, cov, held, spread, unconverged, partnered = identify(problem, list(names))
    theta = problem.theta(free, p)
    s = scales(problem.prior)
    few = too_few_logs(len(logs)) if free and draws > 0 else ""
    boot, boot_unconverged = (bootstrap(problem, free, p, draws, seed, spread) if not few and free and draws > 0
                              else (None, 0))
    seen = informing(problem, free, p) if boot is not None else {}
    rows, footnotes = [], [few.replace("NaN:", "NaN for every parameter:", 1)] if few else []
    for name in names:
        row = {"name": name, "unit": PARAMETERS[name][0], "prior": problem.prior[name], "estimate": theta[name],
               "std": np.nan, "low": np.nan, "high": np.nan, "boot_low": np.nan, "boot_high": np.nan,
               "identifiable": name not in held, "note": held.get(name, "")}
        if name in free:
            j = free.index(name)
            row["std"] = float(np.sqrt(cov[j, j])) * s[name]
            row["low"], row["high"] = theta[name] - Z95 * row["std"], theta[name] + Z95 * row["std"]
            lacking = too_few_informing(seen[name], len(logs)) if boot is not None else few
            if boot is not None and not lacking and np.ptp(np.percentile(boot[:, j], [2.5, 97.5])) == 0:
                lacking = (f"boot_low, boot_high NaN: 95 % or more of the {draws} bootstrap draws gave it one value, "
                           f"{np.median(boot[:, j]):.5g}; its 95 % interval is low to high")
            if boot is not None and not lacking:
                row["boot_low"], row["boot_high"] = np.percentile(boot[:, j], [2.5, 97.5])
            elif lacking:  # a few resamples of the logs give it a few values: their spread, not an interval
                row["note"] = lacking
                if boot is not None:
                    footnotes.append(f"{name}: {row['note']}")
            along = [h for h, partners in partnered.items() if name in partners]
            if along:  # the logs see it only together with a parameter held at its prior: it carries that one's error
                why = (f"fitted with {', '.join(along)} held at the train file's value, which these logs see only together "
                       "with it: its value and interval hold only if that value does")
                row["note"] = f"{row['note']}; {why}" if row["note"] else why
                footnotes.append(f"{name}: {why}")
        rows.append(row)
    table = pd.DataFrame(rows)
    if table[["boot_low", "boot_high"]].notna().any(axis=None):  # printed beside low and high: say what they are
        footnotes.insert(0, BOOTSTRAP_NOTE)
    fits, held_fits = held_against_logs(problem, names, free, p)
    if "mass" in free and "rotating_mass_factor" not in names:  # only Ms (1 + f) is seen where gradients are small
        fitted, half, _ = fits["rotating_mass_factor"]  # converged or not, as the calibration's own fit
        if not badness(problem, fitted, "rotating_mass_factor", half) <= 1.0:
            note = (f"fitted as Ms (1 + f) with rotating_mass_factor held at the train file's "
                    f"{problem.prior['rotating_mass_factor']:.4g}: these logs "
                    + ("cannot tell Ms from f" if not np.isfinite(half) else
                       f"tell f only to {fitted['rotating_mass_factor']:.3g} +- {half:.2g}: "
                       + half_width_text(problem, fitted, "rotating_mass_factor", half))
                    + " (too little gradient work), so its interval holds only if f does")
            before = table.loc[table["name"] == "mass", "note"].iloc[0]
            table.loc[table["name"] == "mass", "note"] = f"{before}; {note}" if before else note
            warnings.warn(f"calibration: mass {note}", EcostudyWarning, stacklevel=2)
    residuals = residual_table(problem, theta)
    used = residuals[residuals["used"]]
    drift = drifts(problem, theta)
    blocks = problem.blocks(free, p)
    quality = {"rms_speed_mps": float(np.sqrt(np.mean(used["residual_mps"] ** 2))),
               "structure_ratio": float(max(drift)) if drift else 1.0,
               "speed_samples": int(blocks["speed"].size), "traction_samples": int(blocks["traction"].size),
               "regeneration_samples": int(blocks["regeneration"].size), "runs": len(problem.runs),
               "noise": {"speed_mps": problem.sigma["speed"], **{f"{k}_share": v for k, v in problem.sigma.items() if k != "speed"}},
               "held_fitted": {n: {"unit": PARAMETERS[n][0], "held": held, "fitted": value, "half_width": half}
                               for n, (held, value, half) in held_fits.items()}}
    reasons = [unconverged] if unconverged else []
    if boot_unconverged:
        reasons.append(f"{boot_unconverged} of {draws} bootstrap fits did not converge")
    reasons += [f"{n} not identifiable from these logs, held at its prior: {why}" for n, why in held.items()]
    if quality["rms_speed_mps"] > MAX_RMS_SPEED:
        reasons.append(f"speed residuals of {quality['rms_speed_mps']:.3g} m/s RMS (more than {MAX_RMS_SPEED} m/s; "
                       f"the logged speed's own noise is {problem.sigma['speed']:.2g} m/s)")
    if quality["structure_ratio"] > MAX_STRUCTURE:
        reasons.append(f"{drift_reason(quality['structure_ratio'])}: the model misses something the logs show")
    reasons += [f"{run.log} run {run.index}: {why}" for run in problem.runs
                if (why := over_limit(run.t, run.x, run.v, track))]
    # a speed scale off biases the mass: judged against the fitted mass's interval (without one, a fixed share)
    j = free.index("mass") if "mass" in free else None
    mass = None if j is None else (theta["mass"], Z95 * float(np.sqrt(cov[j, j])) * s["mass"])
    reasons += [f"{log.name}: {why}" for log in logs
                for why in (over_envelope(log, train), scale_problem(log, mass), force_power_problem(log)) if why]
    if {"efficiency", "regeneration_efficiency"} & set(free):
        reasons += [f"{log.name}: {why}" for log in logs if (why := auxiliary_power(log))]
    reasons += [held_excluded(n, *fitted) for n, fitted in held_fits.items() if held_excluded(n, *fitted)]
    reasons += [f"{n} fitted at its bound 0 (the logs would have it below): its interval is not a fit's, and the "
                "other parameters absorb what the model misses" for n in free if theta[n] <= 1e-9 * abs(problem.prior[n])]
    reasons += [f"{n} {theta[n]:.4g} above 1: the wheel work is more than the line energy logged (a line power, "
                "voltage or current scale off?)" for n in ("efficiency", "regeneration_efficiency") if n in free and theta[n] > 1]
    ratio = theta["mass"] / problem.prior["mass"]
    if "mass" in free and not 1.0 / MASS_RATIO <= ratio <= MASS_RATIO:
        reasons.append(f"mass {theta['mass'] / 1e3:.4g} t is {ratio:.3g} times the train file's "
                       f"{problem.prior['mass'] / 1e3:.4g} t (beyond 1/{MASS_RATIO:g} to {MASS_RATIO:g}): a unit slip "
                       "in the log (power in MW or W under kW names, force in daN under kN)?")
    scale = np.array([s[n] for n in free])
    # the calibrated train: this calibration's status is its own (a flagged one's file says so), not the prior file's
    calibrated = replace(train_with(train, theta), calibration_reason="")
    return Calibration(table, "flagged" if reasons else "ok", "; ".join(reasons), residuals, quality, theta,
                       calibrated, free, cov * np.outer(scale, scale), footnotes,
                       checks_run(logs, free, boot is not None, list(held_fits)))
