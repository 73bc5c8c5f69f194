"""What a traction power limit that never binds would do kept in the convex SOCP.

    .venv/bin/python bench/probe_power_row.py

The SOCP (``ocp.convex.ConvexProgram``) leaves out a traction power limit that never binds
(``core.grid.drop_idle_power``). This plans the thesis commuter on the advanced 1 km trip (100
nodes, window 0-200 s) with limits of 1e6 kW and 1e7 kW, once as the tool does (dropped) and once
with the dropping disabled (the limit kept as its tangent rows), each with and without the
polishing rounds, and prints Clarabel's status, the largest relaxation gap max |rho s - 1|, the
rows of the assembled program and the solve time.
"""
import dataclasses
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ecostudy.core import grid  # noqa: E402
from ecostudy.core.grid import make_segment  # noqa: E402
from ecostudy.core.physics import Envelope  # noqa: E402
from ecostudy.core.types import State  # noqa: E402
from ecostudy.io.loaders import load_track, load_train  # noqa: E402
from ecostudy.ocp import convex  # noqa: E402


def main():
    warnings.simplefilter("ignore")  # the dropped limit's warning, once per program
    train = load_train(ROOT / "trains/yazhemsky2017_commuter.yaml")
    segment = make_segment(load_track(ROOT / "tracks/yazhemsky2017_advanced_1km.yaml"), train, "A", "B")
    nodes = convex.trapezoid_grid(segment, 100)
    polish = convex.MORE_POLISH
    print("| power limit [kW] | limit | polishing | status | max abs(rho s - 1) | program rows | solve s |")
    print("|---|---|---|---|---:|---:|---:|")
    for power_w in (1e9, 1e10):
        heavy = dataclasses.replace(train, traction=Envelope("force_power", max_force=1e6, max_power=power_w))
        for kept in (False, True):
            convex.drop_idle_power = (lambda segment, train, formulation: (train, ())) if kept else grid.drop_idle_power
            for rounds in (polish, 0):
                convex.MORE_POLISH = rounds
                program = convex.ConvexProgram(segment, heavy, nodes, convex.ConvexWeights())
                rows = program.assemble(nodes, State(), (0.0, 200.0), 0.0, 1.0, None)[0].shape[0]
                plan = program.solve(State(), (0.0, 200.0))
                print(f"| {power_w / 1e3:.0e} | {'kept' if kept else 'dropped'} | {'on' if rounds else 'off'} | "
                      f"{plan.status} | {plan.gap:.1e} | {rows} | {plan.seconds:.3f} |")
    convex.drop_idle_power, convex.MORE_POLISH = grid.drop_idle_power, polish


if __name__ == "__main__":
    main()
