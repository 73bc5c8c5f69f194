"""ecostudy's space NLP against an independent CasADi transcription of the same NLP (the
stack's overhead: Pyomo's NL writer and PyNumero against CasADi's graph and its own Ipopt).

    .venv/bin/python bench/bench_casadi.py [--ttobench /work/data/ttobench] [--points 1000 5000]
        [--repeat 3] [--case amsterdam intercity]

Cases: ``amsterdam`` (tracks/amsterdam_rokin_centraal.yaml, trains/amsterdam_metro.yaml, Rokin to
Centraal in 76 s, traction energy minimised: ``studies/default.yaml``) and ``intercity`` (TTOBench
track ``00_var_speed_limit_100``, 48 531 m, with TTOBench's ``NL_Intercity_VIRM6`` as the library
gives it, standstill to standstill in 1541 s, net energy minimised).

It mirrors the space NLP without its lean cuts (``space.build_model(cuts=())``: interval times as
variables, a regenerative force of its own, envelopes at both ends); ``bench/bench_lean.py``
compares ecostudy as it solves (every cut) with a lean transcription. Both sides start from the same grid, node limits and initial point (``ocp.problem.prepare`` and
``capped_guess``) and use the same physics functions (``core.physics``) on the same per-interval
coefficients, so the NLPs have the same variables, constraints and scaling (checked: the counts
are printed). ecostudy's time is its in-process build + NL write + Ipopt (Debian's Ipopt 3.11.9
through PyNumero/cyipopt); CasADi's is building the expression graph and ``nlpsol`` + solving with
CasADi's bundled Ipopt (3.14, MUMPS), timed in the same process. Medians of ``--repeat`` runs.
CasADi comes from PyPI (``pip install -e '.[bench]'``); it is a benchmark reference, not a dependency.
"""
import argparse
import sys
from pathlib import Path

import casadi as ca
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.kinematics import interval_davis, interval_grade_force  # noqa: E402
from ecostudy.core.physics import interval_resistance, line_energy, smooth_table  # noqa: E402
from ecostudy.core.units import signed, to_kwh  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import problem, session, space  # noqa: E402

PARAMS = {"case": "amsterdam", "points": 1000, "ttobench": "/work/data/ttobench"}


def load_case(name, ttobench):
    """(track, train, from, to, running time [s], objective) of a named case."""
    if name == "amsterdam":
        return (load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
                load_train(ROOT / "trains/amsterdam_metro.yaml"), "Rokin", "Centraal", 76.0, "energy")
    lib = Path(ttobench)
    track = load_track(lib / "tracks" / "00_var_speed_limit_100.json")
    return (track, load_train(lib / "trains" / "NL_Intercity_VIRM6.json"),
            *list(track.stops)[::len(track.stops) - 1], 1541.0, "net_energy")


def setup(p):
    """(prepared case, running time, objective, start point): the same for both sides, untimed."""
    track, train, a, b, running_time, objective = load_case(p["case"], p["ttobench"])
    case = problem.prepare(track, train, a, b, p["points"])
    return case, running_time, objective, problem.capped_guess(case, running_time)


@harness.case("casadi.ecostudy", params=PARAMS, setup=setup, reference="casadi.casadi")
def ecostudy_run(state):
    """ecostudy's space NLP without its lean cuts: build + NL write + Ipopt (PyNumero), in process."""
    case, running_time, objective, guess = state
    stages = {}
    with problem.stage(stages, "build"):  # the full form, without the lean cuts, as mirrored below
        m = space.build_model(case.segment, case.train, case.nodes, case.limits, guess, objective=objective,
                              running_time=running_time, cuts=(),
                              time_ref=max(problem.kinematics.running_time(guess[0], case.nodes), 1.0))
    s = session.Session(m)
    outcome = s.solve()
    return {"variables": s.nlp.n_primals(), "constraints": s.nlp.n_constraints(), "iterations": outcome.iterations,
            "ipopt": outcome.status, "ipopt_s": outcome.seconds,
            "energy_kWh": to_kwh(float(m.objective.expr()) * m.energy_ref)}


def objective_expr(objective, train, ft, fr, va, vb, dsd):
    """Traction work or net line energy [J] of CasADi force vectors [kN] (``space.define_objective``)."""
    fs = space.FORCE_SCALE
    if objective == "energy":
        return fs * ca.dot(dsd, ft)
    return ca.sum1(line_energy(fs * ft, fs * fr, 0.5 * (va + vb), dsd, train.eta_traction, train.eta_regeneration))


def casadi_nlp(state):
    """The same NLP written with CasADi SX vectors: (nlpsol, its arguments, energy_ref, n, m)."""
    case, running_time, objective, (v0, dt0, ft0, fb0) = state
    train, segment, nodes, limits = case.train, case.segment, case.nodes, case.limits
    n = len(nodes) - 1
    fs = space.FORCE_SCALE
    ds = np.diff(nodes)
    regen = objective == "net_energy" and train.regeneration is not None
    v, dt, ft, fb = ca.SX.sym("v", n + 1), ca.SX.sym("dt", n), ca.SX.sym("ft", n), ca.SX.sym("fb", n)
    fr = ca.SX.sym("fr", n) if regen else ca.SX.zeros(n)
    T = ca.SX.sym("T")
    va, vb = v[:-1], v[1:]
    per_kg = [ca.DM(np.asarray(x, float) / train.mass) for x in interval_davis(segment, train, nodes)]
    fixed = ca.DM(interval_grade_force(segment, train, nodes) / train.mass)
    dsd = ca.DM(ds)
    net = interval_resistance(va, vb, per_kg, fixed) - (fs / train.mass) * (ft - fb)
    g, lbg, ubg = [], [], []

    def add(expr, lo, hi):
        g.append(expr)
        lbg.append(np.full(expr.shape[0], lo))
        ubg.append(np.full(expr.shape[0], hi))

    add((vb ** 2 - va ** 2) * (0.5 / dsd) + net, 0.0, 0.0)      # speed recursion (energy form)
    add(dt * (va + vb) / (2 * dsd), 1.0, 1.0)                     # interval times
    for force, env in ((ft, train.traction), (fb, train.braking)) + (((fr, train.regeneration),) if regen else ()):
        if env.kind == "table":
            c0, c1, terms = env.coefficients
            scaled = (c0 / fs, c1 / fs, [(a / fs, s) for a, s in terms])
            top = smooth_table(v, scaled, env.width)
            add(force - top[:-1], -np.inf, 0.0)
            add(force - top[1:], -np.inf, 0.0)
        elif np.isfinite(env.max_power):
            pk = env.max_power / fs
            add(force * va / pk, -np.inf, 1.0)
            add(force * vb / pk, -np.inf, 1.0)
    if regen:
        add(fr - fb, -np.inf, 0.0)
    mean = (vb ** 2 - va ** 2) * (0.5 / dsd)
    if np.isfinite(train.max_acceleration):
        add(mean, -np.inf, float(train.max_acceleration))
    if np.isfinite(train.max_deceleration):
        add(-mean, -np.inf, float(train.max_deceleration))
    time_ref = max(float(np.sum(dt0)), 1.0)
    add(ca.sum1(dt) / time_ref - T / time_ref, 0.0, 0.0)
    energy_ref = space.energy_reference(train, segment)
    f = objective_expr(objective, train, ft, fr, va, vb, dsd) / energy_ref
    x = ca.vertcat(v, dt, ft, fb, *([fr] if regen else []), T)
    top_r = min(train.regeneration.max_force, train.braking.peak) / fs if regen else 0.0
    lbx = np.concatenate([np.zeros(n + 1), np.zeros(n), np.zeros(n), np.zeros(n)] + ([np.zeros(n)] if regen else [])
                         + [[running_time]])
    ubx = np.concatenate([limits, np.full(n, np.inf), np.full(n, train.traction.peak / fs),
                          np.full(n, train.braking.peak / fs)] + ([np.full(n, top_r)] if regen else [])
                         + [[running_time]])
    ubx[0] = ubx[n] = 0.0
    x0 = np.concatenate([v0, dt0, ft0 / fs, fb0 / fs] + ([np.minimum(fb0 / fs, top_r)] if regen else [])
                        + [[running_time]])
    x0 = np.clip(x0, lbx, ubx)
    opts = {"ipopt": {k: val for k, val in session.DEFAULT_OPTIONS.items() if k != "sb"},
            "print_time": False}
    opts["ipopt"]["sb"] = "yes"
    solver = ca.nlpsol("eetc", "ipopt", {"x": x, "f": f, "g": ca.vertcat(*g)}, opts)
    arguments = dict(x0=x0, lbx=lbx, ubx=ubx, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
    return solver, arguments, energy_ref, x.shape[0], sum(e.shape[0] for e in g)


@harness.case("casadi.casadi", params=PARAMS, setup=setup)
def casadi_run(state):
    """The NLP of casadi.ecostudy in CasADi: graph + nlpsol + CasADi's bundled Ipopt (3.14), in process."""
    solver, arguments, energy_ref, n, m = casadi_nlp(state)
    with harness.stage() as solve:
        sol = solver(**arguments)
    stats = solver.stats()
    return {"variables": n, "constraints": m, "iterations": stats["iter_count"], "ipopt": stats["return_status"],
            "ipopt_s": solve.seconds, "energy_kWh": to_kwh(float(sol["f"]) * energy_ref)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ttobench", default="/work/data/ttobench", help="TTOBench checkout ('' to skip)")
    ap.add_argument("--points", type=int, nargs="+", default=[1000, 5000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--case", nargs="+", default=["amsterdam", "intercity"])
    args = ap.parse_args()
    print(harness.command(__file__) + "\n")
    table = harness.Table(["case", "K", "variables", "constraints", "ecostudy s", "iterations", "CasADi s", "iterations",
                           "ratio", "Ipopt alone s (ecostudy / CasADi)", "ecostudy kWh", "CasADi kWh", "difference %"])
    base = {}
    for name in args.case:
        if name == "intercity" and not args.ttobench:
            continue
        for points in args.points:
            runs = harness.measure(["casadi.ecostudy"], args.repeat,
                                   {"case": name, "points": points, "ttobench": args.ttobench})
            eco, cas = runs["casadi.ecostudy"], runs["casadi.casadi"]
            te, tc = eco.median("wall_s"), cas.median("wall_s")
            e, c = eco[-1], cas[-1]
            base.setdefault(name, []).append((points, te, tc))
            table.add(name, points, f"{e['variables']} / {c['variables']}", f"{e['constraints']} / {c['constraints']}",
                      f"{te:.2f}", f"{e['iterations']} ({e['ipopt']})", f"{tc:.2f}", f"{c['iterations']} ({c['ipopt']})",
                      f"{te / tc:.2f}", f"{eco.median('ipopt_s'):.2f} / {cas.median('ipopt_s'):.2f}",
                      f"{e['energy_kWh']:.4f}", f"{c['energy_kWh']:.4f}",
                      signed(100 * (e['energy_kWh'] - c['energy_kWh']) / abs(c['energy_kWh']), 4))
    print()
    growth = harness.Table(["case", "K", "ecostudy growth", "CasADi growth"])
    for name, rows in base.items():
        k0, e0, c0 = rows[0]
        for k, e, c in rows[1:]:
            growth.add(name, f"{k0} -> {k}", f"{e / e0:.2f}x", f"{c / c0:.2f}x")


if __name__ == "__main__":
    main()
