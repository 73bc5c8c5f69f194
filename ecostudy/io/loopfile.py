"""The schema of a closed-loop study file (``ecostudy simulate``): controllers x deviation draws.

Units are in the field names, as in :mod:`ecostudy.io.schemas`. Defaults are Yazhemsky 2017's Ch.9
(controller) and Ch.10 (noise) values.
"""
import math
from typing import Annotated, Any, ClassVar, Literal, Optional, Self, Union

from pydantic import Field, model_validator

from ecostudy.core.registry import Registry
from ecostudy.io.schemabase import FileName, Name
from ecostudy.io.schemabase import unique
from ecostudy.io.schemas import Strict


# service braking of trains is near 1 m/s^2 and emergency braking with magnetic track brakes below
# 3 m/s^2: a planned level above 5 is beyond any train (1e300 ran 7000 solves without a plan)
BRAKE_LEVEL_MAX_MPS2 = 5.0


class ConvexSettings(Strict):
    """Weights and buffers of Yazhemsky 2017 eq. 6.10 (Ch.9 values)."""

    time: float = Field(1.0, ge=0, description="w_t [1/s].")
    energy: float = Field(1.0, ge=0, description="w_e, on the force per speed and unit mass.")
    overspeed: float = Field(0.02, ge=0, description="w_os, on the speed inside the buffer.")
    braking: float = Field(1.0, ge=0, description="w_br, on braking beyond brake_level_mps2.")
    buffer_mps: float = Field(1.0, ge=0, description="B_os: the soft buffer below the speed limit [m/s].")
    brake_level_mps2: float = Field(0.8, gt=0, description="B_brk: planned braking above it is penalised [m/s^2]; "
                                    "at most 5 (beyond any train's braking).")

    @model_validator(mode="after")
    def _usable(self) -> Self:
        if self.brake_level_mps2 > BRAKE_LEVEL_MAX_MPS2:
            raise ValueError(f"brake_level_mps2: {self.brake_level_mps2:g} m/s^2 is above {BRAKE_LEVEL_MAX_MPS2:g}, "
                             "beyond any train's braking (service braking near 1 m/s^2, emergency braking below 3)")
        if self.time == 0 and self.energy == 0:  # the plan would follow the penalties alone (ran 17.5 m long)
            raise ValueError("time, energy: both 0: the plan has no time or energy to weigh; give one above 0")
        return self


COMMON = {"name", "kind", "sample_time_s", "das_levels", "delay_samples", "compute_delay"}
# The controller kinds, registered by the closed-loop study (``studies.controllers``: a builder per
# kind, with the fields it reads besides COMMON; any other field given to it is refused here).
CONTROLLER_KINDS: Registry[Any] = Registry("controller kind")  # builders of studies.controllers


class RspcSettings(Strict):
    """Farooqi 2018 Ch. 6's receding-horizon switched controller (``control/rspc.py``)."""

    horizon: int = Field(3, ge=1, le=6, description="N, prediction steps (6^N mode sequences per sample).")
    distance_m: float = Field(25.0, gt=0, description="D, the nominal prediction step [m] (Alg. 6).")
    gamma: float = Field(0.995, ge=0, le=1, description="gamma_S of Farooqi 2018 eq. 6.7: the weight of the horizon time.")
    margin_s: float = Field(1.5, ge=0, description="Aim this much before the latest arrival [s].")


class Controller(Strict):
    """One controller of the study.

    ``convex``: Yazhemsky 2017's SOCP 6.10 re-solved every sample; ``open_loop``: the same SOCP's plan
    from the stand, replayed by position without feedback; ``ato``: the full-horizon
    energy-optimal ATO run (Ipopt NLP) at the latest arrival, replayed open loop by position;
    ``sbpc``: Farooqi 2018's shrinking-horizon move-blocking controller arriving at the latest
    arrival (blocks of ``block`` samples, ``variant``); ``sppc``: Farooqi 2018's shrinking-horizon
    parametrised controller (DAS modes, ``variant`` nominal or two_step); ``rspc``: Farooqi 2018's
    receding-horizon switched controller (DAS modes, ``rspc`` settings). ``das_levels`` applies any controller's
    handle as the nearest of the train's DAS levels, ``delay_samples`` later (a driver).
    ``compute_delay`` is the solver's delay (``control/loop.py``), for every kind. An option the
    kind does not read (``USES``) is refused, so a misplaced one cannot pass silently.
    """

    name: FileName = Field(description="Also a file name part (steps/<name>_draw<i>.csv).")
    kind: str = Field(description="A registered controller kind (``studies.controllers``).")
    settings: ConvexSettings = ConvexSettings()
    rspc: RspcSettings = RspcSettings()
    estimator: Union[bool, Literal["mass", "state"]] = Field(
        False, description="Feed the controller a mass estimate: true or 'mass', the scalar Kalman filter of "
        "Yazhemsky 2017 §10.3; 'state', the EKF of position, speed, mass and disturbance (control/ekf.py).")
    scheme: Literal["midpoint", "left"] = "midpoint"
    block: int = Field(20, ge=1, description="SBPC: L, samples per blocked move (Farooqi 2018 eq. 4.8).")
    variant: Literal["nominal", "two_step", "multi"] = "nominal"
    omega: float = Field(3505.0, gt=0, description="SBPC multi-objective weight on the terminal distance (4.31).")
    transcription: Literal["simultaneous", "condensed"] = Field(
        "simultaneous", description="SBPC: the FHOCP with the states as variables (Ipopt) or condensed to the "
        "block handles (SLSQP; faster per sample for long blocks, slower for L = 1; docs/closed_loop.md).")
    sample_time_s: Optional[float] = Field(None, gt=0, le=60, description="This controller's period and "
                                           "real-time budget [s] (default: the study's sample_time_s).")
    brake_reserve: Optional[float] = Field(None, ge=0, lt=1, description="sbpc, sppc, rspc: the share of the "
                                           "braking envelope their plans hold back (default 0, 0.1, 0.2; 0.2 covers "
                                           "a train 10 % heavier with 10 % weaker brakes).")
    das_levels: bool = Field(False, description="Apply the handle as the nearest DAS level of the train.")
    delay_samples: int = Field(0, ge=0, le=100, description="Driver reaction delay with das_levels [samples].")
    compute_delay: Union[Annotated[int, Field(ge=0, le=100)], Literal["measured"]] = Field(
        1, description="The computation delay: the control planned from the state at sample k acts from k + "
        "compute_delay, planned from the state predicted for then (the previous control holds meanwhile); "
        "'measured': when its solve time has elapsed (not repeatable). 0: solving takes no time.")
    terminal_reserve: Optional[float] = Field(None, ge=0, lt=1, description="sbpc, sppc: stop with a terminal "
                                              "approach (control/terminal.py): full braking on the stopping "
                                              "curve of the brake less this share, coasting otherwise (none: "
                                              "the controller's own stop).")
    terminal_fit: bool = Field(False, description="sbpc, sppc: the terminal approach's curve follows the "
                               "braking measured on the run's full-brake samples, terminal_reserve its prior "
                               "(control/brakefit.py; needs terminal_reserve).")
    time_budget_s: Optional[float] = Field(None, gt=0, description="convex: a solve longer than this is not "
                                           "applied; the last plan is, shifted (default: none, repeatable).")

    @model_validator(mode="after")
    def _options_of_the_kind(self) -> Self:
        if self.kind not in CONTROLLER_KINDS:
            raise ValueError(f"kind: unknown controller kind {self.kind!r}; known: {', '.join(CONTROLLER_KINDS.names())}")
        uses = CONTROLLER_KINDS.spec(self.kind).uses
        if self.kind == "sppc" and self.variant == "multi":
            raise ValueError("sppc has the variants nominal and two_step (no multi-objective one is built)")
        if self.transcription != "simultaneous" and self.kind != "sbpc":
            raise ValueError("transcription is an SBPC setting")
        reserve_kinds = [s.name for s in CONTROLLER_KINDS if "brake_reserve" in s.uses]
        if self.brake_reserve is not None and "brake_reserve" not in uses:
            raise ValueError(f"brake_reserve is for {', '.join(reserve_kinds)} (the convex controller's is "
                             "settings.brake_level_mps2)")
        if self.delay_samples and not self.das_levels:
            raise ValueError("delay_samples: the driver's reaction delay acts on the DAS levels only (das_levels: true)")
        if self.terminal_fit and self.terminal_reserve is None:
            raise ValueError("terminal_fit needs terminal_reserve (the share of the brake held back until "
                             "the train's braking is measured)")
        unused = sorted(self.model_fields_set - COMMON - uses)
        if unused:
            raise ValueError(f"{', '.join(unused)}: not used by a controller of kind {self.kind!r} (it reads "
                             f"{', '.join(sorted(uses)) or 'none of the controller options'})")
        return self


class Range(Strict):
    """True parameter as a multiple of the model's, drawn uniformly from [low, high] per run."""

    low: float = Field(gt=0, le=10)
    high: float = Field(gt=0, le=10, description="At most 10 times the model's (a wider spread is another train).")

    @model_validator(mode="after")
    def _ordered(self) -> Self:
        if self.high < self.low:
            raise ValueError("high must be at least low")
        return self


class Deviations(Strict):
    """The plant's true parameters per run (default: the model itself)."""

    mass: Range = Range(low=1.0, high=1.0)
    resistance: Range = Range(low=1.0, high=1.0)
    traction: Range = Range(low=1.0, high=1.0)
    braking: Range = Range(low=1.0, high=1.0)


class NoiseSettings(Strict):
    """Standard deviations of Yazhemsky 2017 eqs. 10.2-10.4 (zero: none)."""

    acceleration_mps2: float = Field(0.0, ge=0, le=5, description="sigma_a of the process noise.")
    period_s: float = Field(1.0, gt=0, description="The process noise is redrawn every period (thesis: 1 Hz).")
    position_m: float = Field(0.0, ge=0, le=100, description="sigma_X of the position reading.")
    speed_mps: float = Field(0.0, ge=0, le=10, description="sigma_V of the speed reading.")
    accelerometer_mps2: float = Field(0.0, ge=0, le=10, description="sigma_A of the acceleration reading "
                                      "(the mass estimator's input, Yazhemsky 2017 §10.3.5).")


class SimulateFile(Strict):
    file_kind: ClassVar[str | None] = "closed-loop study"
    name: Name
    track: Name
    train: Name
    from_stop: Optional[str] = Field(None, alias="from")
    to_stop: Optional[str] = Field(None, alias="to")
    window_s: tuple[Annotated[float, Field(le=86400)], Annotated[float, Field(le=86400)]] = Field(
        description="Arrival window [T_min, T_max] on the trip's clock [s], within a day.")
    points: int = Field(500, ge=10, le=20000, description="K, the controller's grid nodes.")
    sample_time_s: float = Field(0.1, gt=0, le=60, description="Controller period; also its real-time budget.")
    controllers: list[Controller] = Field(min_length=1)
    deviations: Deviations = Deviations()
    noise: NoiseSettings = NoiseSettings()
    draws: int = Field(1, ge=1, le=100000, description="Monte Carlo draws of deviations and noise seeds.")
    seed: int = Field(0, ge=0)
    output: Optional[str] = None

    @model_validator(mode="after")
    def _checks(self) -> Self:
        unique("controllers", [c.name for c in self.controllers])
        if not 0 <= self.window_s[0] <= self.window_s[1]:
            raise ValueError("window_s: must be [earliest, latest] with 0 <= earliest <= latest")
        for i, c in enumerate(self.controllers):
            if (c.sample_time_s or self.sample_time_s) >= self.window_s[1]:
                raise ValueError(f"{'sample_time_s' if c.sample_time_s is None else f'controllers[{i}].sample_time_s'}: "
                                 "must be shorter than the latest arrival window_s[1]")
            samples = self.window_s[1] / (c.sample_time_s or self.sample_time_s)  # inf past 1e308 (a 1e-320 s step)
            if "block" in c.model_fields_set and math.isfinite(samples) and c.block > math.ceil(samples):
                raise ValueError(f"controllers[{i}].block: {c.block} samples a move is more than the run's "
                                 f"{math.ceil(samples)} (window_s[1] / sample_time_s)")
        return self
