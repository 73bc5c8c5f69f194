"""SI objects shared by every layer: a train, a track, a timing request, a timing point, a supply,
a state and a run's trajectory.

Built by the loaders (:mod:`ecostudy.io.loaders`) or in code; everything here is SI.
"""
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from ecostudy.core.adhesion import Adhesion
from ecostudy.core.defaults import DRAFT_GEAR_TRAVEL_M
from ecostudy.core.physics import EfficiencyMap, Envelope
from ecostudy.core.units import FloatArray, Numeric

SOURCE = "source_file"  # the attribute a track or train read from a file keeps: (file, its SHA-256 then)


def source_file(value: object) -> tuple[str, str] | None:
    """(file, SHA-256 as it was read) of a track or train read from a file (``io.documents.read_from``),
    None for one built in code: what a saved run's ``inputs.json`` names, for ``ecostudy check`` to
    re-simulate it against, and what a warning about the file names."""
    return getattr(value, SOURCE, None)


@dataclass(frozen=True)
class Train:
    """A train in SI units."""

    name: str
    mass: float                 # effective (inertial) mass M [kg]
    static_mass: float          # Ms [kg]
    length: float               # [m]
    davis: tuple[float, float, float]  # (A [N], B [N s/m], C [N s^2/m^2])
    traction: Envelope
    braking: Envelope
    regeneration: Envelope | None = None
    traction_efficiency: float = 1.0
    regeneration_efficiency: float = 0.0
    curve_coefficient: float = 0.0    # lambda_t [m^2/s^2]
    das_levels: tuple[float, ...] = (-1.0, 0.0, 0.5, 0.75, 1.0)
    max_speed: float = float("inf")   # the train's top speed [m/s]: caps every speed limit
    max_acceleration: float = float("inf")  # bound on the net acceleration [m/s^2] (comfort)
    max_deceleration: float = float("inf")  # bound on the net deceleration [m/s^2], on top of the brakes
    curve_resistance: str = "coefficient"   # "coefficient": Ms lambda_t / r; "roeckl": Roeckl's formula
    # ((cross section [m^2], extra C [N s^2/m^2]), ...) ascending
    tunnel_resistance: tuple[tuple[float, float], ...] = ()
    traction_efficiency_map: EfficiencyMap | None = None      # eta_T(v, F) instead of the constant
    regeneration_efficiency_map: EfficiencyMap | None = None  # eta_R(v, F) instead of the constant
    adhesion: Adhesion | None = None  # mu(v) m_adh g: the envelopes are capped at it, runs checked against it
    # why the calibration that wrote this train's file was not ok (its ``calibration`` block); '' when it
    # was ok or the file is not a calibration's: every run of the train is flagged with it (core.status.calibrated)
    calibration_reason: str = ""
    # (curves, tunnels): how the train's file would give curves and tunnels a resistance, in that file's own
    # fields (its reader's words: an OSRD or TTOBench file has not the YAML's), for core.grid.warn_unpaired
    # (message text naming its file: not in the train's repr, which is its physics)
    unpaired: tuple[str, str] = field(default=("the train's curve_coefficient_m2ps2 is 0 (set it, or curve_resistance: "
                                               "roeckl)", "the train gives no tunnel_resistance"), repr=False)
    traction_field: str = "traction"  # the field of its file that gives its traction (TTOBench: max traction force)

    @property
    def rotating_mass_factor(self) -> float:
        """The rotating-mass allowance a train file gives: M / Ms - 1 (the loader's inverse)."""
        return self.mass / self.static_mass - 1.0

    @property
    def eta_traction(self) -> EfficiencyMap | float:
        """The traction efficiency as the net energy uses it: the map, else the constant."""
        return self.traction_efficiency_map or self.traction_efficiency

    @property
    def eta_regeneration(self) -> EfficiencyMap | float:
        """The regeneration efficiency: the map, else the constant."""
        return self.regeneration_efficiency_map or self.regeneration_efficiency

    def electric_brake(self, braking: Numeric, speed: Numeric) -> Numeric:
        """The part [N] of a braking force ``braking`` [N] the electric (regenerative) brake takes at
        ``speed`` [m/s]: all of it up to the regenerative envelope, none without one."""
        if self.regeneration is None:
            return 0.0 * braking
        return np.minimum(braking, self.regeneration.force(speed))

    def with_brake_reserve(self, share: float) -> "Train":
        """This train as a controller plans with it: ``share`` of the service brake held back (the
        braking envelope times 1 - share), for the deviations a plan cannot see."""
        return replace(self, braking=self.braking.scaled(1.0 - share)) if share else self

    def without_idle_power(self, speeds: Numeric) -> tuple["Train", tuple[str, ...]]:
        """(this train without a traction power limit that never binds at ``speeds`` [m/s], the names
        of the envelopes whose limit was dropped): see :func:`ecostudy.core.physics.power_never_binds`.
        Only traction, the limit every formulation has (the SOCP as tangent rows); a braking or
        regenerative power limit is left as it is."""
        idle = {name: getattr(self, name).without_power() for name in ("traction",)
                if getattr(self, name).idle_power(speeds)}
        return (replace(self, **idle) if idle else self), tuple(idle)

    def tunnel_coefficient(self, cross_section: float) -> float:
        """Extra quadratic resistance C [N s^2/m^2] in a tunnel of ``cross_section`` [m^2]: the
        train's table, interpolated linearly between its sections, held beyond its ends."""
        if not self.tunnel_resistance:
            return 0.0
        areas, coefficients = zip(*self.tunnel_resistance)
        return float(np.interp(cross_section, areas, coefficients))


@dataclass(frozen=True)
class Track:
    """A track in SI units; piecewise-constant profiles start at their positions."""

    name: str
    length: float
    stops: dict[str, float]          # name -> position [m]
    gradient_positions: np.ndarray   # [m]
    gradients: np.ndarray            # tan(alpha) [-], positive uphill
    curve_positions: np.ndarray      # [m]
    curvatures: np.ndarray           # 1/radius [1/m] at the section's start, signed by direction, 0 straight
    limit_positions: np.ndarray      # [m]
    limits: np.ndarray               # [m/s]
    curvature_slopes: np.ndarray | None = None  # d(1/radius)/dx [1/m^2]: clothoids; None: all constant
    tunnels: tuple[tuple[float, float, float], ...] = ()  # ((start [m], length [m], cross section [m^2]), ...)


@dataclass(frozen=True)
class Timing:
    """What the run must achieve in time: exactly one of the fields is set (or none: all-out)."""

    running_time: float | None = None       # [s]
    supplement: float | None = None         # fraction of the all-out time [-]
    window: tuple[float, float] | None = None  # (earliest, latest) [s]


@dataclass(frozen=True)
class Window:
    """A timing point between the stops, in travel distance from the departure stop (SI)."""

    distance: float                 # [m] from the departure stop
    earliest: float | None = None   # [s] since departure
    latest: float | None = None
    min_speed: float | None = None  # [m/s]
    max_speed: float | None = None


@dataclass(frozen=True)
class Supply:
    """One substation and its line [SI: V, Ohm, Ohm/m, m]."""

    position: float               # x_sub on the line [m]
    voltage: float = 750.0        # V_s [V]
    resistance: float = 0.01      # R_s [Ohm]
    line_resistance: float = 25e-6  # r [Ohm/m] (Farooqi 2018 §7.2.1: 25 mOhm/km)
    max_voltage: float = 856.0    # V_max, regeneration cut-off [V] (685/600 of 750 V)
    min_voltage: float = 500.0    # lowest pantograph voltage [V]
    max_current: float = float("inf")        # largest current a train draws [A] (thesis Fig. 7.7)
    max_regen_current: float = float("inf")  # largest current a train feeds [A] (thesis Fig. 7.7)

    def feeder(self, x: Numeric) -> FloatArray:
        """R(x) [Ohm] between the bus and a train at line position ``x`` [m]."""
        return self.line_resistance * np.abs(np.asarray(x, float) - self.position)

    def most_power(self, nearest: float) -> float:
        """The most power [W] a lone train ``nearest`` [m] from the substation can draw at its
        pantograph: P = V (V_s - V) / (R_s + R(x)) at the pantograph voltage V no lower than
        ``min_voltage`` (the most at V = V_s / 2), and V_s I_max at most under a current limit."""
        v = max(self.min_voltage, 0.5 * self.voltage)
        resistance = self.resistance + self.line_resistance * abs(nearest)
        line = v * (self.voltage - v) / resistance if resistance > 0 else float("inf")
        return min(line, self.voltage * self.max_current)


@dataclass(frozen=True)
class State:
    """Where a train is: travel distance from its departure stop [m], speed [m/s], clock [s]."""

    position: float = 0.0
    speed: float = 0.0
    time: float = 0.0


class Trajectory(NamedTuple):
    """A run on its grid in SI: node positions and speeds, interval times and forces [m, m/s, s, N]."""

    nodes: np.ndarray
    v: np.ndarray
    dt: np.ndarray
    ft: np.ndarray
    fb: np.ndarray

    @property
    def time(self) -> FloatArray:
        """Clock at every node [s], 0 at the start of the run."""
        return np.concatenate([[0.0], np.cumsum(self.dt)])


@dataclass(frozen=True)
class AirBrake:
    """The wagons' air brakes as a brake pipe signal and a cylinder build-up (SI)."""

    signal_speed: float   # c [m/s]: the brake signal runs from the head at this speed
    build_up: float       # tau_b [s]: first-order time constant of a wagon's brake force rising
    release: float        # tau_r [s]: the same falling


@dataclass(frozen=True)
class DraftGear:
    """Every coupling's draft gear: free slack and loading/unloading stiffness (SI)."""

    slack: float                 # total free play of a coupling [m] (the dead band, +-slack/2)
    loading_stiffness: float     # k_l [N/m]: |deflection| growing
    unloading_stiffness: float   # k_u [N/m]: |deflection| shrinking
    transition_speed: float      # v_0 [m/s]: loading and unloading blend over this closing speed
    smoothing: float             # epsilon [m]: the dead band's corners rounded over this deflection


@dataclass(frozen=True)
class Notches:
    """The locomotives' discrete control positions: traction notch k of ``traction`` applies k /
    ``traction`` of the traction envelope at the locomotive's speed, dynamic-brake notch k of
    ``dynamic_brake`` k / ``dynamic_brake`` of the dynamic-brake envelope."""

    traction: int        # notches above idle
    dynamic_brake: int   # dynamic-brake notches above off


@dataclass(frozen=True)
class Consist:
    """A long train as cars in train order (the head first) joined by couplers, SI (Zhang & Zhuan eq. 1)."""

    name: str
    kinds: tuple[str, ...]       # "locomotive" | "wagon" per car
    mass: np.ndarray             # [kg] per car
    length: np.ndarray           # [m] per car
    resistance: np.ndarray       # (n, 3): c0 [m/s^2], c1 [1/s], c2 [1/m] per car, per unit mass
    traction: tuple[Envelope | None, ...]  # Envelope per car, None for wagons
    dynamic_brake: tuple[Envelope | None, ...]  # Envelope per car, None where there is none
    pneumatic_brake: np.ndarray  # [N] per car, largest pneumatic brake force
    stiffness: float             # k [N/m] of every coupler
    damping: float               # d [N s/m]
    force_limit: float           # |f_in| allowed [N]
    air_brake: AirBrake | None = None    # the plant's air-brake propagation, where the file gives it
    draft_gear: DraftGear | None = None  # the plant's draft gears, where the file gives them
    notches: Notches | None = None        # the locomotives' throttle and dynamic-brake notches, where the file gives them
    draft_gear_travel: float = DRAFT_GEAR_TRAVEL_M  # [m] a coupling closes beyond its slack before its draft gears go solid

    @property
    def cars(self) -> int:
        return len(self.kinds)

    @property
    def locomotives(self) -> list[int]:
        """Indices of the locomotives."""
        return [i for i, k in enumerate(self.kinds) if k == "locomotive"]
