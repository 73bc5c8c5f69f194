"""The earliest stand on the mark from a state, in closed form: when SPPC's step one is known.

Farooqi 2018 Alg. 4's step one (eq. 5.22) asks, every sample, for the smallest end speed gamma the
measured state can reach and, among those plans, the earliest arrival. Wherever the train can
still stand on the mark before the timetable, its answer is gamma = 0 with an arrival before it,
and step two (eq. 5.23) is then the least-energy plan with the end speed within the tolerance and
the arrival by the timetable: the step one NLP only confirms what a cheaper reckoning shows.

:class:`EarliestStand` is that reckoning: the time-optimal run of eq. 2.7 (full traction forward
from the state, held at every speed limit, until it meets the stopping curve integrated backwards
from the mark under the plans' full service braking), on a fixed grid of about ``spacing`` metres
with the track's gradient, curve and limit changes among its nodes, the grade and Davis forces
per interval as ``core.kinematics`` takes them. Its time differs from the phases NLP's earliest
arrival by the grid and the NLP's smoothed envelopes (a few hundredths of a second on the
Amsterdam case, docs/closed_loop.md), so a caller keeps a margin.
"""
import numpy as np

from ecostudy.core.grid import Segment, node_limits
from ecostudy.core.kinematics import braking_curve, interval_davis, interval_grade_force
from ecostudy.core.physics import davis_resistance
from ecostudy.core.types import Train


class EarliestStand:
    """The earliest time to stand on the mark [s] from (position [m], speed [m/s]), or inf; and
    whether the train is over a limit it cannot coast under (:meth:`coasting_over_limit`)."""

    def __init__(self, segment: Segment, train: Train, spacing: float = 2.0) -> None:
        n = max(int(np.ceil(segment.distance / spacing)), 1)
        nodes = np.union1d(np.linspace(0.0, segment.distance, n + 1), segment.breakpoints())
        limits = node_limits(segment, nodes)
        self.train, self.nodes, self.limits = train, nodes, limits
        self.curve = braking_curve(segment, train, nodes, limits)
        self.interval_limits = np.asarray(segment.limit(0.5 * (nodes[:-1] + nodes[1:])), float)
        fixed = interval_grade_force(segment, train, nodes)
        a, b, c = interval_davis(segment, train, nodes)
        self.forces = [(float(a[k]), float(b[k]), float(c[k]), float(fixed[k])) for k in range(len(nodes) - 1)]

    def _curve_at(self, curve: np.ndarray, position: float) -> tuple[int, float]:
        """(the first node ahead of ``position``, the speed [m/s] from which full service braking over
        the rest of its interval reaches ``curve`` there: the limit of the node behind not counted)."""
        x = self.nodes
        j = int(np.searchsorted(x, position, side="right"))
        if j >= len(x):
            return j, float(curve[-1])
        a, b, c, fixed = self.forces[j - 1]
        v = float(curve[j])
        dec = min((self.train.braking.force(v) + davis_resistance(v, a, b, c) + fixed) / self.train.mass,
                  self.train.max_deceleration)
        return j, float(np.sqrt(v * v + 2 * (x[j] - position) * max(dec, 1e-3)))

    def coasting_over_limit(self, position: float, speed: float, tolerance: float = 1e-3) -> bool:
        """Whether the train runs over the limit where it is (by more than ``tolerance`` [m/s]) on a
        stretch where coasting does not slow it (the grade pulls at least as hard as the running
        resistance holds back). There no plan of SPPC's phases NLP exists: every node ahead of the
        train must be under the limit, and a sector brakes only in its last phase, after phases that
        at best coast (``ocp.phases``)."""
        j = min(max(int(np.searchsorted(self.nodes, position, side="right")), 1), len(self.nodes) - 1)
        a, b, c, fixed = self.forces[j - 1]
        return speed > self.interval_limits[j - 1] + tolerance and davis_resistance(speed, a, b, c) + fixed <= 0.0

    def __call__(self, position: float, speed: float) -> float:
        x, curve = self.nodes, self.curve
        j, highest = self._curve_at(curve, position)
        if j >= len(x):
            return 0.0 if speed <= 0.05 else float("inf")
        if speed > highest + 1e-6:
            return float("inf")  # above the stopping curve: no stand on the mark
        train, mass, top = self.train, self.train.mass, self.train.max_acceleration
        v, here, seconds = max(speed, 0.0), position, 0.0
        for k in range(j, len(x)):
            a, b, c, fixed = self.forces[k - 1]
            ds = x[k] - here
            acc = min((train.traction.force(v) - davis_resistance(v, a, b, c) - fixed) / mass, top)
            v2 = v * v + 2 * ds * acc
            if v2 <= 0.0 and k < len(x) - 1 and curve[k] > 0.0:
                return float("inf")  # full traction stalls
            nxt = min(float(np.sqrt(max(v2, 0.0))), self.limits[k], curve[k])
            seconds += 2 * ds / max(v + nxt, 1e-9)
            v, here = nxt, x[k]
        return seconds
