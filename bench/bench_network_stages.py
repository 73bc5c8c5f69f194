"""Where `ecostudy network` spends its CPU, stage by stage, in one process.

    PYTHONPATH=$PWD .venv/bin/python bench/bench_network_stages.py OUT.json network \
        studies/network_metro_3trains.yaml --no-plot --workers 1 --out DIR

Runs the ``ecostudy`` command given after OUT.json in this process (``--workers 1``: every solve
here) with ecostudy's own functions wrapped to add up this process's CPU seconds
(``time.process_time``) per stage, each stage's time less that of the stages called inside it:
the NL write and ASL load (``session.Session``), the Ipopt solves (with cyipopt's callbacks into
PyNumero and the point loaded back), the legs' model builds, the legs' values read out, the rest of
``legs.solve_leg`` (its guards, the models' teardown), the re-simulations, the circuit, the
dissension weights, the fleet's plan and the joint optimum (both without their solves and NL
writes, which are under those stages), the imports and the rest of the command. Writes
{stage: CPU s} to OUT.json and prints it as a markdown table with each stage's share. The command
is otherwise the same (its output is written as without the wrappers).
"""
import functools
import json
import os
import sys
import time

T0 = time.process_time()
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from ecostudy.ocp import solver  # noqa: E402

solver.configure()

from ecostudy.network import circuit, fleet, joint, legs, rules, scoring, strategies  # noqa: E402
from ecostudy.ocp import session, timedomain  # noqa: E402

ACC: dict = {}
STACK: list = []  # CPU seconds of the stages inside each open stage


def timed(name, fn):
    """``fn`` adding its CPU seconds, less those of the stages inside it, to ``ACC[name]``."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        c0 = time.process_time()
        STACK.append(0.0)
        try:
            return fn(*args, **kwargs)
        finally:
            spent = time.process_time() - c0
            ACC[name] = ACC.get(name, 0.0) + spent - STACK.pop()
            if STACK:
                STACK[-1] += spent
    return wrapper


def wrap():
    session.Session.__init__ = timed("NL write and ASL load (`Session`)", session.Session.__init__)
    session.Session.solve = timed("Ipopt solves (with the callbacks, the point loaded back)", session.Session.solve)
    legs.leg_model = timed("leg model builds", legs.leg_model)
    timedomain.leg_arrays = timed("leg values read out (`leg_arrays`)", timedomain.leg_arrays)
    scoring.verify = timed("re-simulations", scoring.verify)
    circuit.solve_steps = timed("circuit", circuit.solve_steps)
    circuit.sensed_voltages = timed("circuit", circuit.sensed_voltages)
    rules.dissension_weights = timed("dissension weights", rules.dissension_weights)
    fleet.plan = timed("fleet plan, without its solves", fleet.plan)
    strategies.joint = timed("joint optimum, without its solve", joint.joint)
    fleet.solve_leg = timed("rest of `solve_leg` (guards, teardown)", legs.solve_leg)


def main():
    out = sys.argv[1]
    sys.argv = ["ecostudy"] + sys.argv[2:]
    wrap()
    from ecostudy.cli import main as command
    exit_now = os._exit
    os._exit = lambda code=0: (_ for _ in ()).throw(SystemExit(code))  # the CLI's fast exit, returned here
    c0 = time.process_time()
    STACK.append(0.0)
    try:
        command()
    except SystemExit:
        pass
    finally:
        os._exit = exit_now
    ACC["rest of the command (tables, files)"] = time.process_time() - c0 - STACK.pop()
    ACC["imports before the command"] = c0 - T0
    total = time.process_time() - T0
    with open(out, "w") as f:
        json.dump({**ACC, "total": total}, f, indent=1)
    print("| stage | CPU s | share |\n|---|---:|---:|")
    for name, cpu in sorted(ACC.items(), key=lambda kv: -kv[1]):
        print(f"| {name} | {cpu:.1f} | {100 * cpu / total:.1f} % |")
    print(f"| total | {total:.1f} | |")


if __name__ == "__main__":
    main()
