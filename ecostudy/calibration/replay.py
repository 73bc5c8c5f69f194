"""The replayed dynamics of a logged run: the energy balance a train with given parameters obeys
under the logged work at the wheel, run by run between stops.

Energy balance per unit effective mass from the departure (Farooqi 2018 eq. 2.1, Farooqi 2018,
multiplied by v and integrated over time):

    v(t)^2 / 2 = [W(t) - A I_1(t) - B I_2(t) - C I_3(t) - Ms w_fixed(t)] / M

W is the logged work at the wheel (the wheel power's interval means times the interval, or the
trapezoid of force times speed), I_k the integrals of R_v(v) v dt for unit Davis coefficients
(:func:`physics.davis_resistance` is linear in A, B and C, so they are taken once over the logged
speed), w_fixed the work per kilogram of static mass against gradients and curves along the logged
positions (:func:`physics.running_resistance` at zero speed; the gradient work is g times the
height gained, exact across gradient changes). A run starts where the train stands (v = 0, so no
initial speed is fitted) and ends where it stands again.

The logged speed is the observation (per unit mass, so its noise does not sit in a regressor and
bias the mass low); the noise of the logged work adds up along a run as a random walk, which a
scalar Kalman filter whitens (:meth:`Run.gains`, :meth:`Run.whitened`; Yazhemsky 2017 Ch. 10,
Yazhemsky 2017, estimates the mass with a scalar Kalman filter too). Samples below
:data:`MIN_SPEED` (smoothed) are left out: there the speed says little about the energy.
"""
import warnings
from dataclasses import dataclass

import numpy as np

from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.core.grid import Profile
from ecostudy.core.physics import davis_resistance, running_resistance
from ecostudy.core.units import KMH

STANDING_SPEED = 0.25   # [m/s] below this, without traction, a train stands (speed noise allowed)
STANDING_TIME = 1.0     # [s] a stand lasts at least this long
REST_SIGMAS = 3.0       # a log's first sample within this many of its stated speed noise is at rest (at_rest)
MIN_SPEED = 2.0         # [m/s] residuals only above this speed (of the speed smoothed over SMOOTHING)
SMOOTHING = 1.0         # [s]
TRACTION_SHARE = 0.05   # efficiency samples: power above this share of the log's largest
ENVELOPE_TOLERANCE = 0.1  # a logged force more than this share above the train file's envelope ...
ENVELOPE_ROWS = 10         # ... in at least this many rows is flagged (noise and a sampled force allowed)
IDLE_SHARE = 0.01       # auxiliary power: intervals whose wheel power is below this share of the log's largest ...
AUX_SHARE = 0.001       # ... drawing a median line power above this share of the largest line power ...
AUX_ERRORS = 5.0        # ... and this many standard errors of that median above 0 are flagged
LIMIT_TOLERANCE_KMH = 1.0  # a logged speed (smoothed over SMOOTHING) over the line's limit by more is flagged


@dataclass
class Run:
    """One run of a log between two stands, prepared for the replay (SI, per sample)."""

    log: str
    index: int
    t: np.ndarray        # [s] from the log's start
    x: np.ndarray        # track position [m]
    v: np.ndarray        # measured speed [m/s]
    work: np.ndarray     # logged work at the wheel since the departure [J]
    davis: np.ndarray    # (3, n) integrals of R_v(v) v dt for A = 1, B = 1, C = 1 [J per unit coefficient]
    fixed: np.ndarray    # gradient and curve work per kg of static mass since the departure [J/kg]
    used: np.ndarray     # samples whose speed residual counts
    stands: bool = True  # ends at a stand (False: the log ends while the train moves)

    @property
    def distance(self):
        return float(abs(self.x[-1] - self.x[0]))

    def basis(self, sigma_speed=0.0):
        """Columns whose combination with :func:`coefficients` is the kinetic energy per effective
        mass from the logged speed minus the replayed one [J/kg] at every sample; sigma^2 / 2 taken
        off the logged v^2 / 2, the mean that speed noise adds. Per unit mass, so that the noisy
        logged speed is the observation, not a regressor whose noise would bias the mass low."""
        return np.column_stack([0.5 * (self.v * self.v - sigma_speed ** 2), -self.work, self.davis.T, self.fixed])

    def gains(self, mass, sigma_speed, sigma_power):
        """(K, S) of the scalar Kalman filter that whitens :meth:`balance` at the used samples: the
        logged work's noise (``sigma_power`` of each interval's work, per ``mass``) adds up along the
        run as a random walk in kinetic energy per mass, the speed noise (``sigma_speed``) reads it
        as v sigma_speed [J/kg]. Gains depend on the noise levels only, so they are computed once."""
        q = (sigma_power * np.diff(self.work) / mass) ** 2
        r = (np.maximum(smoothed(self.t, self.v), MIN_SPEED) * sigma_speed) ** 2  # weights free of the noise
        walk = np.concatenate([[0.0], np.cumsum(q)])
        k_out, s_out, p, last = [], [], 0.0, 0
        for i in np.nonzero(self.used)[0]:
            p += walk[i] - walk[last]
            last = i
            s = p + r[i]
            k_out.append(p / s)
            s_out.append(s)
            p *= 1.0 - p / s
        return np.array(k_out), np.array(s_out)

    def whitened(self, gains, sigma_speed):
        """:meth:`basis` at the used samples through the filter of :meth:`gains`, divided by the
        innovations' spread: ``whitened @ coefficients(...)`` are the standardised innovations,
        white with unit variance when the model and the noise levels are right (the filter is
        linear, so the columns are filtered once)."""
        gain, spread = gains
        rows = self.basis(sigma_speed)[self.used]
        z, out = np.zeros(rows.shape[1]), np.empty_like(rows)
        for i, (row, k) in enumerate(zip(rows, gain)):
            out[i] = row - z
            z += k * out[i]
        return out / np.sqrt(spread)[:, None]

    def speed(self, mass, static_mass, davis):
        """Replayed speed at every sample [m/s] for effective and static mass [kg] and (A, B, C)."""
        energy = self.work - np.dot(davis, self.davis) - static_mass * self.fixed
        return np.sqrt(np.maximum(2.0 * energy / mass, 0.0))


def coefficients(mass, static_mass, davis):
    """The weights of :meth:`Run.basis`: 1, and 1, A, B, C and the static mass per effective mass."""
    return np.array([1.0, 1.0 / mass, *(np.asarray(davis) / mass), static_mass / mass])


def wheel_work(log):
    """Work at the wheel over each interval between rows [J] (len n - 1)."""
    dt = np.diff(log.t)
    if log.power_wheel is not None:
        p = log.power_wheel
        return p[:-1] * dt if log.header.power_sampling == "interval_mean" else 0.5 * (p[1:] + p[:-1]) * dt
    if log.force is not None and log.v is not None:
        fv = log.force * log.v
        return 0.5 * (fv[1:] + fv[:-1]) * dt
    raise InputError(problem(log.path or log.name, "columns", "the replay needs the work at the wheel: a "
                             "force_kN or power_wheel_kW column (with speed_mps for the force)"))


def line_power(log):
    """Mean line power over each interval [W] (len n - 1), or None."""
    p = log.power_line
    if p is None:
        return None
    return p[:-1] if log.header.power_sampling == "interval_mean" else 0.5 * (p[1:] + p[:-1])


def speeds(log):
    """Measured speed, or the positions differenced where the log has no speed [m/s]: central
    differences inside, second-order one-sided ones at the log's ends (exact for a constant
    acceleration: a train starting from rest reads 0 at its first row, not the half of a step's
    speed gain a first-order difference reads, 0.53 m/s at 1 Hz, above the rest speed)."""
    return log.v if log.v is not None else np.abs(np.gradient(log.x, log.t, edge_order=2 if len(log.x) > 2 else 1))


def _stretches(mask):
    """(first, end) sample indices of each run of True in ``mask`` (end exclusive)."""
    change = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return zip(np.flatnonzero(change == 1), np.flatnonzero(change == -1))


def standing(log, work):
    """Samples at which the train stands: slow and without traction, for at least STANDING_TIME, or
    at the log's first or last row at rest (:func:`at_rest`; the last without traction). A
    stand's samples that a noisy sensor reads above STANDING_SPEED, for less than STANDING_TIME
    between slow ones and slow by the speed smoothed over SMOOTHING, are the stand's too (0.15 m/s
    of noise reads above it in one sample of ten: the stand split into phantom runs of 1-5 s)."""
    v, t = speeds(log), log.t
    idle = (np.append(work, 0.0) <= 0.0) & (np.append(0.0, work) <= 0.0)
    slow = (v < STANDING_SPEED) & idle
    quiet = (smoothed(t, v) < STANDING_SPEED) & idle
    for i, j in list(_stretches(~slow)):
        if 0 < i and j < len(slow) and t[j - 1] - t[i] < STANDING_TIME and quiet[i:j].all():
            slow[i:j] = True
    slow[0] |= abs(v[0]) < at_rest(log)  # at rest when the log starts, even if it departs at once
    # at rest without traction at its last row: the log ends as the train stops (still braking, as a
    # driver holds the brake), not while it moves
    slow[-1] |= bool(abs(v[-1]) < at_rest(log) and idle[-1])
    out = np.zeros_like(slow)
    for i, j in _stretches(slow):
        if t[j - 1] - t[i] >= STANDING_TIME or i == 0 or j == len(slow):
            out[i:j] = True
    return out


def speed_noise(second):
    """The speed sensor's noise [m/s] read off the ``second`` differences of speeds sampled along a
    smooth motion: their robust spread (1.4826 median absolute deviations) over sqrt 6 (a smooth
    motion leaves next to nothing there, white noise sigma^2 (1 + 4 + 1))."""
    return 1.4826 * float(np.median(np.abs(second - np.median(second)))) / np.sqrt(6)


def at_rest(log):
    """Below what speed [m/s] the log's first sample is at rest: :data:`STANDING_SPEED`, or the
    speed noise (:data:`REST_SIGMAS` times its header's ``speed_sigma_mps``, else times
    :func:`speed_noise` of its speed column) or its speed column's last digit (a sensor at rest reads
    one step of it), whichever is more. A first sample above it starts the log moving, and its first
    run is not replayed (it has no departure)."""
    noise = log.header.speed_sigma_mps or (speed_noise(np.diff(log.v, 2)) if log.v is not None and len(log.v) > 12 else 0.0)
    return max(STANDING_SPEED, REST_SIGMAS * noise, log.resolution.get("speed", 0.0) * (1.0 + 1e-9))


def smoothed(t, v, span=SMOOTHING):
    """Centred moving average of ``v`` over ``span`` seconds: choosing samples or weights by it
    instead of the noisy speed keeps the choice independent of the noise (no selection bias)."""
    w = max(int(round(span / float(np.median(np.diff(t))))) | 1, 1) if len(t) > 1 else 1
    padded = np.pad(v, w // 2, mode="edge")
    return np.convolve(padded, np.ones(w) / w, mode="valid")


def over_limit(t, x, v, track, tolerance_kmh=LIMIT_TOLERANCE_KMH):
    """Why a logged run broke the line's speed limit ("" if it kept it): its speed smoothed over
    :data:`SMOOTHING` (the sensor's noise averaged out) above the track's limit at the logged
    position by more than ``tolerance_kmh``, the largest excess, where and when."""
    speed, limit = smoothed(t, v), Profile(track.limit_positions, track.limits)(x)
    i = int(np.argmax(speed - limit))
    excess = float(speed[i] - limit[i]) / KMH
    if excess <= tolerance_kmh:
        return ""
    return (f"logged speed {speed[i] / KMH:.1f} km/h at {x[i]:.0f} m ({t[i]:.0f} s), {excess:.1f} km/h over the "
            f"line's {limit[i] / KMH:.0f} km/h limit (tolerance {tolerance_kmh:g} km/h)")


def over_envelope(log, train):
    """Why a log's traction exceeds the train file's envelope ("" if it does not): its force at the
    wheel (the force column, else the wheel power over the speed above :data:`MIN_SPEED`) above
    the envelope at the logged speed by more than :data:`ENVELOPE_TOLERANCE` in at least
    :data:`ENVELOPE_ROWS` rows, the largest excess and where. The replay reads the logged work, so
    the fit does not see it; an optimum of the calibrated train cannot drive what was logged."""
    if log.v is None or (log.force is None and log.power_wheel is None):
        return ""
    speed = np.abs(log.v)
    moving = speed > MIN_SPEED
    force = log.force if log.force is not None else np.where(moving, log.power_wheel / np.maximum(speed, MIN_SPEED), 0.0)
    top = np.asarray(train.traction.force(np.maximum(speed, 1e-3)), float)
    over = np.nonzero(force > (1.0 + ENVELOPE_TOLERANCE) * top)[0]
    if over.size < ENVELOPE_ROWS:
        return ""
    i = int(over[np.argmax(force[over] / top[over])])
    return (f"logged traction {force[i] / 1e3:.0f} kN at {speed[i] / KMH:.0f} km/h ({log.x[i]:.0f} m, {log.t[i]:.0f} s) is "
            f"{force[i] / top[i]:.2f} times the train file's envelope ({top[i] / 1e3:.0f} kN), beyond "
            f"{1 + ENVELOPE_TOLERANCE:g} in {over.size} rows: its traction envelope is not this train's")


def cumulative(values):
    return np.concatenate([[0.0], np.cumsum(values)])


def prepare(log, track, train):
    """The runs of ``log`` on ``track`` (each from a stand to the next), ready for :class:`Run`;
    a log that never stands and moves refuses in one line."""
    if track.tunnels and train.tunnel_resistance:
        warnings.warn(f"track '{track.name}': the replay does not model the tunnel resistance; the Davis "
                      "coefficients fitted there include it", EcostudyWarning, stacklevel=2)
    work = wheel_work(log)
    v = speeds(log)
    stand = standing(log, work)
    height = Profile(track.gradient_positions, track.gradients).integral(log.x)
    curve = Profile(track.curve_positions, track.curvatures, track.curvature_slopes)
    ds = np.abs(np.diff(log.x))
    grade = np.diff(height) / np.maximum(ds, 1e-9)  # along the travel: the height gained per metre run
    per_kg = running_resistance(0.0, (0.0, 0.0, 0.0), 1.0, grade, train.curve_coefficient,
                                curve(0.5 * (log.x[1:] + log.x[:-1])), roeckl=train.curve_resistance == "roeckl")
    fixed = per_kg * ds
    dt = np.diff(log.t)
    basis = [davis_resistance(v, *unit) * v for unit in np.eye(3)]
    trapezoid = np.array([0.5 * (b[1:] + b[:-1]) * dt for b in basis])
    runs, index = [], 0
    departures = np.nonzero(stand[:-1] & ~stand[1:])[0]
    if departures.size and not stand[0]:  # the rows before the first stand: no departure to replay from
        first = int(np.argmax(stand))
        warnings.warn(problem(log.path or log.name, "speed", f"the log starts moving ({v[0]:.1f} m/s at "
                              f"{log.x[0]:.0f} m): its first {log.t[first] - log.t[0]:.0f} s and "
                              f"{abs(log.x[first] - log.x[0]):.0f} m, before the first stand, are not replayed"),
                      EcostudyWarning, stacklevel=2)
    for d in departures:
        following = np.nonzero(stand[d + 1:])[0]
        end = d + 1 + (following[0] if following.size else len(stand) - d - 2)
        sl = slice(d, end + 1)
        if end - d < 10:
            continue
        runs.append(Run(log.name, index, log.t[sl], log.x[sl], v[sl], cumulative(work[d:end]),
                        np.array([cumulative(row[d:end]) for row in trapezoid]), cumulative(fixed[d:end]),
                        smoothed(log.t[sl], v[sl]) > MIN_SPEED, bool(following.size)))
        index += 1
    if not runs:
        raise InputError(problem(log.path or log.name, "speed", "no run from a stand to a stand: the train never "
                                 f"stands (speed below {STANDING_SPEED} m/s without traction for {STANDING_TIME:g} s) "
                                 "and then moves"))
    return runs


def efficiency_samples(log, train):
    """(traction, regeneration) log-ratios ln(P_line / P_wheel) of intervals well inside a traction
    or an electric-braking phase (both neighbours alike; braking within the regeneration
    envelope, so that no friction brake hides in the wheel power); empty without a line power."""
    line = line_power(log)
    if line is None:
        return np.zeros(0), np.zeros(0)
    wheel = wheel_work(log) / np.diff(log.t)
    scale = TRACTION_SHARE * np.max(np.abs(wheel))
    inner = np.zeros(len(wheel), bool)
    inner[1:-1] = True
    pull = (wheel > scale) & (line > 0)
    pull &= inner & np.roll(pull, 1) & np.roll(pull, -1)
    brake = (wheel < -scale) & (line < 0)
    if train.regeneration is not None:
        v = 0.5 * (speeds(log)[1:] + speeds(log)[:-1])
        brake &= -wheel / np.maximum(v, 1.0) < 0.95 * train.regeneration.force(np.maximum(v, 0.1))
    brake &= inner & np.roll(brake, 1) & np.roll(brake, -1)
    return np.log(line[pull] / wheel[pull]), np.log(line[brake] / wheel[brake])


def idle_line_power(log):
    """The line power [W] of the intervals where the wheels draw none (standing, coasting: wheel power
    below :data:`IDLE_SHARE` of the log's largest), where the log has a line power and 20 such
    intervals or more; else None (:func:`auxiliary_power` is not judged)."""
    line = line_power(log)
    if line is None:
        return None
    wheel = wheel_work(log) / np.diff(log.t)
    idle = (np.abs(wheel) < IDLE_SHARE * np.max(np.abs(wheel))) & np.isfinite(line)
    return line[idle] if idle.sum() >= 20 else None


def auxiliary_power(log):
    """What the log's line power draws while the wheels draw none (:func:`idle_line_power`): a reason
    when its median is above :data:`AUX_SHARE` of the largest line power and :data:`AUX_ERRORS`
    standard errors above 0, else ''. The fitted efficiency is wheel work per line energy with no
    auxiliary term, so such a draw (heating, air conditioning, compressors) pulls it low by the draw
    over the traction power."""
    drawn = idle_line_power(log)
    if drawn is None:
        return ""
    median = float(np.median(drawn))
    error = 1.2533 * 1.4826 * float(np.median(np.abs(drawn - median))) / np.sqrt(drawn.size)
    if median <= AUX_SHARE * np.nanmax(np.abs(line_power(log))) or median <= AUX_ERRORS * error:
        return ""
    return (f"{log.line_column or 'the line power'} draws {median / 1e3:.3g} kW (median over {drawn.size} intervals) "
            "while the wheels draw none (standing, coasting): auxiliary power in the line power, which the "
            "efficiency (wheel work per line energy, no auxiliary term) absorbs, fitted too low")
