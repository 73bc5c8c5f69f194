"""ecostudy's net-energy optimum against the published GPOPS-II optimum of ms-eetc's repository
(``gpops/00_var_speed_limit_100_GPOPSII.csv``: 440.141 kWh; the data of ``gpops/trainMain.m``).

    .venv/bin/python bench/bench_gpops.py --ttobench PATH [--points 500 1000 2000]

The case, as ``trainMain.m`` sets it: TTOBench track ``00_var_speed_limit_100`` (48 531 m, flat,
140 / 100 / 140 km/h), and ms-eetc's GPOPS-II train as ``trainMain.m`` writes it (not TTOBench's
``NL_Intercity_VIRM6.json``, which has 2157 kW of traction, a 142.5 kN / 3616 kW regenerative brake,
efficiencies 87.5 / 70 % and a 140 km/h top speed): no pneumatic brake, the regenerative brake as
strong as the traction (213.9 kN, 3129.277 kW both ways), efficiencies 0.73 both ways,
1 m/s at both ends, T = 1541 s, the net energy (traction / eta_T - eta_R x regenerated) minimised.
The optimum is re-driven by the plant (DOP853) from 1 m/s to the end of the line; the table
gives both energies and their difference from GPOPS-II.
"""
import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench import harness  # noqa: E402
from ecostudy.analysis.tables import handles  # noqa: E402
from ecostudy.core.plant import Plant  # noqa: E402
from ecostudy.core.types import State  # noqa: E402
from ecostudy.core.units import signed, to_kwh  # noqa: E402
from ecostudy.io.loaders import load_track, train_from_dict  # noqa: E402
from ecostudy.ocp.problem import prepare  # noqa: E402
from ecostudy.ocp.restart import Replanner  # noqa: E402

GPOPS_KWH = 440.1406149
VIRM6_GPOPS = {  # gpops/trainMain.m
    "name": "VIRM6 as in ms-eetc gpops/trainMain.m", "source": "dkouzoup/ms-eetc gpops/trainMain.m",
    "mass_t": 391.0, "rotating_mass_factor": 0.06, "length_m": 0.0,
    "davis": {"a_N": 5854.0, "b_N_per_mps": 74.16, "c_N_per_mps2": 12.96},
    "traction": {"max_force_kN": 213.9, "max_power_kW": 3129.277},
    "braking": {"max_force_kN": 213.9, "max_power_kW": 3129.277},
    "regenerative_braking": {"max_force_kN": 213.9, "max_power_kW": 3129.277, "efficiency": 0.73},
    "traction_efficiency": 0.73, "max_speed_kmh": 160.0,
}


def at_end(solutions, distance):
    """State (t, x, v, works) where the driven run passes ``distance``."""
    for sol in solutions:
        if sol.y[0, 0] <= distance <= sol.y[0, -1]:
            t = brentq(lambda tt: sol.sol(tt)[0] - distance, sol.t[0], sol.t[-1], xtol=1e-9)
            return t, sol.sol(t)
    raise RuntimeError("the run never reached the end of the line")


def run(track, train, points, v_end=1.0, running_time=1541.0):
    with harness.stage() as solving:
        case = prepare(track, train, "S0", "S1", points)
        planner = Replanner(case, running_time=running_time, objective="net_energy")
        plan = planner.solve(State(0.0, v_end, 0.0), end_speed=(v_end, v_end), arrival=running_time)
    m = planner.model
    ds = np.diff(case.nodes)
    fr = np.array([m.fr[k].value for k in m.I]) * 1e3 if hasattr(m, "fr") else np.zeros(len(ds))
    net = float(np.sum(plan.ft * ds)) / train.traction_efficiency - train.regeneration_efficiency * float(np.sum(fr * ds))
    u = handles(train, plan.v, plan.ft, plan.fb)
    _, _, solutions = Plant(case.segment, train).drive(case.nodes, u, initial_speed=v_end)
    t_end, y = at_end(solutions, case.segment.distance)
    sim = y[2] / train.traction_efficiency - train.regeneration_efficiency * y[4]
    return {"points": points, "ipopt": plan.outcome.status, "iterations": plan.outcome.iterations,
            "seconds": solving.seconds, "model_kWh": to_kwh(net), "simulated_kWh": to_kwh(sim),
            "simulated_time_s": t_end, "simulated_end_speed": y[1]}


@harness.case("gpops.virm6", params={"ttobench": "/work/data/ttobench", "points": 500},
              setup=lambda p: (load_track(Path(p["ttobench"]) / "tracks" / "00_var_speed_limit_100.json"),
                               train_from_dict(VIRM6_GPOPS, "bench_gpops VIRM6"), p["points"]))
def gpops_case(state):
    """TTOBench's VIRM6 run at 1541 s against GPOPS-II's net energy: solve, then re-driven by the plant."""
    return run(*state)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ttobench", required=True, help="A TTOBench checkout (tracks/ folder).")
    ap.add_argument("--points", type=int, nargs="+", default=[500, 1000, 2000])
    args = ap.parse_args()
    track = load_track(Path(args.ttobench) / "tracks" / "00_var_speed_limit_100.json")
    train = train_from_dict(VIRM6_GPOPS, "bench_gpops VIRM6")
    print(harness.command(__file__) + "\n")
    table = harness.Table(["K", "Ipopt", "iterations", "s", "NLP net energy kWh", "vs GPOPS-II", "re-driven kWh",
                           "vs GPOPS-II", "re-driven time s", "end speed m/s"])
    for k in args.points:
        r = run(track, train, k)
        table.add(k, r["ipopt"], r["iterations"], f"{r['seconds']:.1f}", f"{r['model_kWh']:.3f}",
                  f"{signed(100 * (r['model_kWh'] / GPOPS_KWH - 1), 3)} %", f"{r['simulated_kWh']:.3f}",
                  f"{signed(100 * (r['simulated_kWh'] / GPOPS_KWH - 1), 3)} %", f"{r['simulated_time_s']:.2f}",
                  f"{r['simulated_end_speed']:.3f}")


if __name__ == "__main__":
    main()
