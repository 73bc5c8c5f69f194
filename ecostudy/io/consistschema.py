"""The consist file's schema: a long train as an ordered list of vehicles joined by couplers
(Zhang & Zhuan eq. 1, Tables I-II); units in the field names."""
from typing import ClassVar, Literal, Optional, Self

from pydantic import Field, model_validator

from ecostudy.core.defaults import DRAFT_GEAR_TRAVEL_M
from ecostudy.io.schemabase import Strict


class CarResistance(Strict):
    """f_r = m (c0 + c1 v + c2 v^2), per unit mass (Zhang & Zhuan eq. 1; its Table I misprints c2 as c0)."""

    c0_mps2: float = Field(ge=0, le=1)
    c1_per_s: float = Field(ge=0, le=1)
    c2_per_m: float = Field(ge=0, le=1)


class ForcePower(Strict):
    max_force_kN: float = Field(gt=0, le=10000)
    max_power_kW: Optional[float] = Field(None, gt=0)


class VehicleType(Strict):
    kind: Literal["locomotive", "wagon"]
    mass_t: float = Field(ge=1, le=1000)
    length_m: float = Field(gt=0, le=100)
    resistance: CarResistance
    traction: Optional[ForcePower] = Field(None, description="Locomotives: traction envelope.")
    dynamic_brake: Optional[ForcePower] = Field(None, description="Locomotives: electric (dynamic) brake.")
    pneumatic_brake_kN: float = Field(0.0, ge=0, le=2000, description="Wagons: largest pneumatic brake force.")

    @model_validator(mode="after")
    def _kind(self) -> Self:
        if self.kind == "locomotive" and self.traction is None:
            raise ValueError("a locomotive needs 'traction'")
        if self.kind == "wagon" and (self.traction is not None or self.dynamic_brake is not None):
            raise ValueError("a wagon has no traction or dynamic brake: give pneumatic_brake_kN")
        if self.kind == "locomotive" and self.pneumatic_brake_kN > 0:  # the plant would add it beyond the grip cap
            raise ValueError("pneumatic_brake_kN: a locomotive brakes with its dynamic_brake here (Zhang & Zhuan's "
                             "model); the pneumatic brake is the wagons'")
        return self


class Group(Strict):
    """``count`` vehicles of one type, in train order."""

    type: str
    count: int = Field(1, ge=1, le=1000)


# A coupling joins two freight draft gears in series (one at each car's end). Published linear
# equivalents of its stiffness: Zhang & Zhuan's k = 10 488 kN/m (Table II) to 23 851 kN/m, two Miner
# TF-880 gears (AAR M-901E) at their maximum capacity, 858 000 lbf at 3.15 in (Miner's specification);
# outside half the lowest to twice the highest (rounded) a value is warned of (docs/heavyhaul.md,
# "Consist files": the sources, and that the margin is ecostudy's choice, not theirs)
PLAUSIBLE_STIFFNESS_KN_PER_M = (5e3, 5e4)
STIFFNESS_SOURCES = ("published linear equivalents of a coupling of two freight draft gears run from 10488 kN/m "
                     "(Zhang & Zhuan 2013, Table II) to 23851 kN/m (two Miner TF-880 AAR M-901E gears in series at "
                     "their maximum capacity); the range is half the lowest to twice the highest, docs/heavyhaul.md "
                     "'Consist files'")


class Couplers(Strict):
    stiffness_kN_per_m: float = Field(gt=0, le=1e6)
    damping_kNs_per_m: float = Field(ge=0, le=1e5)
    force_limit_kN: float = Field(gt=0, le=1e5, description="Largest allowed |in-train force|.")
    draft_gear_travel_m: float = Field(DRAFT_GEAR_TRAVEL_M, gt=0, le=1, description="How far a coupling closes "
                                       "beyond its slack before its two draft gears go solid (default: 2 x 3.25 in, "
                                       "AAR M-901E Group J); a run closing one further is flagged.")


class AirBrake(Strict):
    """The wagons' air brakes (the plant's ``air_brake`` effect): a wagon's brake force follows its
    command once the brake pipe signal, running from the head at ``signal_speed_mps``, has reached it,
    rising (falling) as a first-order lag of ``build_up_s`` (``release_s``)."""

    signal_speed_mps: float = Field(gt=0, le=400, description="Brake pipe signal speed (UIC 540: >= 250 m/s).")
    build_up_s: float = Field(gt=0, le=120, description="Time constant of a wagon's brake force rising.")
    release_s: float = Field(gt=0, le=300, description="Time constant of a wagon's brake force falling.")
    source: str = Field(min_length=1, description="Where the values come from (or that they are typical).")


class DraftGear(Strict):
    """Every coupling's draft gear (the plant's ``draft_gear`` effect): ``slack_mm`` of free play, then
    the loading stiffness while the deflection grows and the unloading stiffness while it shrinks (the
    loop between them is the energy the gear dissipates). The controller keeps ``couplers``' linear
    stiffness and damping (its design model); the damping acts only with the slack taken up."""

    slack_mm: float = Field(ge=0, le=200, description="Total free play of a coupling (dead band +-slack/2).")
    loading_stiffness_kN_per_m: float = Field(gt=0, le=1e6)
    unloading_stiffness_kN_per_m: float = Field(gt=0, le=1e6)
    transition_speed_mps: float = Field(0.01, gt=0, le=1, description="Loading and unloading blend over "
                                        "this closing speed (tanh).")
    smoothing_mm: float = Field(0.5, gt=0, le=10, description="The dead band's corners rounded over this.")
    source: str = Field(min_length=1, description="Where the values come from (or that they are typical).")

    @model_validator(mode="after")
    def _loop(self) -> "DraftGear":
        if self.unloading_stiffness_kN_per_m > self.loading_stiffness_kN_per_m:
            raise ValueError("unloading_stiffness_kN_per_m must not exceed loading_stiffness_kN_per_m "
                             "(the gear would make energy)")
        return self


class Notches(Strict):
    """The locomotives' throttle and dynamic-brake notches (the plant's ``notches`` effect): a
    locomotive applies traction notch k of ``traction`` as k / ``traction`` of its traction envelope
    at its speed, and dynamic-brake notch k of ``dynamic_brake`` alike; the controller's request is
    rounded to the nearest notch at each sample."""

    traction: int = Field(gt=0, le=1000, description="Traction notches above idle (North American practice: 8).")
    dynamic_brake: int = Field(gt=0, le=1000, description="Dynamic-brake notches above off (8 on many locomotives).")
    source: str = Field(min_length=1, description="Where the values come from (or that they are typical).")


class ConsistFile(Strict):
    file_kind: ClassVar[str | None] = "consist"
    name: str
    source: str
    types: dict[str, VehicleType] = Field(min_length=1)
    vehicles: list[Group] = Field(min_length=1, max_length=1000)
    couplers: Couplers
    air_brake: Optional[AirBrake] = Field(None, description="Air-brake propagation data (switched on in a study).")
    draft_gear: Optional[DraftGear] = Field(None, description="Draft-gear data (switched on in a study).")
    notches: Optional[Notches] = Field(None, description="Locomotive notch data (switched on in a study).")

    @model_validator(mode="after")
    def _known(self) -> Self:
        unknown = sorted({g.type for g in self.vehicles} - set(self.types))
        if unknown:
            raise ValueError(f"vehicles: unknown types {', '.join(unknown)} (types: {', '.join(self.types)})")
        if sum(g.count for g in self.vehicles) < 2:
            raise ValueError("vehicles: a consist needs at least two vehicles (one coupler)")
        if not any(self.types[g.type].kind == "locomotive" for g in self.vehicles):
            raise ValueError("vehicles: a consist needs a locomotive")
        return self

    def implausible(self) -> list[tuple[str, str]]:
        """(field, problem) of each stiffness a coupling's loading follows (the couplers', the draft
        gear's loading one) outside :data:`PLAUSIBLE_STIFFNESS_KN_PER_M`: a warning, not a refusal."""
        low, high = PLAUSIBLE_STIFFNESS_KN_PER_M
        given = [("couplers.stiffness_kN_per_m", self.couplers.stiffness_kN_per_m)]
        if self.draft_gear is not None:
            given.append(("draft_gear.loading_stiffness_kN_per_m", self.draft_gear.loading_stiffness_kN_per_m))
        return [(field, f"{k:g} kN/m is outside {low:g}-{high:g} kN/m, the range plausible for freight draft gear "
                 f"({STIFFNESS_SOURCES})") for field, k in given if not low <= k <= high]
