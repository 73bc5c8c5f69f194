"""ecostudy end to end against a lean CasADi transcription of the same physics: speeds and forces only.

    pip install -e '.[bench]'    # CasADi: a benchmark reference, not a dependency of ecostudy
    PYTHONPATH=$PWD .venv/bin/python bench/bench_lean.py [--points 1000 5000] [--repeat 3] [--case long metro]

Unlike ``bench/bench_casadi.py``, which writes ecostudy's own NLP in CasADi (how fast the stack is),
this reference is written as lean as the problem allows, independently of ``ocp.space``: the
variables are the speeds at the nodes (both ends fixed by bounds) and the traction, braking and,
where the regenerative envelope does not cover the braking one, regenerative forces per interval;
the running time is a single equality sum 2 ds_k / (v_k + v_k+1) = T (no time-step variable, no T
variable); power limits are left out where they never bind and otherwise hold where ecostudy's
default holds them (at both ends of each interval; once at the mean speed if ``space.CUTS`` has
``mid_power``); speed-force tables hold at both ends of each interval. The physics functions
(``core.physics``) and per-interval coefficients are ecostudy's, so the optima must agree.

ecostudy's time is its in-process build + NL write + Ipopt (``ocp.problem.build``, Debian's Ipopt
through PyNumero); CasADi's is building the SX graph + ``nlpsol`` + solving with CasADi's bundled
Ipopt, in the same process, from the same start (``problem.capped_guess``). Medians of ``--repeat``,
wall and the process's CPU time (the latter less disturbed by other processes on a shared machine).
``--timing FOLDER`` writes Ipopt's own timers (``print_timing_statistics``: function evaluations,
linear system, back-solves, ...) of each side's last solve to a file per side, case and K.
A last table per case gives each side's stages in CPU seconds of the process (ecostudy: build, NL
write, ASL load, solve with the load of the point into the model, energy; the reference: graph,
``nlpsol``, solve), Ipopt's ms per iteration (with ``--timing``: its function evaluations', linear
system's and whole algorithm's CPU ms) and each one's growth from the smallest K to the largest.

Cases (shipped): ``long`` is tracks/regional_line_20stops.yaml S01 to S20 (22.4 km run through) with
trains/regional_alstom.yaml, net energy, in 1.15 times its envelope time; ``metro`` is
studies/default.yaml (Amsterdam metro, Rokin to Centraal in 76 s, traction energy).
"""
import argparse
import re
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from bench.bench_casadi import objective_expr  # noqa: E402
from ecostudy.core.kinematics import interval_davis, interval_grade_force  # noqa: E402
from ecostudy.core.physics import interval_resistance, smooth_table  # noqa: E402
from ecostudy.core.units import signed, to_kwh  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import problem, session, solver, space  # noqa: E402
from pyomo.contrib.pynumero.interfaces.ampl_nlp import AslNLP  # noqa: E402

PARAMS = {"case": "long", "points": 1000}
TIMING: dict = {"folder": None}  # --timing FOLDER: Ipopt's timing statistics of each solve, a file per side


def timing_options(side: str, p: dict) -> dict:
    """Ipopt options that write ``side``'s timers (``print_timing_statistics``) to a file in the
    ``--timing`` folder (``{side}_{case}_{points}.txt``, the last repeat's), or none."""
    if TIMING["folder"] is None:
        return {}
    path = Path(TIMING["folder"]) / f"{side}_{p['case']}_{p['points']}.txt"
    return {"print_timing_statistics": "yes", "output_file": str(path), "file_print_level": 5}


class Clock:
    """CPU seconds of this process (``time.process_time``: the work, less disturbed than the wall
    clock by other processes) since the last lap."""

    def __init__(self):
        self.last = time.process_time()

    def lap(self) -> float:
        now, before = time.process_time(), self.last
        self.last = now
        return now - before


ASL_LOAD = {"seconds": 0.0}  # the ASL load inside ``PyomoNLP`` (the rest of ``Session``'s time is the NL write)
_asl_init = AslNLP.__init__


def _timed_asl_init(self, *args, **kwargs):
    t0 = time.process_time()
    _asl_init(self, *args, **kwargs)
    ASL_LOAD["seconds"] += time.process_time() - t0


AslNLP.__init__ = _timed_asl_init  # PyomoNLP's super().__init__ reads the class attribute: timed, nothing else changed

TIMER = re.compile(r"^\s*(\w[\w ]*?)\.*:\s+([\d.]+) \(sys:\s+([\d.]+) wall:\s+([\d.]+)\)", re.M)


def ipopt_timers(side: str, p: dict) -> dict:
    """CPU seconds of Ipopt's timers in ``side``'s last timing file (``--timing``): function
    evaluations, the linear system (``PDSystemSolverTotal``) and the whole algorithm; none without it."""
    if TIMING["folder"] is None:
        return {}
    text = (Path(TIMING["folder"]) / f"{side}_{p['case']}_{p['points']}.txt").read_text()
    cpu = {name.strip(): float(c) for name, c, _, _ in TIMER.findall(text)}
    return {"functions_cpu_s": cpu.get("Function Evaluations", float("nan")),
            "linear_system_cpu_s": cpu.get("PDSystemSolverTotal", float("nan")),
            "algorithm_cpu_s": cpu.get("OverallAlgorithm", float("nan"))}


def setup(p):
    """(prepared case, running time [s], objective, start point) of ``long`` or ``metro``, untimed."""
    solver.configure()
    if p["case"] == "long":
        case = problem.prepare(load_track(ROOT / "tracks/regional_line_20stops.yaml"),
                               load_train(ROOT / "trains/regional_alstom.yaml"), "S01", "S20", p["points"])
        running_time, objective = round(1.15 * case.estimate), "net_energy"
    else:
        case = problem.prepare(load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
                               load_train(ROOT / "trains/amsterdam_metro.yaml"), "Rokin", "Centraal", p["points"])
        running_time, objective = 76.0, "energy"
    return case, running_time, objective, problem.capped_guess(case, running_time), p


@harness.case("lean.ecostudy", params=PARAMS, setup=setup, reference="lean.lean")
def ecostudy_run(state):
    """ecostudy as it solves (every cut): build + NL write + Ipopt (PyNumero), in process."""
    case, running_time, objective, guess, p = state
    clock, stages = Clock(), {}
    m = problem.build(case, guess, objective, {}, running_time=running_time)
    stages["build"] = clock.lap()
    ASL_LOAD["seconds"] = 0.0
    s = session.Session(m)
    stages["asl_load"] = ASL_LOAD["seconds"]
    stages["nl_write"] = clock.lap() - ASL_LOAD["seconds"]
    outcome = s.solve(timing_options("ecostudy", p))
    stages["solve"] = clock.lap()  # Ipopt, then the point and multipliers into the model
    energy = to_kwh(float(m.objective.expr()) * m.energy_ref)
    stages["extract"] = clock.lap()
    return {"variables": s.nlp.n_primals(), "constraints": s.nlp.n_constraints(), "iterations": outcome.iterations,
            "ipopt": outcome.status, "ipopt_s": outcome.seconds, "energy_kWh": energy, "stages": stages,
            **ipopt_timers("ecostudy", p)}


@harness.case("lean.lean", params=PARAMS, setup=setup)
def lean_run(state):
    """The lean CasADi transcription (speeds and forces only): graph + nlpsol + CasADi's Ipopt, in process."""
    case, running_time, objective, (v0, _, ft0, fb0), p = state
    clock = Clock()
    train, segment, nodes = case.train, case.segment, case.nodes
    n, fs = len(nodes) - 1, space.FORCE_SCALE
    dsd = ca.DM(np.diff(nodes))
    speeds = np.linspace(0.0, float(np.max(case.limits)), 101)
    regen = objective == "net_energy" and train.regeneration is not None
    own_regen = regen and not np.all(train.regeneration.force(speeds) >= train.braking.force(speeds))
    v, ft, fb = ca.SX.sym("v", n + 1), ca.SX.sym("ft", n), ca.SX.sym("fb", n)
    fr = ca.SX.sym("fr", n) if own_regen else (fb if regen else ca.SX.zeros(n))
    va, vb = v[:-1], v[1:]
    per_kg = [ca.DM(np.asarray(x, float) / train.mass) for x in interval_davis(segment, train, nodes)]
    fixed = ca.DM(interval_grade_force(segment, train, nodes) / train.mass)
    g, lbg, ubg = [], [], []

    def add(expr, lo, hi):
        g.append(expr)
        lbg.append(np.full(expr.shape[0], lo))
        ubg.append(np.full(expr.shape[0], hi))

    accel = (vb ** 2 - va ** 2) * (0.5 / dsd)
    add(accel + interval_resistance(va, vb, per_kg, fixed) - (fs / train.mass) * (ft - fb), 0.0, 0.0)
    add(ca.sum1(2 * dsd / (va + vb)) / running_time, 1.0, 1.0)
    envelopes = [(ft, train.traction), (fb, train.braking)] + ([(fr, train.regeneration)] if own_regen else [])
    for force, env in envelopes:
        if env.kind == "table":
            c0, c1, terms = env.coefficients
            top = smooth_table(v, (c0 / fs, c1 / fs, [(a / fs, s) for a, s in terms]), env.width)
            add(force - top[:-1], -np.inf, 0.0)
            add(force - top[1:], -np.inf, 0.0)
        elif np.isfinite(env.max_power) and not env.idle_power(speeds) and "mid_power" in space.CUTS:
            add(force * (va + vb) / (2 * env.max_power / fs), -np.inf, 1.0)
        elif np.isfinite(env.max_power) and not env.idle_power(speeds):  # the physics ecostudy solves
            add(force * va / (env.max_power / fs), -np.inf, 1.0)
            add(force * vb / (env.max_power / fs), -np.inf, 1.0)
    if own_regen:
        add(fr - fb, -np.inf, 0.0)
    if np.isfinite(train.max_acceleration):
        add(accel, -np.inf, float(train.max_acceleration))
    if np.isfinite(train.max_deceleration):
        add(-accel, -np.inf, float(train.max_deceleration))
    energy_ref = space.energy_reference(train, segment)
    f = objective_expr(objective, train, ft, fr, va, vb, dsd) / energy_ref
    top_r = min(train.regeneration.max_force, train.braking.peak) / fs if own_regen else 0.0
    x = ca.vertcat(v, ft, fb, *([fr] if own_regen else []))
    lbx = np.zeros(x.shape[0])
    ubx = np.concatenate([case.limits, np.full(n, train.traction.peak / fs), np.full(n, train.braking.peak / fs)]
                         + ([np.full(n, top_r)] if own_regen else []))
    ubx[0] = ubx[n] = 0.0
    x0 = np.clip(np.concatenate([v0, ft0 / fs, fb0 / fs] + ([np.minimum(fb0 / fs, top_r)] if own_regen else [])),
                 lbx, ubx)
    opts = {"ipopt": {**session.DEFAULT_OPTIONS, **timing_options("lean", p)}, "print_time": False}
    graph = clock.lap()
    nlp = ca.nlpsol("lean", "ipopt", {"x": x, "f": f, "g": ca.vertcat(*g)}, opts)
    built = clock.lap()
    with harness.stage() as solve:
        sol = nlp(x0=x0, lbx=lbx, ubx=ubx, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
    stages = {"graph": graph, "nlpsol": built, "solve": clock.lap()}
    stats = nlp.stats()
    return {"variables": x.shape[0], "constraints": sum(e.shape[0] for e in g), "iterations": stats["iter_count"],
            "ipopt": stats["return_status"], "ipopt_s": solve.seconds, "energy_kWh": to_kwh(float(sol["f"]) * energy_ref),
            "stages": stages,
            **ipopt_timers("lean", p)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, nargs="+", default=[1000, 5000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--case", nargs="+", default=["long"])
    ap.add_argument("--timing", metavar="FOLDER", help="write Ipopt's timing statistics of each side's solve there")
    args = ap.parse_args()
    if args.timing:
        Path(args.timing).mkdir(parents=True, exist_ok=True)
        TIMING["folder"] = args.timing
    print(harness.command(__file__) + "\n")
    table = harness.Table(["case", "K", "variables (ecostudy / lean)", "constraints", "ecostudy s", "iterations",
                           "lean s", "iterations", "ratio", "CPU s (ecostudy / lean)", "CPU ratio",
                           "Ipopt alone s (ecostudy / lean)", "ecostudy kWh", "lean kWh", "difference %"])
    grown = {}
    staged = {}
    for name in args.case:
        for points in args.points:
            runs = harness.measure(["lean.ecostudy"], args.repeat, {"case": name, "points": points})
            eco, lean = runs["lean.ecostudy"], runs["lean.lean"]
            staged[name, points] = eco, lean
            te, tl = eco.median("wall_s"), lean.median("wall_s")
            ce, cl = eco.median("cpu_s"), lean.median("cpu_s")
            e, c = eco[-1], lean[-1]
            grown.setdefault(name, []).append((points, te, tl, ce, cl))
            table.add(name, points, f"{e['variables']} / {c['variables']}", f"{e['constraints']} / {c['constraints']}",
                      f"{te:.2f}", f"{e['iterations']} ({e['ipopt']})", f"{tl:.2f}", f"{c['iterations']} ({c['ipopt']})",
                      f"{te / tl:.2f}", f"{ce:.2f} / {cl:.2f}", f"{ce / cl:.2f}",
                      f"{eco.median('ipopt_s'):.2f} / {lean.median('ipopt_s'):.2f}", f"{e['energy_kWh']:.4f}",
                      f"{c['energy_kWh']:.4f}", signed(100 * (e['energy_kWh'] - c['energy_kWh']) / abs(c['energy_kWh']), 4))
    print()
    growth = harness.Table(["case", "K", "ecostudy growth (wall / CPU)", "lean growth (wall / CPU)"])
    for name, rows in grown.items():
        k0, e0, l0, ce0, cl0 = rows[0]
        for k, e, lt, ce, cl in rows[1:]:
            growth.add(name, f"{k0} -> {k}", f"{e / e0:.2f}x / {ce / ce0:.2f}x", f"{lt / l0:.2f}x / {cl / cl0:.2f}x")
    print()
    stage_table(staged)


STAGES = {"ecostudy": ["build", "nl_write", "asl_load", "solve", "extract"], "lean": ["graph", "nlpsol", "solve"]}


def stage_table(staged: dict) -> None:
    """Per case, each side's stages (medians, CPU s), Ipopt's wall ms per iteration and, with ``--timing``,
    the CPU ms per iteration of its function evaluations, linear system and whole algorithm (the
    last repeat's), at each K, and their growth from the smallest K to the largest."""
    for name in dict.fromkeys(n for n, _ in staged):
        points = sorted(k for n, k in staged if n == name)
        table = harness.Table(["case", "side", "stage"] + [f"K = {k}" for k in points] + [f"growth {points[0]} -> {points[-1]}"])
        for i, side in enumerate(STAGES):
            runs = [staged[name, k][i] for k in points]
            rows = {stage: [r.median(f"{stage}_s") for r in runs] for stage in STAGES[side]}
            rows["Ipopt wall ms per iteration"] = [1e3 * r.median("ipopt_s") / r.median("iterations") for r in runs]
            for t in ("functions", "linear_system", "algorithm"):
                if all(r.last(f"{t}_cpu_s") is not None for r in runs):
                    rows[f"Ipopt {t.replace('_', ' ')}, CPU ms per iteration"] = [
                        1e3 * r.last(f"{t}_cpu_s") / r.last("iterations") for r in runs]
            rows["whole (wall s)"] = [r.median("wall_s") for r in runs]
            rows["whole (CPU s)"] = [r.median("cpu_s") for r in runs]
            rows["iterations"] = [r.median("iterations") for r in runs]
            for stage, values in rows.items():
                table.add(name, side, stage, *(f"{v:.3f}" if stage != "iterations" else f"{v:g}" for v in values),
                          f"{values[-1] / values[0]:.2f}x")
        print()


if __name__ == "__main__":
    main()
