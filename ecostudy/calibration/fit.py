"""Least squares on the replayed dynamics, 95 % intervals, identifiability and a bootstrap over logs.

Parameters are fitted as multiples of the train file's values (the prior), p = theta / theta_0,
by :func:`scipy.optimize.least_squares`. The residuals are the standardised innovations of the
replayed energy balance (:mod:`ecostudy.calibration.replay`: a scalar Kalman filter whitens the
random walk that the logged work's noise leaves, so the residuals are white with unit variance
when model and noise levels are right) and, where the log has the line power, the log-ratios
ln(P_line / P_wheel) against -ln eta_T in traction and ln eta_R in electric braking, each weighted
by its spread at a first fit. Noise levels come from the logs (:meth:`Problem.measure_noise`).
The 95 % interval of a parameter is 1.96 standard deviations of cov = s^2 (J^T J)^-1 at the
optimum (J by central differences, s^2 the residual variance); with several logs a bootstrap over
logs (logs drawn with replacement, refitted) gives a second interval.

Identifiability, judged from the logs alone (:func:`badness`; the train file's value plays no part):
a Davis term whose 95 % half-width moves the running resistance over the logged speeds by more
than :data:`MAX_RESISTANCE_SHARE` of it, any other parameter whose half-width exceeds
:data:`MAX_RELATIVE_WIDTH` of its estimate, a parameter whose interval reaches below its bound 0,
or one that lies in a null direction of J (a singular value below 1e-9 of the largest) is not
identifiable from these logs. It is held at its prior, not fitted to noise, and the fit
is repeated without it (the others keep the variance they had while it was free: :func:`widened`); the report says which parameters it moves with (the weakest singular
direction of J). Examples: the quadratic Davis term C from a slow run, the static mass against
the rotating-mass allowance on flat track (only M = Ms (1 + f) is seen there), the efficiency of
a log without line power.
"""
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import least_squares

from ecostudy.calibration.replay import coefficients, efficiency_samples, prepare, speed_noise
from ecostudy.core.progress import stage, step

# name -> (unit, what it is)
PARAMETERS = {
    "mass": ("kg", "static mass Ms; the effective mass M keeps its ratio to it"),
    "rotating_mass_factor": ("-", "rotating-mass allowance f, M = Ms (1 + f)"),
    "davis_a": ("N", "Davis A"),
    "davis_b": ("N s/m", "Davis B"),
    "davis_c": ("N s^2/m^2", "Davis C"),
    "efficiency": ("-", "traction efficiency, wheel work per line energy"),
    "regeneration_efficiency": ("-", "regeneration efficiency, line energy per wheel work"),
}
DEFAULT_FIT = ("mass", "davis_a", "davis_b", "davis_c", "efficiency")
MAX_RELATIVE_WIDTH = 0.5   # 95 % half-width above this share of the estimate: not identifiable (mass, f, efficiencies)
# a Davis term's 95 % half-width times v^k above this share of the running resistance over the logged speeds:
# not identifiable (badness); the share, not the term's own size, as B or C can be a small part of a known resistance
MAX_RESISTANCE_SHARE = 0.2
DAVIS_POWER = {"davis_a": 0, "davis_b": 1, "davis_c": 2}  # the power of v each Davis term multiplies
MAX_EVALUATIONS = None     # least_squares' max_nfev (None: its own cap, 100 evaluations a parameter)
NULL_SINGULAR = 1e-9       # singular value of the column-scaled J below this share of the largest: a null direction
Z95 = 1.959964


def priors(train):
    """The train file's value of every parameter (SI)."""
    return {"mass": train.static_mass, "rotating_mass_factor": train.mass / train.static_mass - 1.0,
            "davis_a": train.davis[0], "davis_b": train.davis[1], "davis_c": train.davis[2],
            "efficiency": train.traction_efficiency, "regeneration_efficiency": train.regeneration_efficiency}


def scales(prior):
    """theta = theta_0 + scale (p - 1): the prior itself, or a typical size where the prior is 0."""
    fallback = {"rotating_mass_factor": 0.05, "davis_a": 1e-3 * prior["mass"], "davis_b": 1e-5 * prior["mass"],
                "davis_c": 1e-6 * prior["mass"], "efficiency": 0.8, "regeneration_efficiency": 0.8, "mass": 1.0}
    return {k: abs(v) if v else fallback[k] for k, v in prior.items()}


def train_with(train, theta):
    """``train`` with the parameter values ``theta`` (SI)."""
    static = theta["mass"]
    return replace(train, static_mass=static, mass=static * (1.0 + theta["rotating_mass_factor"]),
                   davis=(theta["davis_a"], theta["davis_b"], theta["davis_c"]),
                   traction_efficiency=theta["efficiency"], regeneration_efficiency=theta["regeneration_efficiency"])


@dataclass
class Problem:
    """The runs and efficiency samples of some logs, the prior and the parameters to fit."""

    runs: list
    traction: dict           # log name -> ln(P_line / P_wheel) in traction
    regeneration: dict       # log name -> the same in electric braking
    prior: dict
    sigma: dict = field(default_factory=lambda: {"speed": 0.05, "traction": 0.014, "regeneration": 0.014,
                                                 "power": 0.01})
    gains: list = field(default_factory=list)   # per run: its whitened basis (Run.whitened)

    @classmethod
    def from_logs(cls, logs, track, train):
        """The problem of ``logs``, with the noise levels measured from them (:meth:`measure_noise`)."""
        runs, traction, regeneration = [], {}, {}
        for log in logs:
            runs += prepare(log, track, train)
            traction[log.name], regeneration[log.name] = efficiency_samples(log, train)
        problem = cls(runs, traction, regeneration, priors(train))
        problem.measure_noise(logs)
        return problem

    def measure_noise(self, logs):
        """Speed noise from the headers (``speed_sigma_mps``, their mean), else from the logged speeds'
        second differences (robust spread / sqrt 6: a smooth motion leaves nothing there); power
        noise from the headers, else from the traction log-ratios (two independent readings:
        spread / sqrt 2), else 1 %; then the filter gains."""
        second = np.concatenate([np.diff(run.v[run.used], 2) for run in self.runs])
        speeds = [log.header.speed_sigma_mps for log in logs if log.header.speed_sigma_mps]
        if speeds:
            self.sigma["speed"] = float(np.mean(speeds))
        elif second.size > 10:
            self.sigma["speed"] = max(speed_noise(second), 1e-4)
        declared = [log.header.power_sigma_percent for log in logs if log.header.power_sigma_percent]
        ratios = np.concatenate(list(self.traction.values()))
        if declared:
            self.sigma["power"] = float(np.mean(declared)) / 100.0
        elif ratios.size > 20:
            self.sigma["power"] = max(float(np.std(ratios)) / np.sqrt(2), 1e-4)
        self.refilter(self.prior["mass"] * (1.0 + self.prior["rotating_mass_factor"]))

    def refilter(self, mass):
        """The filter gains and whitened bases for effective mass ``mass`` [kg] (the work's noise per
        unit mass depends on it)."""
        self.gains = [run.whitened(run.gains(mass, self.sigma["speed"], self.sigma["power"]), self.sigma["speed"])
                      for run in self.runs]

    def theta(self, names, p, fixed=None):
        """Every parameter's value [SI]: ``names`` at the relative values ``p``, those in ``fixed``
        (a dict, SI) at theirs, the rest at the prior."""
        s = scales(self.prior)
        out = dict(self.prior)
        out.update(fixed or {})
        out.update({n: self.prior[n] + s[n] * (float(x) - 1.0) for n, x in zip(names, p)})
        return out

    def blocks(self, names, p, logs=None, fixed=None):
        """Unweighted residuals per block (speed [m/s], traction and regeneration log-ratios [-])
        over the logs named in ``logs`` (a list, repeats allowed; None: all), parameters not in
        ``names`` at ``fixed`` or the prior (:meth:`theta`)."""
        th = self.theta(names, p, fixed)
        mass, davis = th["mass"] * (1.0 + th["rotating_mass_factor"]), (th["davis_a"], th["davis_b"], th["davis_c"])
        chosen = logs if logs is not None else list(self.traction)
        weights = coefficients(mass, th["mass"], davis)
        speed = [whitened @ weights for _, whitened in self.ordered_runs(chosen)]
        eta_t, eta_r = max(th["efficiency"], 1e-6), max(th["regeneration_efficiency"], 1e-6)
        return {"speed": np.concatenate(speed),
                "traction": np.concatenate([self.traction[n] + np.log(eta_t) for n in chosen]),
                "regeneration": np.concatenate([self.regeneration[n] - np.log(eta_r) for n in chosen])}

    def ordered_runs(self, logs=None):
        """(run, whitened basis) of the logs named in ``logs`` (all when None), in the order of the residuals."""
        by_log = {}
        for run, gains in zip(self.runs, self.gains):
            by_log.setdefault(run.log, []).append((run, gains))
        return [run for n in (logs if logs is not None else list(self.traction)) for run in by_log[n]]

    def residuals(self, names, p, logs=None, fixed=None):
        b = self.blocks(names, p, logs, fixed)
        return np.concatenate([b["speed"], b["traction"] / self.sigma["traction"],
                               b["regeneration"] / self.sigma["regeneration"]])

    def jacobian(self, names, p, step=1e-5, logs=None):
        """d residuals / d p by central differences, over the logs named in ``logs`` (None: all)."""
        cols = []
        for j in range(len(names)):
            hi, lo = np.array(p, float), np.array(p, float)
            hi[j] += step
            lo[j] -= step
            cols.append((self.residuals(names, hi, logs) - self.residuals(names, lo, logs)) / (2 * step))
        return np.column_stack(cols) if cols else np.zeros((len(self.residuals(names, p, logs)), 0))


def solve(problem, names, start=None, logs=None, fixed=None):
    """Least squares over ``names`` (relative values p, each theta >= 0), the others at ``fixed``
    or the prior; returns (p, '' or why it is not converged: least_squares' own message)."""
    if not names:
        return np.zeros(0), ""
    s = scales(problem.prior)
    lower = [1.0 - problem.prior[n] / s[n] for n in names]
    x0 = np.ones(len(names)) if start is None else np.clip(start, np.array(lower) + 1e-6, None)
    result = least_squares(lambda p: problem.residuals(names, p, logs, fixed), x0, method="trf",
                           bounds=(lower, np.inf), x_scale=1.0, xtol=1e-10, ftol=1e-10, max_nfev=MAX_EVALUATIONS)
    return result.x, "" if result.success else f"the least-squares fit did not converge: {result.message}"


def covariance(problem, names, p):
    """(covariance s^2 (J^T J)^-1 of p, singular values of the column-scaled J, its weakest right
    singular vector); variances along null directions of J are infinite."""
    jac = problem.jacobian(names, p)
    r = problem.residuals(names, p)
    dof = max(len(r) - len(names), 1)
    s2 = float(r @ r) / dof
    norms = np.linalg.norm(jac, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    scaled = jac / safe
    _, sv, vt = np.linalg.svd(scaled, full_matrices=False)
    null = (sv < NULL_SINGULAR * sv[0]) if sv.size and sv[0] > 0 else np.ones(sv.size, bool)
    inv = np.where(null, 0.0, 1.0 / np.where(null, 1.0, sv) ** 2)
    h_inv = (vt.T * inv) @ vt / np.outer(safe, safe)
    cov = h_inv * s2
    lost = np.any(np.abs(vt[null]) > 0.1, axis=0) | (norms == 0)
    cov[lost, :] = np.inf
    cov[:, lost] = np.inf
    return cov, sv, (vt[-1] if sv.size else np.zeros(0))


def resistance_share(problem, theta, name, half):
    """The 95 % half-width ``half`` [SI] of the Davis term ``name`` as a share of the running
    resistance the logs show: its effect on the force over the logged speeds (RMS of half v^k over
    the replayed samples, k = 0, 1, 2 for A, B, C) over the resistance at ``theta`` there (RMS of
    A + B v + C v^2). Speeds and fitted resistance come from the logs: the train file's values play
    no part (against them, one set of logs held B with the file's 119.5 N s/m and passed it with 1195)."""
    v = np.abs(np.concatenate([run.v[run.used] for run in problem.runs]))
    resistance = theta["davis_a"] + theta["davis_b"] * v + theta["davis_c"] * v * v
    scale = float(np.sqrt(np.mean(resistance ** 2)))
    effect = half * float(np.sqrt(np.mean(v ** (2 * DAVIS_POWER[name]))))
    return effect / scale if scale > 0 else np.inf


def badness(problem, theta, name, half):
    """How far ``name`` at ``theta[name]`` +- ``half`` [SI] (its 95 % half-width) is from identified,
    1 at the limit, judged from the logs alone: the larger of its half-width's share (a Davis term's
    of the running resistance, :func:`resistance_share`, against :data:`MAX_RESISTANCE_SHARE`; any
    other's of its estimate, against :data:`MAX_RELATIVE_WIDTH`) over its limit, and the half-width
    over the estimate (above 1 the interval reaches below the bound 0, which no parameter crosses).
    inf along a null direction or for an estimate of 0."""
    value = abs(theta[name])
    if not np.isfinite(half) or value == 0:
        return np.inf
    share = (resistance_share(problem, theta, name, half) / MAX_RESISTANCE_SHARE if name in DAVIS_POWER
             else half / value / MAX_RELATIVE_WIDTH)
    return max(share, half / value)


def half_width_text(problem, theta, name, half):
    """Why ``name`` at ``theta[name]`` +- ``half`` [SI] is not identifiable (:func:`badness` above 1)."""
    value, unit = theta[name], "" if PARAMETERS[name][0] == "-" else f" {PARAMETERS[name][0]}"
    if not np.isfinite(half):
        return "95 % half-width unbounded"
    if name in DAVIS_POWER:
        share = resistance_share(problem, theta, name, half)
        text = (f"95 % half-width {half:.3g}{unit}, {100 * share:.0f} % of the running resistance over the logged "
                f"speeds (limit {100 * MAX_RESISTANCE_SHARE:.0f} %)")
    else:
        share = half / abs(value) if value else np.inf
        text = (f"95 % half-width {half:.3g}{unit}, " + (f"{100 * share:.0f} % of" if share <= 10 else "more than 10 times")
                + f" the estimate (limit {100 * MAX_RELATIVE_WIDTH:.0f} %)")
    if value - half < 0:
        text += f"; its interval {value - half:.3g} to {value + half:.3g}{unit} reaches below the bound 0"
    return text


def fitted_free(problem, free, p, name):
    """(every parameter's value [SI], the 95 % half-width [SI] of ``name``, '' or why the fit did not
    converge) with ``name``, held at its prior, fitted beside ``free`` from ``p`` (and its prior);
    the half-width is inf along a null direction (the logs see only a combination)."""
    names = [*free, name]
    q, unconverged = solve(problem, names, np.append(p, 1.0))
    half = Z95 * float(np.sqrt(covariance(problem, names, q)[0][-1, -1])) * scales(problem.prior)[name]
    return problem.theta(names, q), half, unconverged


def informing(problem, names, p):
    """{name: the logs whose residuals move with it at ``p``}: its column of the log's own Jacobian
    above :data:`NULL_SINGULAR` of the largest log's (a regeneration efficiency moves only the
    residuals of logs with electric braking and a line power). A parameter only one log informs has
    the same value in every resample of a bootstrap over logs."""
    logs = list(problem.traction)
    norms = np.array([np.linalg.norm(problem.jacobian(names, p, logs=[log]), axis=0) for log in logs])
    return {n: [log for log, size in zip(logs, norms[:, j]) if size > NULL_SINGULAR * norms[:, j].max()]
            for j, n in enumerate(names)}


def estimate_noise(problem, names, p):
    """Set each block's noise to its residuals' standard deviation at ``p`` (degrees of freedom:
    the parameters that act on the block)."""
    b = problem.blocks(names, p)
    acting = {"traction": [n for n in names if n == "efficiency"],
              "regeneration": [n for n in names if n == "regeneration_efficiency"]}
    for key in acting:
        values = b[key]
        dof = len(values) - len(acting[key])
        if dof > 0:
            problem.sigma[key] = max(float(np.sqrt(values @ values / dof)), 1e-9)


def widened(cov, free, widest):
    """``cov`` with each parameter's variance raised to the largest finite one it had in an earlier
    fit (recorded in ``widest``, by name), correlations kept: holding a parameter at its prior does
    not make the others better known than when it was free (their estimates move with the held
    value). A variance that was infinite (a null direction: only a combination is seen, the prior
    fixes the split) is not carried over."""
    variance = np.diag(cov).copy()
    for j, name in enumerate(free):
        if np.isfinite(variance[j]):
            widest[name] = max(widest.get(name, 0.0), variance[j])
    ratio = [np.sqrt(widest[n] / variance[j]) if np.isfinite(variance[j]) and variance[j] > 0 else 1.0
             for j, n in enumerate(free)]
    return cov * np.outer(ratio, ratio)


def identify(problem, requested):
    """Fit ``requested`` parameters, holding those the logs do not identify at their prior.

    Returns (free names, p, covariance, held: {name: reason}, spread: {held name: its standard
    deviation in relative units in the fit where it was held, the largest it had while free (inf
    along a null direction: the prior fixes it by convention)}, '' or why the last fit, the one
    returned, is not converged, partners: {held name: the free names it moved with})."""
    free, held, widest, spread, partnered = list(requested), {}, {}, {}, {}
    while True:
        p, _ = solve(problem, free)
        estimate_noise(problem, free, p)
        th = problem.theta(free, p)
        problem.refilter(th["mass"] * (1.0 + th["rotating_mass_factor"]))  # weights at the fitted mass
        p, unconverged = solve(problem, free, p)
        th = problem.theta(free, p)
        cov, sv, weakest = covariance(problem, free, p)
        if not free:
            return free, p, cov, held, spread, unconverged, partnered
        cov = widened(cov, free, widest)
        s = scales(problem.prior)
        half = [Z95 * np.sqrt(cov[j, j]) * s[n] for j, n in enumerate(free)]
        width = np.array([badness(problem, th, n, h) for n, h in zip(free, half)])
        worst = int(np.argmax(width))
        if width[worst] <= 1.0:
            return free, p, cov, held, spread, unconverged, partnered
        partners = [n for j, n in enumerate(free) if j != worst and abs(weakest[j]) > 0.3]
        ratio = sv[-1] / sv[0] if sv[0] > 0 else 0.0
        reason = half_width_text(problem, th, free[worst], half[worst])
        if partners:
            reason += f"; moves with {', '.join(partners)} (singular value ratio {ratio:.1e})"
        if unconverged:  # the width was read at a point least_squares did not converge to
            reason += "; judged at a fit that did not converge"
        held[free[worst]], partnered[free[worst]] = reason, partners
        spread[free[worst]] = float(np.sqrt(cov[worst, worst]))
        free.pop(worst)


def bootstrap(problem, names, p, draws, seed=0, spread=None):
    """(estimates of ``names`` refitted on ``draws`` resamples of the logs (with replacement) [SI],
    how many of those fits are not converged).

    A parameter held at its prior (``spread``: {name: standard deviation, relative}, as
    :func:`identify` gives it) is not known as well as holding it pretends: each draw also draws
    it, normal about the value it is held at with the largest spread it had while free (cut at
    theta >= 0; not drawn along a null direction, infinite spread, where the prior fixes it by
    convention), and refits the others with it there. Resampling the logs alone would carry no
    uncertainty of a held parameter (its value is the same in every draw), and two logs give
    three distinct resamples. A parametric bootstrap for the held parameters (Efron & Tibshirani,
    "An Introduction to the Bootstrap", the parametric bootstrap) inside the one over logs; the
    held parameters are drawn independently of each other."""
    logs = list(problem.traction)
    rng = np.random.default_rng(seed)
    s = scales(problem.prior)
    drawn = {n: sd for n, sd in (spread or {}).items() if np.isfinite(sd) and sd > 0}
    out, unconverged = [], 0
    stage("bootstrap over logs", total=draws, unit="draws")
    for draw in range(draws):
        pick = [logs[i] for i in rng.integers(0, len(logs), len(logs))]
        fixed = {n: max(problem.prior[n] + s[n] * sd * rng.standard_normal(), 0.0) for n, sd in drawn.items()}
        q, why = solve(problem, names, p, pick, fixed)
        unconverged += bool(why)
        th = problem.theta(names, q, fixed)
        out.append([th[n] for n in names])
        step(draw + 1)
    return np.array(out), unconverged
