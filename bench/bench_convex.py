"""Yazhemsky 2017's convex controller: one SOCP solve by Clarabel, ECOS and Ipopt (same program), and
the solve time per control step in closed loop at several K.

    .venv/bin/python bench/bench_convex.py [--repeat 5] [--loop-points 250 500 1000]

Part 1: the Fig. 9.2 program (advanced 1 km trip, weights 10/1) from a stand at K = 500, solved
``--repeat`` times by each solver in this process: median wall time [ms], iterations, the optimal
arrival time and the relaxation gap max |rho s - 1| (exactness), the objective's difference from
Clarabel's. Ipopt (Debian's, through cyipopt) solves the same rows with the cone written as
rho s >= 1 (s, rho >= 0), exact first and second derivatives, warm-started nowhere.
Part 2: the Fig. 9.2 trip in closed loop (10 Hz, plant DOP853) at each K: solve time per step
(mean, p95, max), steps over the 100 ms budget, arrival, energy, stop error.
"""
import argparse
import functools
import sys
from pathlib import Path

import numpy as np
from scipy import sparse

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import clarabel  # noqa: E402
import cyipopt  # noqa: E402
import ecos  # noqa: E402

from bench import harness  # noqa: E402
from ecostudy.control.controllers import Convex  # noqa: E402
from ecostudy.control.loop import run_loop  # noqa: E402
from ecostudy.core.grid import make_segment  # noqa: E402
from ecostudy.core.plant import Plant  # noqa: E402
from ecostudy.core.types import State  # noqa: E402
from ecostudy.core.units import number, signed  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp.convex import ConvexProgram, ConvexWeights, trapezoid_grid  # noqa: E402


def split(A, b, cones):
    """(equality rows, inequality rows, cone rows as (first, third component) matrices)."""
    dims = [(type(c).__name__, c.dim) for c in cones]
    n_eq = sum(d for k, d in dims if k == "ZeroConeT")
    n_le = sum(d for k, d in dims if k == "NonnegativeConeT")
    A = A.tocsr()
    soc = np.arange(n_eq + n_le, A.shape[0]).reshape(-1, 3)
    return (A[:n_eq], b[:n_eq]), (A[n_eq:n_eq + n_le], b[n_eq:n_eq + n_le]), (A[soc[:, 0]], A[soc[:, 2]], soc)


def solve_ecos(A, b, q, cones):
    (Ae, be), (Al, bl), (_, _, soc) = split(A, b, cones)
    G = sparse.vstack([Al, A.tocsr()[soc.ravel()]]).tocsc()
    h = np.concatenate([bl, b[soc.ravel()]])
    out = ecos.solve(q, G, h, {"l": Al.shape[0], "q": [3] * soc.shape[0]}, Ae.tocsc(), be, verbose=False)
    return out["x"], out["info"]["iter"]


class IpoptSocp:
    """The same program for Ipopt: linear rows plus rho s >= 1 per cone, from Clarabel's rows:
    the cone's first component is s + rho = -A0 z, its third s - rho = -A2 z, so
    rho s = ((A0 z)^2 - (A2 z)^2) / 4."""

    def __init__(self, A, b, q, cones):
        (self.Ae, self.be), (self.Al, self.bl), (self.A0, self.A2, _) = split(A, b, cones)
        self.q = q
        self.lin = sparse.vstack([self.Ae, self.Al]).tocsr()
        pattern = (abs(self.A0) + abs(self.A2)).tocoo()
        self.jrows = np.concatenate([self.lin.tocoo().row, pattern.row + self.lin.shape[0]])
        self.jcols = np.concatenate([self.lin.tocoo().col, pattern.col])
        self.pattern = pattern
        hp = sparse.tril(abs(self.A0).T @ abs(self.A0) + abs(self.A2).T @ abs(self.A2)).tocoo()
        self.hrows, self.hcols = hp.row, hp.col

    def objective(self, z):
        return float(self.q @ z)

    def gradient(self, z):
        return self.q

    def constraints(self, z):
        c0, c2 = self.A0 @ z, self.A2 @ z
        return np.concatenate([self.lin @ z, (c0 * c0 - c2 * c2) / 4.0])

    def jacobianstructure(self):
        return self.jrows, self.jcols

    def jacobian(self, z):
        c0, c2 = self.A0 @ z, self.A2 @ z
        J = (sparse.diags(c0 / 2.0) @ self.A0 - sparse.diags(c2 / 2.0) @ self.A2).tocsr()
        return np.concatenate([self.lin.tocoo().data, np.asarray(J[self.pattern.row, self.pattern.col]).ravel()])

    def hessianstructure(self):
        return self.hrows, self.hcols

    def hessian(self, z, lagrange, factor):
        lam = lagrange[self.lin.shape[0]:]
        H = (self.A0.T @ sparse.diags(lam / 2.0) @ self.A0 - self.A2.T @ sparse.diags(lam / 2.0) @ self.A2).tocsr()
        return np.asarray(H[self.hrows, self.hcols]).ravel()

    def solve(self):
        n = len(self.q)
        m = self.lin.shape[0] + self.A0.shape[0]
        cl = np.concatenate([self.be, -np.inf * np.ones(self.Al.shape[0]), np.ones(self.A0.shape[0])])
        cu = np.concatenate([self.be, self.bl, np.inf * np.ones(self.A0.shape[0])])
        nlp = cyipopt.Problem(n=n, m=m, problem_obj=self, lb=-np.inf * np.ones(n), ub=np.inf * np.ones(n), cl=cl, cu=cu)
        nlp.add_option("print_level", 0)
        nlp.add_option("sb", "yes")
        nlp.add_option("tol", 1e-8)
        z0 = np.ones(n)
        z, info = nlp.solve(z0)
        return z, info["status"]


@functools.lru_cache(maxsize=1)
def program():
    """The Fig. 9.2 SOCP from a stand at K = 500, assembled once: (segment, train, weights, nodes, A, b, q, cones, index)."""
    train = load_train(ROOT / "trains/yazhemsky2017_commuter.yaml")
    segment = make_segment(load_track(ROOT / "tracks/yazhemsky2017_advanced_1km.yaml"), train, "A", "B")
    weights = ConvexWeights(time=10.0, energy=1.0)
    prog = ConvexProgram(segment, train, trapezoid_grid(segment, 500), weights)
    x = prog.grid_from(0.0, 0.05)
    A, b, q, cones, index = prog.assemble(x, State(), (0.0, 200.0), 0.0, 1.0, None)
    return segment, train, weights, len(x), A, b, q, cones, index


def run_clarabel(A, b, q, cones, refine):
    settings = clarabel.DefaultSettings()
    settings.verbose, settings.iterative_refinement_enable = False, refine
    sol = clarabel.DefaultSolver(sparse.csc_matrix((A.shape[1], A.shape[1])), q, A, b, cones, settings).solve()
    return np.asarray(sol.x), sol.iterations


SOLVERS = {"clarabel": ("Clarabel (ecostudy's settings)", lambda A, b, q, cones: run_clarabel(A, b, q, cones, False)),
           "clarabel_refine": ("Clarabel (iterative refinement on)", lambda A, b, q, cones: run_clarabel(A, b, q, cones, True)),
           "ecos": ("ECOS", solve_ecos),
           "ipopt": ("Ipopt 3.11 (cyipopt, rho s >= 1)", lambda A, b, q, cones: IpoptSocp(A, b, q, cones).solve())}


def socp_case(key):
    """The harness case of one solver on the Fig. 9.2 SOCP: iterations, arrival, relaxation gap, objective."""
    def run(_):
        *_, A, b, q, cones, index = program()
        z, iters = SOLVERS[key][1](A, b, q, cones)
        v, rho, t = z[index["v"]], z[index["rho"]], z[index["t"]]
        return {"iterations": str(iters), "arrival_s": float(t[-1]), "objective": float(q @ z),
                "gap": float(np.max(np.abs(rho * 0.5 * (v[:-1] + v[1:]) - 1.0)))}
    return harness.register(f"convex.{key}", run, reference=None if key == "clarabel" else "convex.clarabel",
                            doc=f"Yazhemsky 2017's SOCP (Fig. 9.2, K = 500) solved once by {SOLVERS[key][0]}")


for _key in SOLVERS:
    socp_case(_key)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--loop-points", type=int, nargs="*", default=[250, 500, 1000])
    args = p.parse_args()
    print(harness.command(__file__) + "\n")
    segment, train, weights, nodes, A, *_ = program()
    print(f"K = {nodes} nodes: {A.shape[1]} variables, {A.shape[0]} rows, {A.nnz} nonzeros\n")
    runs = harness.measure([f"convex.{key}" for key in SOLVERS], args.repeat)
    table = harness.Table(["solver", "median wall [ms]", "iterations / status", "arrival [s]", "max abs(rho s - 1)",
                           "objective - Clarabel's"])
    reference = runs["convex.clarabel"].last("objective")
    for key, (name, _) in SOLVERS.items():
        r = runs[f"convex.{key}"]
        table.add(name, f"{1e3 * r.median('wall_s'):.1f}", r.last("iterations"), f"{r.last('arrival_s'):.3f}",
                  f"{r.last('gap'):.1e}", number(r.last('objective') - reference, '+.1e'))
    print()
    table = harness.Table(["K", "steps", "solve mean [ms]", "p95 [ms]", "max [ms]", "steps over 100 ms", "arrival [s]",
                           "energy [J/kg]", "stop error [m]"])
    for k in args.loop_points:
        controller = Convex(ConvexProgram(segment, train, trapezoid_grid(segment, k), weights), (0.0, 200.0))
        result = run_loop(Plant(segment, train), controller, 0.1, plant_step=0.1)
        s = 1e3 * np.array([x for x in controller.solve_seconds if x > 0])
        table.add(k, s.size, f"{s.mean():.1f}", f"{np.percentile(s, 95):.1f}", f"{s.max():.1f}", int(np.sum(s > 100)),
                  f"{result.arrival_time_s:.2f}", f"{result.traction_work / train.mass:.2f}", signed(result.stop_error_m, 3))


if __name__ == "__main__":
    main()
