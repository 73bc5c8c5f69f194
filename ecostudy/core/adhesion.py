"""Adhesion: the force a train's driven wheels can transmit to the rail, mu(v) m_adh g.

- :func:`curtius_kniffler`: Curtius & Kniffler's dry-rail coefficient mu = 0.161 + 7.5 / (v + 44),
  v in km/h (the one copy; the heavy-haul plant reads it from here).
- :class:`Adhesion`: a point-mass train's adhesive mass (the mass on its driven axles) and its law
  of mu over speed (Curtius & Kniffler's, or a constant).
- :func:`capped`: an envelope capped at that limit, once, as a speed-force table, so every
  formulation and the plant see the same curve (the train file's ``adhesion`` field, read by
  :mod:`ecostudy.io.loaders`).
- :func:`use`: how much of the limit a run's forces ask for (1: all of it), the check of a run.
"""
import warnings
from dataclasses import dataclass
from os import PathLike

import numpy as np

from ecostudy.core.errors import EcostudyWarning, problem
from ecostudy.core.physics import GRAVITY, Envelope, table_width
from ecostudy.core.units import KMH, FloatArray, Numeric

# a run whose traction or electric braking asks more than 1 + this share of mu(v) m_adh g is flagged
# (a point-mass train, and a heavy-haul locomotive: heavyhaul.metrics.ADHESION): the capped table is
# within CAP_TOLERANCE of the cap between its points and its rounded kinks add as much again
# (physics.table_width), so 1 % is well clear of the cap's own error
TOLERANCE = 0.01
CAP_TOLERANCE = 0.001  # a capped table's linear interpolation within 0.1 % of min(envelope, mu m g)
CAP_SAMPLES = 4001     # speeds at which the capped curve is sampled from 0 to the top speed
TOP_SPEED = 400 * KMH  # the capped table's last speed for a train without a top speed [m/s]


def curtius_kniffler(speed: Numeric) -> Numeric:
    """Adhesion coefficient of dry rail [-] at ``speed`` [m/s]: Curtius & Kniffler's
    mu = 0.161 + 7.5 / (v + 44), v in km/h (0.33 at rest, 0.22 at 80 km/h)."""
    return 0.161 + 7.5 / (3.6 * abs(speed) + 44.0)


@dataclass(frozen=True)
class Adhesion:
    """The adhesion limit of a point-mass train: mu(v) ``mass`` g, ``mass`` the adhesive mass [kg]
    (on the driven axles), ``law`` ``"curtius_kniffler"`` or ``"constant"`` (``mu`` [-])."""

    mass: float
    law: str = "curtius_kniffler"
    mu: float | None = None

    def __post_init__(self) -> None:
        if self.law not in ("curtius_kniffler", "constant") or (self.law == "constant") != (self.mu is not None):
            raise ValueError(f"adhesion: law 'curtius_kniffler', or 'constant' with its mu (not {self.law!r}, mu {self.mu})")

    def coefficient(self, speed: Numeric) -> Numeric:
        """mu at ``speed`` [m/s]."""
        if self.mu is not None:  # the constant law
            return self.mu + 0.0 * speed
        return curtius_kniffler(speed)

    def limit(self, speed: Numeric) -> Numeric:
        """mu(v) m_adh g [N] at ``speed`` [m/s]."""
        return self.coefficient(speed) * self.mass * GRAVITY

    def describe(self) -> str:
        """The law and the adhesive mass in words, for warnings and flags."""
        law = "Curtius & Kniffler" if self.law == "curtius_kniffler" else f"mu {self.mu:g}"
        return f"{law}, {self.mass / 1000.0:g} t adhesive"


def _knots(speeds: FloatArray, forces: FloatArray, tolerance: float, breaks: FloatArray) -> list[int]:
    """Indices of the fewest samples (greedily) whose linear interpolation stays within
    ``tolerance`` (relative) of ``forces`` at every sample; every speed of ``breaks`` (kinks of
    the curve, among ``speeds``) is one of them."""
    knots, i, last = [0], 0, len(speeds) - 1
    fixed = set(np.searchsorted(speeds, breaks).tolist()) | {last}
    scale = np.maximum(np.abs(forces), 1e-3 * float(np.max(np.abs(forces))))
    while i < last:
        j = i + 1
        while j not in fixed:
            k = j + 1
            chord = np.interp(speeds[i:k + 1], [speeds[i], speeds[k]], [forces[i], forces[k]])
            if np.max(np.abs(chord - forces[i:k + 1]) / scale[i:k + 1]) > tolerance:
                break
            j = k
        knots.append(j)
        i = j
    return knots


def capped(envelope: Envelope, limit: "Adhesion", top: float) -> tuple[Envelope, tuple[float, float] | None]:
    """(``envelope`` capped at ``limit`` up to ``top`` [m/s], (lowest, highest) speed where the cap
    binds [m/s], or None and ``envelope`` itself where it never does).

    The capped curve min(envelope(v), mu(v) m_adh g) is sampled at :data:`CAP_SAMPLES` speeds from 0
    to ``top`` and kept as a table of the fewest of them whose linear interpolation stays within
    :data:`CAP_TOLERANCE` of it; beyond ``top`` the table holds its last force (the grip keeps
    falling: a run faster than ``top`` is left to the check of runs, :func:`use`). A table
    envelope is read as the file means it, linear between its points.
    """
    if envelope.kind == "table":
        kinks = np.asarray(envelope.speeds, float)
    else:  # the corner of a force and a power limit
        kinks = np.array([envelope.max_power / envelope.max_force]) if np.isfinite(envelope.max_power) else np.array([])
    kinks = kinks[(kinks > 0) & (kinks < top)]
    speeds = np.union1d(np.linspace(0.0, top, CAP_SAMPLES), kinks)
    if envelope.kind == "table":
        full = np.interp(speeds, envelope.speeds, envelope.forces)
    else:
        full = np.asarray(envelope.force(speeds), float)
    grip = np.asarray(limit.limit(speeds), float)
    binds = grip < full * (1.0 - 1e-9)
    if not binds.any():
        return envelope, None
    forces = np.minimum(full, grip)
    crossings = speeds[1:][np.diff(binds.astype(int)) != 0]  # where the cap starts or stops binding
    keep = _knots(speeds, forces, CAP_TOLERANCE, np.union1d(kinks, crossings))
    v, f = speeds[keep], forces[keep]
    table = Envelope("table", speeds=tuple(v.tolist()), forces=tuple(f.tolist()), width=table_width(v, f))
    return table, (float(speeds[binds][0]), float(speeds[binds][-1]))


def capped_envelopes(traction: Envelope, regeneration: Envelope | None, limit: "Adhesion", top: float,
                     where: str | PathLike[str]) -> tuple[Envelope, Envelope | None]:
    """A train's traction envelope and electric brake (None: none) capped at ``limit`` up to ``top``
    [m/s] (:func:`capped`), each with a warning where the cap binds (``where``: the train file)."""
    return (capped_warned(traction, limit, top, "traction envelope", where),
            None if regeneration is None else capped_warned(regeneration, limit, top, "regenerative braking", where))


def capped_warned(envelope: Envelope, limit: "Adhesion", top: float, what: str, where: str | PathLike[str]) -> Envelope:
    """:func:`capped`, with a warning naming the file, ``what`` was capped and the speeds where the
    cap binds."""
    out, binds = capped(envelope, limit, top)
    if binds is not None:
        low, high, end = binds[0] / KMH, binds[1] / KMH, top / KMH
        start = low < 0.5  # from rest, as the message rounds it
        speeds = (f"below {high:.0f} km/h" if start and high < end - 0.5
                  else f"at every speed up to {high:.0f} km/h" if start else f"from {low:.0f} to {high:.0f} km/h")
        warnings.warn(problem(where, "adhesion", f"{what} above adhesion ({limit.describe()}) {speeds}: capped there"),
                      EcostudyWarning, stacklevel=5)
    return out


def use(limit: "Adhesion", speed: Numeric, force: Numeric) -> FloatArray:
    """|force| / (mu(v) m_adh g) at each ``speed`` [m/s] and ``force`` [N] (arrays): the share of the
    adhesion limit the force asks for."""
    share: FloatArray = np.abs(np.asarray(force, float)) / np.asarray(limit.limit(np.asarray(speed, float)), float)
    return share
