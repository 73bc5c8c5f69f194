"""Where a run's energy goes: the energy drawn from the line, the losses in traction, the traction
at the wheel, and what the wheel's work becomes (running resistance, potential and kinetic energy,
braking: regeneration returned to the line and the rest dissipated).

The work--energy balance of the speed recursion (Farooqi 2018, eq. 2.1 with the interval
resistance of eq. 2.2; the net energy of eq. 7.3) summed over the grid:

    sum F_T ds = sum R_v(v0, v1) ds + sum R_c ds + sum Ms g tan(alpha) ds + M (v_D^2 - v_0^2) / 2
                 + sum F_B ds

holds to the solver's tolerance on a solved run; ``residual`` is what is left. Every term is
computed by the functions the NLP uses (``physics.interval_resistance``, ``physics.gradient_force``,
``physics.line_energy``, ``kinematics.interval_grade_force`` / ``interval_davis``).
"""
from typing import NamedTuple

import numpy as np

from ecostudy.analysis.tables import regenerated_force
from ecostudy.core.kinematics import interval_davis, interval_grade_force
from ecostudy.core.physics import gradient_force, interval_resistance, line_energy


class EnergyFlow(NamedTuple):
    """A run's energy flow [J]; every field SI (:meth:`kwh` for display)."""

    drawn: float        # from the line for traction: sum F_T ds / eta_T
    traction_losses: float  # drawn - traction
    traction: float     # at the wheel: sum F_T ds
    resistance: float   # running (Davis, tunnel) and curve resistance work
    potential: float    # potential energy gained (negative: lost going downhill)
    kinetic: float      # kinetic energy gained between the first and last node
    braking: float      # braking work at the wheel: sum F_B ds (friction and electric)
    regenerated: float  # returned to the line: sum eta_R F_R ds
    dissipated: float   # braking - regenerated: friction brakes and the electric brake's losses
    residual: float     # traction - (resistance + potential + kinetic + braking)

    @property
    def net(self):
        """Net energy from the line [J]: drawn - regenerated (eq. 7.3)."""
        return self.drawn - self.regenerated

    def parts(self):
        """What the traction at the wheel becomes [J], by name (adds up to ``traction - residual``)."""
        return {"resistance": self.resistance, "potential energy": self.potential,
                "kinetic energy": self.kinetic, "regeneration returned": self.regenerated,
                "braking dissipated": self.dissipated}


def energy_flow(segment, train, trajectory):
    """The :class:`EnergyFlow` of a run on its grid (``trajectory``: core.types.Trajectory, SI).

    Parameters
    ----------
    segment : core.grid.Segment  The run's segment (gradient, curvature, tunnels).
    train : core.types.Train  Its train (masses, Davis coefficients, efficiencies, envelopes).
    trajectory : core.types.Trajectory  Node positions [m] and speeds [m/s], interval forces [N].
    """
    nodes, v, ft, fb = trajectory.nodes, trajectory.v, trajectory.ft, trajectory.fb
    ds = np.diff(nodes)
    vm = 0.5 * (v[:-1] + v[1:])
    middle = 0.5 * (nodes[:-1] + nodes[1:])
    fixed = interval_grade_force(segment, train, nodes)            # gradient and curve [N]
    grade = gradient_force(train.static_mass, segment.gradient(middle))
    davis = interval_resistance(v[:-1], v[1:], interval_davis(segment, train, nodes), 0.0)
    fr = regenerated_force(train, v, fb)
    zero = np.zeros_like(ft)
    drawn = float(np.sum(line_energy(ft, zero, vm, ds, train.eta_traction, train.eta_regeneration)))
    regenerated = -float(np.sum(line_energy(zero, fr, vm, ds, train.eta_traction, train.eta_regeneration)))
    traction, braking = float(ft @ ds), float(fb @ ds)
    resistance = float((davis + fixed - grade) @ ds)
    potential = float(grade @ ds)
    kinetic = 0.5 * train.mass * float(v[-1] ** 2 - v[0] ** 2)
    return EnergyFlow(drawn=drawn, traction_losses=drawn - traction, traction=traction,
                      resistance=resistance, potential=potential, kinetic=kinetic, braking=braking,
                      regenerated=regenerated, dissipated=braking - regenerated,
                      residual=traction - (resistance + potential + kinetic + braking))


def run_energy_flow(result):
    """:func:`energy_flow` of an ``analysis.single.RunResult`` (one solved here: it carries the SI
    :class:`~ecostudy.core.types.Trajectory` the flow is computed from)."""
    if result.trajectory is None:
        raise ValueError("this run carries no SI trajectory (a run read back from its files): solve it again "
                         "to see its energy flow")
    return energy_flow(result.segment, result.train, result.trajectory)
