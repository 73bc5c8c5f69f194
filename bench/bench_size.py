"""Size and pace of the space NLP, one cut of the lean formulation at a time (``ocp.space.CUTS``).

    PYTHONPATH=$PWD .venv/bin/python bench/bench_size.py [--case metro long regen] [--points 1000]

For each case it builds the NLP with no cut, then adds the cuts one by one (``time_step``,
``one_brake``, ``idle_power``: ``ocp.space.CUTS``, the default; then ``mid_power``), and prints per row: variables, constraints,
Ipopt's KKT rows (n + m_eq + 2 m_ineq: primals, slacks, multipliers), iterations, the process's
CPU milliseconds per Ipopt iteration (less sensitive than wall time to other processes on a shared
machine), Ipopt's wall seconds and the energy of the optimum [kWh] with its change from the full
NLP. Sizes and iterations do not depend on the machine; times do.

Cases (all shipped): ``metro`` is studies/default.yaml (Amsterdam metro, Rokin to Centraal in 76 s,
traction energy); ``long`` is tracks/regional_line_20stops.yaml S01 to S20 (22.4 km run through)
with trains/regional_alstom.yaml, net energy, in 1.15 times its all-out envelope time; ``regen`` is
that case with the regional train's regenerative envelope raised to cover its whole braking
envelope, where the ``one_brake`` cut applies (no shipped train's regeneration covers its braking);
``leg`` is the first leg of studies/network_metro_2trains.yaml (tracks/metro_line_4stops.yaml,
A to B, the Amsterdam metro) as a time-domain leg on 0.5 s steps in 1.10 times the envelope time,
net energy (``network.legs.leg_cost`` with every step's weight 1), from its trapezoidal start: its
cuts are ``timedomain.CUTS`` (no time-step variable to cut there), then ``mid_power``, which legs
leave out.
"""
import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyomo.environ as pyo

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.core.physics import Envelope  # noqa: E402
from ecostudy.core.units import signed, to_kwh  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.network import legs  # noqa: E402
from ecostudy.ocp import problem, session, solver, space, timedomain  # noqa: E402


def cases(points):
    """name -> (case, running time [s], objective)."""
    metro = problem.prepare(load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml"),
                            load_train(ROOT / "trains/amsterdam_metro.yaml"), "Rokin", "Centraal", points)
    track, train = load_track(ROOT / "tracks/regional_line_20stops.yaml"), load_train(ROOT / "trains/regional_alstom.yaml")
    long = problem.prepare(track, train, "S01", "S20", points)
    covering = replace(train, regeneration=Envelope("force_power", max_force=train.braking.peak))
    regen = problem.prepare(track, covering, "S01", "S20", points)
    line = load_track(ROOT / "tracks/metro_line_4stops.yaml")
    first, second = list(line.stops)[:2]
    leg = problem.prepare(line, load_train(ROOT / "trains/amsterdam_metro.yaml"), first, second, points)
    return {"metro": (metro, 76.0, "energy"), "leg": (leg, round(1.10 * leg.estimate / 0.5) * 0.5, "leg"), "long": (long, round(1.15 * long.estimate), "net_energy"),
            "regen": (regen, round(1.15 * regen.estimate), "net_energy")}


def leg_model(case, running_time, cuts):
    """A time-domain leg of ``case`` on 0.5 s steps, net energy [kWh] as its objective."""
    leg = timedomain.Leg(case, 0, int(round(running_time / 0.5)), 0.5, 0.0, 1.0)
    m = pyo.ConcreteModel()
    b = timedomain.add_leg(m, "leg", leg, one_handle=False, cuts=cuts)
    m.energy_ref = legs.leg_energy_ref(leg) * 1e3  # [J] per objective unit (kW s over kJ)
    m.objective = pyo.Objective(expr=legs.leg_cost(b, legs.cost_coefficients(leg)) * leg.dt / legs.leg_energy_ref(leg))
    return m


def measure(case, running_time, objective, cuts):
    """One build and solve with ``cuts``: a row of the table."""
    if objective == "leg":
        m = leg_model(case, running_time, cuts)
    else:
        guess = problem.capped_guess(case, running_time)
        time_ref = max(problem.kinematics.running_time(guess[0], case.nodes), 1.0)
        m = space.build_model(case.segment, case.train, case.nodes, case.limits, guess, objective=objective,
                              running_time=running_time, time_ref=time_ref, cuts=cuts)
    nlp = session.Session(m)
    out, cpu, _ = harness.timed(nlp.solve)
    n, eq, ineq = nlp.nlp.n_primals(), nlp.nlp.n_eq_constraints(), nlp.nlp.n_ineq_constraints()
    energy = to_kwh(pyo.value(m.objective) * m.energy_ref)
    return dict(variables=n, constraints=eq + ineq, kkt=n + eq + 2 * ineq, iterations=out.iterations,
                ms=1e3 * cpu / max(out.iterations, 1), seconds=out.seconds, energy=energy, status=out.status)


def every_cut(objective):
    """The cuts in the order the table adds them: the defaults, then mid_power."""
    return space.ALL_CUTS if objective != "leg" else timedomain.CUTS + ("mid_power",)


@harness.case("size.cuts", setup=lambda p: (cases(p["points"])[p["case"]], p),
              params={"case": "metro", "points": 1000, "cuts": 99})
def with_cuts(state):
    """One build and solve of ``case`` with its first ``cuts`` lean cuts (99: all): sizes, iterations, CPU per iteration."""
    (case, running_time, objective), p = state
    solver.configure()
    r = measure(case, running_time, objective, tuple(every_cut(objective)[:p["cuts"]]))
    r["ipopt"] = r.pop("status")  # Ipopt's word; the harness's status is ok / flagged / failed
    return r


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", nargs="+", default=["metro", "long", "regen", "leg"])
    parser.add_argument("--points", type=int, default=1000)
    args = parser.parse_args()
    solver.configure()
    every = cases(args.points)
    print(harness.command(__file__) + "\n")
    table = harness.Table(["case", "cuts", "variables", "constraints", "KKT rows", "iterations", "CPU ms/iteration",
                           "Ipopt wall s", "energy kWh", "vs full"])
    for name in args.case:
        case, running_time, objective = every[name]
        full = None
        for i in range(len(every_cut(objective)) + 1):
            cuts = tuple(every_cut(objective)[:i])
            r = measure(case, running_time, objective, cuts)
            full = r["energy"] if full is None else full
            flag = "" if r["status"] == "optimal" else f" ({r['status']})"
            table.add(name, " + ".join(cuts) or "none", r["variables"], r["constraints"], r["kkt"],
                      f"{r['iterations']}{flag}", f"{r['ms']:.1f}", f"{r['seconds']:.2f}", f"{r['energy']:.4f}",
                      f"{signed(100 * (r['energy'] - full) / full, 3)} %")


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
