"""RSPC: receding-horizon switched predictive control (Farooqi 2018 Ch. 6, Alg. 5 and the adaptive Alg. 6).

Every sample the controller enumerates the switching sequences chi = [sigma(0|k), ..., sigma(N-1|k)]
over the six DAS modes of Remark 6.1.1 (traction at each DAS level, cruise, coast, full service
braking), predicts each with the space-domain model (6.2)-(6.3), drops those that leave the
admissible set X (6.4: below the limits, here below the limits' braking curve so that a limit drop
beyond the horizon can still be met; the train may not stop short) and applies the first mode of
the cheapest (6.11-6.12). No solver: 6^N sequences per sample (``ocp.phases.sequences``), pruned as they
become infeasible, which is why the thesis keeps N short. Cost (6.7)-(6.8):

    J = sum_j (D_j / D) (1 - gamma_S) ((F_T - F_R) / F_Tmax)^2
        + gamma_S ((x1(0|k) + T_horizon - x1(N|k)) / T_horizon)^2

(the stage weight D_j / D is 1 for steps of the nominal length D and keeps a short step from
counting as a whole one). T_horizon (Remark 6.2.1, "a heuristic"): the time a reference run takes
over the horizon's distance, scaled by the time left over the reference's time to the stop; the
reference is the industrial eco-drive coasting run of Table 6.1 (full traction under the limits,
coasting from the earliest point that meets the timetable less ``margin``), so the short horizon
follows a run that coasts where coasting pays, and a late train gets a shorter T_horizon.

Adaptive sampling (Alg. 6): prediction steps are D metres long but never cross a sector boundary
(a change of gradient, curve or limit; a step ends at the boundary, so the remaining sector
length D_Gamma(k) < D sets that step, rows 1-2); the first step is the distance the train runs
in one loop sample (v T_s), because the loop holds the applied handle for T_s: where that run
crosses a sector end it is predicted in pieces under the same handle. Braking (row 3,
eqs. 6.15-6.16): when coasting one more sample would leave the train above the stopping curve
(the braking distance D_b reaches the remaining distance D_p: delta D <= 0), the controller
brakes in full; from then on it brakes while that holds and coasts otherwise, so the stop is
re-checked every sample against the measured state. The stopping curve is integrated with the
model's braking envelope less ``brake_reserve`` (not eq. 6.15's one-step estimate at the current
speed), so a train whose brakes are weaker than the model's still stops at the mark.

The prediction integrates (6.2) in kinetic energy: v(j+1)^2 = v(j)^2 + 2 D_j a(j), time
2 D_j / (v(j) + v(j+1)); this is (6.2) to first order and has no singularity at a stand.
"""
import time

import numpy as np

from ecostudy.control.controllers import handle_of
from ecostudy.control.fallback import Fallback
from ecostudy.core import kinematics
from ecostudy.core.physics import acceleration, davis_resistance
from ecostudy.core.plant import Cruise, Plant
from ecostudy.ocp.phases import rspc_modes


class Rspc(Fallback):
    """``case``: a prepared case (``ocp.problem.prepare``: segment, nominal train, grid, limits);
    ``arrival``: the timetabled arrival [s] on the trip's clock; ``sample_time``: the loop's T_s
    [s]; ``horizon``: N; ``distance``: D [m]; ``gamma``: gamma_S of (6.7)."""

    def __init__(self, case, arrival, sample_time, horizon=3, distance=25.0, gamma=0.995, margin=1.5,
                 brake_reserve=0.2, final_m=0.3):
        if horizon < 1:
            raise ValueError(f"horizon must be at least 1, not {horizon}")
        if distance <= 0:
            raise ValueError(f"distance must be positive, not {distance}")
        self.case, self.arrival, self.ts, self.n, self.d = case, float(arrival), float(sample_time), int(horizon), float(distance)
        self.gamma, self.margin, self.final_m = float(gamma), float(margin), float(final_m)
        train, segment, nodes = case.train, case.segment, case.nodes
        self.model = Plant(segment, train)
        self.modes = rspc_modes(train)
        self.coast = next(m for m in self.modes if m.kind == "coast")
        self.brake = min((m for m in self.modes if m.kind == "brake"), key=lambda m: m.level)  # the strongest
        self.f_max = train.traction.peak
        self.edges = np.concatenate([segment.breakpoints(), [segment.distance]])
        reserved = train.with_brake_reserve(brake_reserve)
        # the admissible speeds: below every limit's braking curve (not the stop's: row 3 handles it)
        self.cap_sq = kinematics.braking_curve(segment, reserved, nodes, case.limits, end_speed=np.inf) ** 2
        self.stop_sq = kinematics.braking_curve(segment, reserved, nodes, np.full_like(nodes, np.inf)) ** 2
        reference, run = self._reference(self.arrival - margin)
        self.t_ref, self.t_run = kinematics.clock(reference, nodes), kinematics.clock(run, nodes)
        self.braking, self.chosen = False, []
        self._start_records()

    # ------------------------------------------------------------------ the model
    def _accel(self, x_mid, v, control):
        """(dv/dt [m/s^2], F_T [N], F_R [N]) of ``control`` (a handle, or a mode: cruise holds the
        speed it is at) at speed ``v`` in the sector around ``x_mid``."""
        m = self.model
        a, b, c = m.davis
        resist = davis_resistance(v, a, b, c + m.tunnel(x_mid)) + m.grade_force(x_mid)
        if not isinstance(control, float):
            control = Cruise(v) if control.kind == "cruise" else control.level
        ft, fb = m.forces(v, control, resist)
        return acceleration(ft, fb, resist, m.mass), ft, resist

    def handle(self, position, speed, mode):
        """The handle ``mode`` applies from the measured state, held for the sample: its DAS level;
        cruise: the handle whose force holds the measured speed there."""
        if mode.kind != "cruise":
            return float(mode.level)
        resist = self._accel(position, speed, mode)[2]
        return handle_of(self.case.train, speed, *self.model.forces(speed, Cruise(speed), resist))

    def _reference(self, target):
        """(the reference run, the run T_horizon is taken from) [m/s] on the case's grid: the
        eco-drive coasting profile (full traction, coasting from the earliest point that still
        arrives by ``target``, the stopping curve) with the braking reserve; the second without the
        stop's braking (row 3 brakes for the stop: a horizon reaching into the reference's braking
        would ask the train to slow early), floored at 1 m/s where coasting would end at a stand."""
        c, train, nodes = self.case, self.case.train, self.case.nodes
        fastest = np.minimum(c.envelope, np.sqrt(np.minimum(self.cap_sq, self.stop_sq)))

        def profile(k):
            return kinematics.coasting_profile(c.segment, train, nodes, c.limits, fastest, k)

        def meets(k):
            return kinematics.running_time(profile(k), nodes) <= target

        last = len(nodes) - 1  # if not even the latest coasting point meets the target: no coasting
        hi = kinematics.earliest_coasting_point(meets, last, first=0) if meets(last) else last
        reference = profile(hi)
        coast = kinematics.coast_speeds(c.segment, train, nodes, c.limits, hi, fastest[hi])
        run = reference.copy()
        run[hi:] = np.maximum(np.maximum(reference[hi:], np.minimum(coast[hi:], np.sqrt(self.cap_sq[hi:]))), 1.0)
        return reference, run

    def steps(self, position, speed):
        """(start positions, lengths, how many of them the first sample covers) of the prediction
        (Alg. 6's adaptive sampling): the sample's run v T_s, cut where sectors end (its handle is
        held across), then N - 1 steps of D, each ending at a sector end it would cross."""
        starts, lengths, x, held = [], [], position, 0
        wants = [max(speed * self.ts, 0.5)] + [self.d] * (self.n - 1)
        for j, want in enumerate(wants):
            while want > 1e-6 and x < self.edges[-1] - 1e-6:
                edge = self.edges[np.searchsorted(self.edges, x + 1e-6)]
                step = min(want, edge - x)
                starts.append(x)
                lengths.append(step)
                x, want = x + step, (want - step if j == 0 else 0.0)  # the sample's run goes on
            if j == 0:
                held = len(starts)
        return starts, lengths, held

    def horizon_time(self, position, clock, end):
        """T_horizon (Remark 6.2.1; module docstring) for the run from ``position`` to ``end`` [s]."""
        t_x, t_stop = np.interp([position, self.case.nodes[-1]], self.case.nodes, self.t_ref)
        run_x, run_end = np.interp([position, end], self.case.nodes, self.t_run)
        ahead = t_stop - t_x
        scale = (self.arrival - self.margin - clock) / ahead if ahead > 1e-9 else 1.0
        return max((run_end - run_x) * max(scale, 0.05), 1e-3)

    def best(self, position, speed, clock):
        """(cost, first mode) of the cheapest admissible sequence of (6.9), or None."""
        starts, lengths, held = self.steps(position, speed)
        if not starts:
            return None
        end = starts[-1] + lengths[-1]
        t_h = self.horizon_time(position, clock, end)
        cap = np.interp(np.array(starts[1:] + [end]), self.case.nodes, self.cap_sq)
        found = [np.inf, None]
        first_handles = [(mode, self.handle(position, speed, mode)) for mode in self.modes]

        def expand(j, v, t, cost, first):
            if j == len(starts):
                total = cost + self.gamma * ((clock + t_h - t) / t_h) ** 2
                if total < found[0]:
                    found[0], found[1] = total, first[0]
                return
            x_mid = starts[j] + 0.5 * lengths[j]
            # within the first sample the plant holds one handle; after it, one mode per step
            choices = first_handles if j == 0 else [first] if j < held else [(m, m) for m in self.modes]
            for mode, control in choices:
                acc, ft, resist = self._accel(x_mid, v, control)
                v2 = v * v + 2.0 * lengths[j] * acc
                if v2 <= 0.0 or v2 > cap[j]:  # stops short, or above a limit's braking curve
                    continue
                w = np.sqrt(v2)
                stage = (1.0 - self.gamma) * (lengths[j] / self.d) * ((ft - resist) / self.f_max) ** 2
                expand(j + 1, w, t + 2.0 * lengths[j] / (v + w), cost + stage, (mode, control) if j == 0 else first)

        expand(0, max(speed, 0.0), clock, 0.0, None)
        return None if found[1] is None else found

    def must_brake(self, position, speed):
        """Alg. 6 row 3: coasting one more sample would leave the train above the stopping curve."""
        x_mid = position + 0.5 * max(speed * self.ts, 0.0)
        acc = self._accel(x_mid, speed, self.coast)[0]
        run = speed * self.ts
        v2 = speed * speed + 2.0 * run * acc
        return v2 >= float(np.interp(position + run, self.case.nodes, self.stop_sq))

    # ------------------------------------------------------------------ the controller
    def plan(self, measured):
        distance = self.case.segment.distance
        x, v = min(max(measured.position, 0.0), distance), max(measured.speed, 0.0)
        if x >= distance - self.final_m:
            self.without_solve("final")
            return -1.0
        t0, status = time.perf_counter(), "ok"
        if self.must_brake(x, v):
            self.braking, mode, status = True, self.brake, "stopping_curve"
        elif self.braking:
            mode = self.coast  # between the stopping curve's samples: coast
        else:
            found = self.best(x, v, measured.time)
            mode = None if found is None else found[1]
        self.solve_seconds.append(time.perf_counter() - t0)
        # no admissible sequence: every sequence, the last one's tail among them, leaves X from the
        # measured state, so no shifted plan holds there: full braking (the safe mode)
        if mode is None:
            self.failures += 1
            handle, kind = self.fall_back(measured)
            self.chosen.append(self.brake.kind)
            self.record("no_sequence", self.solve_seconds[-1], fallback=kind)
            return handle
        self.chosen.append(mode.kind if mode.kind != "traction" else f"traction {mode.level:g}")
        self.record(status, self.solve_seconds[-1])
        return self.handle(x, v, mode)
