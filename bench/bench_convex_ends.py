"""How the convex controller's Clarabel calls end on a closed-loop study, and replays of them.

    .venv/bin/python bench/bench_convex_ends.py record STUDY.yaml --only CONTROLLER [--draw 0] --store DIR
    .venv/bin/python bench/bench_convex_ends.py replay DIR [--variant NAME ...] [--ends AlmostSolved] [--limit N]

``record`` runs the study's controller in this process (``ecostudy simulate``'s engine, one
worker) with every Clarabel call of ``ocp.convex.ConvexProgram`` recorded: per call its kind (first
solve, refined re-solve, tightening round), status, iterations, solve time and residuals, in
DIR/calls.csv, and the program (A, b, q, cones, the settings it ran with) in DIR/problems/ for
every call that did not end ``Solved`` and every tenth that did. It prints the counts per kind and
status and the residuals of the ends that were not ``Solved``.

``replay`` solves the stored programs again with variants of Clarabel's settings (and of the
scaling) and prints, per variant, the ends, the iterations and the solve time.
"""
import argparse
import sys
import tempfile
import time
from pathlib import Path

import clarabel
import numpy as np
import pandas as pd
from scipy import sparse

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.ocp import convex  # noqa: E402

SETTINGS = ("iterative_refinement_enable", "tol_feas", "tol_gap_abs", "tol_gap_rel", "max_iter")


def record(args):
    store = Path(args.store)
    (store / "problems").mkdir(parents=True, exist_ok=True)
    calls = []
    original = convex.ConvexProgram._conic

    def recorded(self, problem, tight=None, refined=False):
        A, b, q, cones, index = self.assemble(*problem, tight)
        settings = self.refined if refined else self.settings
        P = sparse.csc_matrix((A.shape[1], A.shape[1]))
        start = time.perf_counter()
        solution = clarabel.DefaultSolver(P, q, A, b, cones, settings).solve()
        wall = time.perf_counter() - start
        z = np.asarray(solution.x, float)
        status = str(solution.status)
        rho, v = z[index["rho"]], z[index["v"]]
        s = self._speed(v)
        k = len(calls)
        row = {"call": k, "kind": "refined" if refined else ("tight" if tight is not None else "first"),
               "position": float(problem[1].position), "speed": float(problem[1].speed),
               "status": status, "iterations": solution.iterations, "solve_time": solution.solve_time,
               "wall": wall, "r_prim": solution.r_prim, "r_dual": solution.r_dual,
               "obj": solution.obj_val, "obj_dual": solution.obj_val_dual,
               "gap_rel": abs(solution.obj_val - solution.obj_val_dual) / max(1.0, min(abs(solution.obj_val),
                                                                                        abs(solution.obj_val_dual))),
               "relaxation": float(np.max(np.abs(rho * s - 1.0))) if rho.size else 0.0,
               "rows": A.shape[0], "columns": A.shape[1],
               "refinement": bool(settings.iterative_refinement_enable)}
        calls.append(row)
        if status != "Solved" or k % 10 == 0:
            counts = [(type(c).__name__, getattr(c, "dim", None)) for c in cones]
            zero = sum(1 for c in cones if isinstance(c, clarabel.ZeroConeT))
            np.savez_compressed(store / "problems" / f"{k:06d}.npz", data=A.data, indices=A.indices, indptr=A.indptr,
                                shape=A.shape, b=b, q=q, cone_kinds=np.array([c[0] for c in counts]),
                                cone_dims=np.array([_dim(c) for c in cones]), zero=zero,
                                refinement=bool(settings.iterative_refinement_enable),
                                nv=len(index["v"]), status=status)
        return z[index["v"]], z[index["t"]], z[index["rho"]], z[index["g"]], status

    convex.ConvexProgram._conic = recorded
    try:
        from ecostudy.studies.closedloop import simulate_study
        with tempfile.TemporaryDirectory() as out:
            simulate_study(Path(args.study), workers=1, out=Path(out), only=[args.only],
                           draw=None)
            runs = pd.read_csv(Path(out) / "runs.csv")
            steps = sorted((Path(out) / "steps").glob(f"{args.only}_draw*.csv"))
            for f in steps:
                (store / f.name).write_bytes(f.read_bytes())
            runs.to_csv(store / "runs.csv", index=False)
    finally:
        convex.ConvexProgram._conic = original
    table = pd.DataFrame(calls)
    table.to_csv(store / "calls.csv", index=False)
    summarise(table)


def _dim(cone):
    text = repr(cone)
    digits = "".join(ch for ch in text if ch.isdigit())
    return int(digits) if digits else 0


def summarise(table):
    print(table.groupby(["kind", "status"]).size().to_string())
    bad = table[table.status != "Solved"]
    if len(bad):
        print("not Solved: r_prim max %.1e, r_dual max %.1e median %.1e, gap_rel max %.1e, iterations median %d"
              % (bad.r_prim.max(), bad.r_dual.max(), bad.r_dual.median(), bad.gap_rel.max(), bad.iterations.median()))
    ok = table[table.status == "Solved"]
    if len(ok):
        print("Solved: iterations median %d, solve_time median %.1f ms p95 %.1f ms"
              % (ok.iterations.median(), 1e3 * ok.solve_time.median(), 1e3 * ok.solve_time.quantile(0.95)))


def load(path):
    f = np.load(path)
    A = sparse.csc_matrix((f["data"], f["indices"], f["indptr"]), shape=tuple(f["shape"]))
    cones = []
    for kind, dim in zip(f["cone_kinds"], f["cone_dims"]):
        cones.append({"ZeroConeT": clarabel.ZeroConeT, "NonnegativeConeT": clarabel.NonnegativeConeT,
                      "SecondOrderConeT": clarabel.SecondOrderConeT}[str(kind)](int(dim)))
    return A, f["b"], f["q"], cones, bool(f["refinement"]), str(f["status"])


def variant_settings(name, refinement):
    s = clarabel.DefaultSettings()
    s.verbose = False
    s.iterative_refinement_enable = refinement
    for part in name.split("+"):
        if part == "as_run":
            continue
        key, _, value = part.partition("=")
        current = getattr(s, key)
        setattr(s, key, type(current)(value) if not isinstance(current, bool) else value in ("1", "true", "True"))
    return s


def replay(args):
    files = sorted(Path(args.store, "problems").glob("*.npz"))
    rows = []
    for path in files:
        A, b, q, cones, refinement, status = load(path)
        if args.ends and status not in args.ends:
            continue
        if args.limit and len({r["file"] for r in rows}) >= args.limit:
            break
        for name in args.variant:
            s = variant_settings(name, refinement)
            P = sparse.csc_matrix((A.shape[1], A.shape[1]))
            solution = clarabel.DefaultSolver(P, q, A, b, cones, s).solve()
            rows.append({"file": path.name, "recorded": status, "variant": name, "status": str(solution.status),
                         "iterations": solution.iterations, "solve_time": solution.solve_time,
                         "r_prim": solution.r_prim, "r_dual": solution.r_dual, "obj": solution.obj_val})
    table = pd.DataFrame(rows)
    if table.empty:
        print("no stored program matched")
        return
    for name, group in table.groupby("variant", sort=False):
        ends = group.status.value_counts().to_dict()
        print(f"{name}: {len(group)} programs, ends {ends}, iterations median {group.iterations.median():.0f}, "
              f"solve median {1e3 * group.solve_time.median():.1f} ms p95 {1e3 * group.solve_time.quantile(0.95):.1f} ms, "
              f"r_dual max {group.r_dual.max():.1e}")
    if args.csv:
        table.to_csv(args.csv, index=False)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("record")
    r.add_argument("study")
    r.add_argument("--only", required=True)
    r.add_argument("--store", required=True)
    s = sub.add_parser("replay")
    s.add_argument("store")
    s.add_argument("--variant", nargs="+", default=["as_run"],
                   help="'as_run' or SETTING=VALUE[+SETTING=VALUE...] on top of the recorded settings")
    s.add_argument("--ends", nargs="*", default=["AlmostSolved"])
    s.add_argument("--limit", type=int, default=0)
    s.add_argument("--csv")
    args = p.parse_args()
    record(args) if args.command == "record" else replay(args)


if __name__ == "__main__":
    main()
