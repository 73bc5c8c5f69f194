"""Heavy haul: where K_b puts the braking and what eq. 4's terms say about it, sample by sample
(Zhang & Zhuan, "Braking penalized receding horizon control of heavy haul trains", eqs. 4-8, 11).

    python bench/heavyhaul_split.py heavyhaul_brake_penalty_rolling --kb 1 60
    python bench/heavyhaul_split.py heavyhaul_brake_penalty_rolling --kb 1 60 --integral
    python bench/heavyhaul_split.py heavyhaul_brake_penalty_rolling --kb 1 60 --brake-on all

Per K_b: the run's numbers (the largest braking-sample force, E, tracking, the head and rear
locomotive groups' dynamic braking), then the braking samples with the largest in-train forces:
each locomotive group's effort and dynamic-brake limit, the wagons' braking, eq. 4's terms at the
sample's optimum, the QP's predicted force at the virtual couplers next to the locomotives against
the plant's real couplers there at the sample's end, and the plant's largest force in the sample
(where). "without dynamic braking": the same QP at the same sample with the locomotives' braking
held off (their lower bound 0): its terms and its predicted largest force, i.e. what the optimum
traded. ``--integral``: eq. 4's force term integrated over each sample under the zero-order hold
(Van Loan) instead of taken at the sample ends: tried, not adopted (docs/heavyhaul.md). ``--brake-on all``:
the study's cases with ``brake_penalty_on: all`` (K_b on the locomotives' dynamic braking too).
"""
import argparse
import sys
import warnings
from multiprocessing import Pool
from pathlib import Path

import numpy as np
from scipy.linalg import expm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ecostudy.core.errors import EcostudyWarning  # noqa: E402
from ecostudy.core.units import KN, KWH  # noqa: E402
from ecostudy.heavyhaul import condensed  # noqa: E402
from ecostudy.heavyhaul.linear import fence  # noqa: E402
from ecostudy.heavyhaul.metrics import braking_samples  # noqa: E402
from ecostudy.heavyhaul.rhc import TERMS, objective_values, sample_inputs  # noqa: E402
from ecostudy.studies import heavyhaul as study  # noqa: E402


def force_integral(model, terms):
    """W with the mean over a sample of K_f sum s_j f_j^2 / 1e4 = [x; u - o]' W [x; u - o] (the design
    model's continuous form held over Ts: Van Loan's block exponential)."""
    n, m = model.Bc.shape
    F = np.zeros((n + m, n + m))
    F[:n, :n], F[:n, n:] = model.Ac, model.Bc * KN
    Q = np.zeros((n + m, n + m))
    Q[m:n, m:n] = np.diag(terms.kf * terms.stiff ** 2 / 1e4)  # the coupler extensions follow the m speeds
    C = np.zeros((2 * (n + m), 2 * (n + m)))
    C[:n + m, :n + m], C[:n + m, n + m:], C[n + m:, n + m:] = -F.T, Q, F
    E = expm(C * model.ts)
    W = E[n + m:, n + m:].T @ E[:n + m, n + m:] / model.ts
    return 0.5 * (W + W.T)


class Recorded(condensed.CondensedHorizon):
    """The condensed QP, recording each sample's optimum and its counterfactual without dynamic braking;
    ``integral``: the force term over each whole sample (:func:`force_integral`)."""

    integral = False

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.args, self.samples = (args, kwargs), []
        if self.integral:
            n, nu, t = self.n, self.nc * self.n, self.terms
            self.W = force_integral(self.model, t)
            self.H = []
            for k in range(self.np_):
                select = np.zeros((n, nu))
                move = min(k, self.nc - 1)
                select[:, move * n:(move + 1) * n] = np.eye(n)
                self.H.append(np.vstack([np.zeros((2 * n - 1, nu)) if k == 0 else self.G[k - 1], select]))
            self.q = np.concatenate([t.kv, np.zeros(n - 1)])  # the speeds at the sample ends only
            effort = np.zeros(nu)
            for k in range(self.np_):
                move = min(k, self.nc - 1)
                effort[move * n:(move + 1) * n] += t.ke * t.penalty / 1e4
            hessian = 2 * self.scale * (sum(g.T @ (self.q[:, None] * g) for g in self.G) + np.diag(effort)
                                        + sum(h.T @ self.W @ h for h in self.H))
            self.solver = type(self.solver)(hessian, self.rows)
        inner = self.solver.solve

        def solve(g, lo, hi, rows, c_lo, c_hi):
            u, status, its = inner(g + self.extra, lo, hi, rows, c_lo, c_hi)
            self.u = np.asarray(u)[:self.nc * self.n].copy()  # the moves (brake_penalty_on: all's variables after them)
            return u, status, its
        self.solver.solve, self.extra = solve, 0.0

    def _free(self, state, offsets_kN):
        """d(k): the predicted states with no input, k = 1..Np."""
        offsets = np.broadcast_to(np.atleast_2d(offsets_kN), (self.np_, self.n))
        shifts = [self.AB[0] @ offsets[j] for j in range(self.np_)]
        state = np.asarray(state, float)
        return offsets, np.array([self.powers[k] @ state - sum(self.powers[k - 1 - j] @ shifts[j] for j in range(k))
                                  for k in range(1, self.np_ + 1)])

    def solve(self, state, offsets_kN, low_kN, high_kN, reference):
        offsets, d = self._free(state, offsets_kN)
        if self.integral:
            z = [np.concatenate([np.asarray(state, float) if k == 0 else d[k - 1], -offsets[k]]) for k in range(self.np_)]
            self.extra = 2 * self.scale * sum(h.T @ (self.W @ zk) for h, zk in zip(self.H, z))
        previous = self.previous.copy()
        first = super().solve(state, offsets_kN, low_kN, high_kN, reference)
        row = {"optimum": self.evaluate(self.u, d, reference, low_kN, high_kN)}
        if np.any(self.u[:self.n][self.locos] < -1.0):  # the same QP with the dynamic brakes held off
            twin = type(self)(*self.args[0], **self.args[1])
            twin.previous = previous
            low = np.array(low_kN, float)
            low[self.locos] = 0.0
            twin.solve(state, offsets_kN, low, high_kN, reference)
            row["without dynamic braking"] = twin.samples[-1]["optimum"]
        self.samples.append(row)
        return first

    def evaluate(self, u, d, reference, low_kN, high_kN):
        n, np_, nc = self.n, self.np_, self.nc
        _, vr, _ = sample_inputs(self, np.zeros(n), low_kN, high_kN, reference)
        predicted = np.array([self.G[k] @ u + d[k] for k in range(np_)])
        values = objective_values(self.terms, self.wagons, predicted, u.reshape(nc, n), vr, self.model.ts)
        forces = predicted[:, n:] * self.terms.stiff
        return {"terms": [values[t] for t in TERMS], "first": u[:n].copy(), "largest": float(np.abs(forces).max()),
                "ends": (float(forces[0, 0]), float(forces[0, -1]))}


class RecordedIntegral(Recorded):
    integral = True


def one(job):
    path, kb, integral, top, brake_on = job
    study.QP_FORMS["daqp"] = RecordedIntegral if integral else Recorded
    _, _, _, cases = study.expand(path)
    case = {**next(c for c in cases if c["labels"]["K_b"] == kb), "brake_penalty_on": brake_on}
    consist, controller, record, reference, plant = study.drive(case)
    s = study.summarise(consist, controller, record, reference, plant.segment.distance, controller.locos)
    locos = controller.locos
    e = record.efforts / KN
    v = 0.5 * (record.mean_speed + np.concatenate([[0.0], record.mean_speed[:-1]]))
    dynamic = [np.sum(np.maximum(-e[:, j], 0.0) * v * np.diff(record.times, prepend=0.0)) * KN / KWH for j in locos]
    lines = [f"K_b = {kb:g}{' (force term integrated over each sample)' if integral else ''}: force_max_braking "
             f"{s['force_max_braking_kN']:.1f} kN ({s['braking_samples']} samples), E {s['energy_total_kWh']:.0f} kWh "
             f"(traction {s['traction_kWh']:.0f}, wagons {s['wagon_brake_kWh']:.0f}, dynamic {s['dynamic_brake_kWh']:.0f}), "
             f"tracking {s['tracking_mean_mps']:.4f} m/s, stretch {s['stretch_braking_samples']} samples / "
             f"{s['stretch_braking_kWh']:.1f} kWh; dynamic braking head / rear group {dynamic[0]:.0f} / {dynamic[-1]:.0f} kWh "
             f"(effort x mean speed)"]
    braking = braking_samples(record.efforts, locos)
    times = np.concatenate([t for t, _ in plant.history])
    forces = np.concatenate([f for _, f in plant.history]) / KN
    boundary = [cars[-1] for cars in fence(consist, case["labels"]["f"], case["sample_time"]).members[:-1]]
    for k in sorted(np.argsort(np.where(braking, record.largest_coupler, 0.0))[::-1][:top]):
        if not braking[k]:
            continue
        row, ends = controller.samples[k], record.couplers[k][[boundary[0], boundary[-1]]] / KN
        opt = row["optimum"]
        inside = (times > (record.times[k - 1] if k else -1.0)) & (times <= record.times[k] + 1e-9)
        point, coupler = np.unravel_index(np.argmax(np.abs(forces[inside])), forces[inside].shape)
        lines.append(
            f"  sample {k} ({record.times[k]:.0f} s, head {record.head[k]:.0f} m, {record.mean_speed[k]:.2f} m/s): "
            f"locomotives head {e[k, locos[0]]:.0f} / rear {e[k, locos[-1]]:.0f} kN (dynamic limits "
            f"{record.dynamic_limits[k][0] / KN:.0f} / {record.dynamic_limits[k][-1] / KN:.0f}), wagons "
            f"{np.delete(e[k], locos).sum():.0f} kN; plant largest {record.largest_coupler[k] / KN:.1f} kN in the sample"
            f" (coupler {coupler + 1} at {times[inside][point]:.1f} s), at its end {ends[0]:.0f} / {ends[1]:.0f} kN at the couplers next "
            f"to the head / rear locomotives; QP predicted there {opt['ends'][0]:.0f} / {opt['ends'][1]:.0f} kN")
        for name, r in row.items():
            lines.append(f"    {name}: first move head {r['first'][locos[0]]:.0f} rear {r['first'][locos[-1]]:.0f} wagons "
                         f"{np.delete(r['first'], locos).sum():.0f} kN; " + " ".join(
                             f"J_{t} {x:.1f}" for t, x in zip(TERMS, r["terms"]))
                         + f" (sum {sum(r['terms']):.1f}); largest predicted force {r['largest']:.0f} kN")
    return "\n".join(lines)


if __name__ == "__main__":
    warnings.simplefilter("ignore", EcostudyWarning)
    parser = argparse.ArgumentParser()
    parser.add_argument("study", help="a study name in studies/ (Np, Nc, f and the scale as it says)")
    parser.add_argument("--kb", type=float, nargs="+", default=[1.0, 60.0])
    parser.add_argument("--top", type=int, default=4, help="braking samples shown (the largest forces)")
    parser.add_argument("--integral", action="store_true", help="eq. 4's force term over each whole sample")
    parser.add_argument("--brake-on", choices=["wagons", "all"], default="wagons", help="the study's brake_penalty_on")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    jobs = [(ROOT / "studies" / f"{args.study}.yaml", kb, args.integral, args.top, args.brake_on) for kb in args.kb]
    with Pool(min(args.workers, len(jobs))) as pool:
        for text in pool.map(one, jobs):
            print(text)
