"""The train file's schema (units in the field names); see :mod:`ecostudy.io.schemas`."""
from typing import ClassVar, Literal, Optional, Self

from pydantic import Field, field_validator, model_validator

from ecostudy.core import units
from ecostudy.core.budget import duration, is_forced
from ecostudy.io.schemabase import Name, Strict, increasing as _increasing

MAX_TABLE_POINTS = 5000
# solve time per table point and grid node: the Amsterdam metro with its traction table resampled
# to 500 and 2000 points took 11.6 s and 36.0 s at K = 300 (8 points: 2.6 s), on a shared machine
SECONDS_PER_POINT_NODE = 6e-5
MAX_ACCELERATION = 10.0  # [m/s^2] about 1 g: wheels on rails transmit a third of it; more is a unit slip
MIN_DECELERATION = 0.1  # [m/s^2] a net bound below it leaves a train that cannot stop, not one that brakes gently
MASS_RANGE_T = (1.0, 100000.0)  # [t] a static mass outside it is a unit slip (kg given as t, or t as kg)
MAX_ROTATING_SHARE = 1.0  # [-] the rotating masses add at most the static mass (M <= 2 Ms)
MAX_CURVE_COEFFICIENT = 100.0  # [m^2/s^2] lambda_t: 600 m g / 1000 (the usual 600 / r in N/kN) is 5.9


class ForceTable(Strict):
    """Speed-force table: linear between points, constant beyond the ends."""

    speed_kmh: list[float] = Field(min_length=2, description="Speeds [km/h], strictly increasing.")
    force_kN: list[float] = Field(min_length=2, description="Maximum force at each speed [kN].")

    @field_validator("speed_kmh")
    @classmethod
    def _speeds(cls, v: list[float]) -> list[float]:
        if v[0] < 0 or v[-1] > 1000:
            raise ValueError("speeds must lie in [0, 1000] km/h")
        if len(v) > MAX_TABLE_POINTS and not is_forced():
            raise ValueError(f"a table of {len(v):,} points: every point is a term of the force at every grid node, "
                             f"an estimated {duration(SECONDS_PER_POINT_NODE * len(v) * 1000)} to solve at K = 1000; "
                             f"thin it to at most {MAX_TABLE_POINTS:,} points, or give --force to run it anyway")
        return _increasing(v, "speeds")

    @field_validator("force_kN")
    @classmethod
    def _forces(cls, v: list[float]) -> list[float]:
        if min(v) < 0 or max(v) > 100000:
            raise ValueError("forces must lie in [0, 100000] kN")
        if max(v) <= 0:  # a table of no force: no train moves (or stops) on it
            raise ValueError("every force is 0 kN: a table that gives no force at any speed")
        return v

    @model_validator(mode="after")
    def _lengths(self) -> Self:
        if len(self.speed_kmh) != len(self.force_kN):
            raise ValueError("speed_kmh and force_kN must have the same length")
        return self


class EfficiencyTable(Strict):
    """Efficiency over speed and force (bilinear, constant beyond the table): one row per speed."""

    speed_kmh: list[float] = Field(min_length=2, description="Speeds [km/h], strictly increasing.")
    force_kN: list[float] = Field(min_length=2, description="Forces [kN] at the wheel, strictly increasing.")
    efficiency: list[list[float]] = Field(description="Wheel to line (traction) or line to wheel share [-], "
                                          "one row per speed, one value per force.")

    @model_validator(mode="after")
    def _shape(self) -> Self:
        _increasing(self.speed_kmh, "speed_kmh")
        _increasing(self.force_kN, "force_kN")
        if min(self.speed_kmh) < 0 or min(self.force_kN) < 0:
            raise ValueError("speeds and forces must be >= 0")
        if len(self.efficiency) != len(self.speed_kmh) or any(len(r) != len(self.force_kN) for r in self.efficiency):
            raise ValueError("efficiency needs one row per speed with one value per force")
        if any(not 0.05 <= x <= 1 for r in self.efficiency for x in r):
            raise ValueError("efficiencies must lie in [0.05, 1] (a share, not per cent)")
        return self


class Traction(Strict):
    """Traction envelope: a table, or a maximum force with an optional maximum power."""

    table: Optional[ForceTable] = None
    max_force_kN: Optional[float] = Field(None, gt=0, le=100000)
    max_power_kW: Optional[float] = Field(None, gt=0)

    @model_validator(mode="after")
    def _one_form(self) -> Self:
        if (self.table is None) == (self.max_force_kN is None):
            raise ValueError("give either 'table' or 'max_force_kN' (with optional 'max_power_kW')")
        if self.table is not None and self.max_power_kW is not None:
            raise ValueError("'max_power_kW' goes with 'max_force_kN', not with 'table'")
        return self


class Braking(Traction):
    """Service braking: a table, a maximum force (and power), or a maximum deceleration."""

    max_deceleration_mps2: Optional[float] = Field(
        None, gt=0, le=MAX_ACCELERATION, description="A braking force of the effective mass times this [N], "
        "not a deceleration: resistance adds to it, a descent takes from it (the train's own "
        "max_deceleration_mps2 bounds the net deceleration).")

    @model_validator(mode="after")
    def _one_form(self) -> Self:
        forms = [self.table is not None, self.max_force_kN is not None,
                 self.max_deceleration_mps2 is not None]
        if sum(forms) != 1:
            raise ValueError("give one of 'table', 'max_force_kN' or 'max_deceleration_mps2'")
        return self


class Regeneration(Strict):
    """Regenerative (electric) braking limits; braking beyond them goes to friction brakes."""

    max_force_kN: Optional[float] = Field(None, gt=0, le=100000)
    max_power_kW: Optional[float] = Field(None, gt=0)
    efficiency: float = Field(0.8, ge=0.05, le=1, description="Wheel to line [-], a share (0.8), not per cent.")
    efficiency_map: Optional[EfficiencyTable] = Field(None, description="Efficiency over speed and force "
                                                      "instead of the constant (net energy and its check).")


class Davis(Strict):
    """Davis coefficients A + B v + C v^2: exactly one complete triple of one unit system."""

    a_N: Optional[float] = Field(None, ge=0)
    b_N_per_mps: Optional[float] = Field(None, ge=0)
    c_N_per_mps2: Optional[float] = Field(None, ge=0)
    a_kN: Optional[float] = Field(None, ge=0)
    b_kN_per_kmh: Optional[float] = Field(None, ge=0)
    c_kN_per_kmh2: Optional[float] = Field(None, ge=0)
    a_N_per_kg: Optional[float] = Field(None, ge=0)
    b_N_per_kg_per_mps: Optional[float] = Field(None, ge=0)
    c_N_per_kg_per_mps2: Optional[float] = Field(None, ge=0)

    TRIPLES: ClassVar[tuple[tuple[str, str, str], ...]] = (("a_N", "b_N_per_mps", "c_N_per_mps2"),
               ("a_kN", "b_kN_per_kmh", "c_kN_per_kmh2"),
               ("a_N_per_kg", "b_N_per_kg_per_mps", "c_N_per_kg_per_mps2"))

    @model_validator(mode="after")
    def _one_triple(self) -> Self:
        given = [t for t in self.TRIPLES if any(getattr(self, f) is not None for f in t)]
        if len(given) != 1 or any(getattr(self, f) is None for f in given[0]):
            raise ValueError("give one complete triple: " + " | ".join("/".join(t) for t in self.TRIPLES))
        return self


class TunnelResistance(Strict):
    """Extra quadratic resistance in a tunnel of the given cross section (TTOBench ``tunnel resistance``)."""

    cross_section_m2: float = Field(gt=0)
    c_kN_per_kmh2: float = Field(ge=0)


class AdhesionLimit(Strict):
    """What the driven wheels transmit: mu(v) m_adh g caps traction and electric braking."""

    adhesive_mass_t: float = Field(gt=0, description="Mass on the driven (motored) axles [t], at most mass_t.")
    law: Literal["curtius_kniffler", "constant"] = Field(
        "curtius_kniffler", description="mu over speed: 'curtius_kniffler' (dry rail, mu = 0.161 + 7.5 / (v + 44), "
        "v in km/h) or 'constant' (mu).")
    mu: Optional[float] = Field(None, gt=0, le=1, description="Adhesion coefficient [-] of law 'constant'.")

    @model_validator(mode="after")
    def _law(self) -> Self:
        if self.law == "constant" and self.mu is None:
            raise ValueError("law 'constant' needs mu (the adhesion coefficient, e.g. 0.3)")
        if self.law != "constant" and self.mu is not None:
            raise ValueError(f"mu goes with law 'constant'; law '{self.law}' gives mu over speed itself")
        return self


class Calibration(Strict):
    """What ``ecostudy calibrate`` found when it wrote this file: every run of a train whose
    calibration was not ok is flagged with the reason (:func:`ecostudy.core.status.calibrated`)."""

    status: Literal["ok", "flagged"] = Field(description="The calibration's status: ok or flagged.")
    reason: str = Field("", description="Why it was flagged (each reason of the calibration); none when ok.")

    @model_validator(mode="after")
    def _reason(self) -> Self:
        if self.status == "flagged" and not self.reason.strip():
            raise ValueError("reason: a flagged calibration needs its reason")
        if self.status == "ok" and self.reason.strip():
            raise ValueError("reason: an ok calibration has none (status ok with a reason: which is it?)")
        return self


class TrainFile(Strict):
    file_kind: ClassVar[str | None] = "train"
    name: Name
    source: str = Field(description="Where the numbers come from.")
    mass_t: float = Field(ge=MASS_RANGE_T[0], le=MASS_RANGE_T[1], description="Static mass Ms [t] (1 t to 100 000 t).")
    rotating_mass_factor: Optional[float] = Field(None, ge=0, le=MAX_ROTATING_SHARE, description="M = Ms (1 + "
                                                  "factor), at most 1 (a share: 0.06, not 1.06 or per cent).")
    effective_mass_t: Optional[float] = Field(None, gt=0, description="Effective mass M [t], mass_t to twice it.")
    length_m: float = Field(ge=0, description="Train length [m]; 0 for a point mass.")
    davis: Davis
    traction: Traction
    braking: Braking
    traction_efficiency: float = Field(1.0, ge=0.05, le=1, description="Wheel work per line energy [-], a share "
                                       "(0.85), not per cent.")
    traction_efficiency_map: Optional[EfficiencyTable] = Field(
        None, description="Efficiency over speed and force instead of the constant (net energy and its check; "
        "formulations that cannot use it keep traction_efficiency and say so).")
    regenerative_braking: Optional[Regeneration] = None
    curve_coefficient_m2ps2: float = Field(0.0, ge=0, le=MAX_CURVE_COEFFICIENT,
                                           description="lambda_t of Farooqi 2018 eq. 2.2 (about 6).")
    curve_resistance: Literal["coefficient", "roeckl"] = Field(
        "coefficient", description="'coefficient': Ms lambda_t / r (Farooqi 2018 eq. 2.2); 'roeckl': Roeckl's "
        "formula, as ms-eetc (TTOBench's reference implementation) uses it.")
    tunnel_resistance: list[TunnelResistance] = Field(default_factory=list)
    max_speed_kmh: Optional[float] = Field(None, gt=0, le=1000, description="The train's top speed: caps every limit.")
    max_acceleration_mps2: Optional[float] = Field(None, gt=0, le=MAX_ACCELERATION,
                                                   description="Bound on the net acceleration.")
    max_deceleration_mps2: Optional[float] = Field(None, ge=MIN_DECELERATION, le=MAX_ACCELERATION,
                                                   description="Bound on the net deceleration "
                                                   "(on top of the braking forces; not the brake itself).")
    das_handle_levels: list[float] = Field(default_factory=lambda: [-1.0, 0.0, 0.5, 0.75, 1.0])
    adhesion: Optional[AdhesionLimit] = Field(None, description="Caps the traction envelope and the electric "
                                              "brake at mu(v) m_adh g; none: no adhesion limit.")
    calibration: Optional[Calibration] = Field(None, description="Written by ecostudy calibrate: its status, "
                                               "and the reason where it was flagged (every run of the train then is).")

    @model_validator(mode="after")
    def _adhesive_mass(self) -> Self:
        if self.adhesion is not None and self.adhesion.adhesive_mass_t > self.mass_t:
            raise ValueError(f"adhesion.adhesive_mass_t: {self.adhesion.adhesive_mass_t:g} t exceeds mass_t "
                             f"({self.mass_t:g} t): the driven axles carry at most the whole train")
        return self

    @model_validator(mode="after")
    def _curves_and_tunnels(self) -> Self:
        if self.curve_resistance == "roeckl" and self.curve_coefficient_m2ps2:
            raise ValueError("curve_coefficient_m2ps2: goes with curve_resistance 'coefficient', not 'roeckl'")
        for i, (a, b) in enumerate(zip(self.tunnel_resistance, self.tunnel_resistance[1:]), start=1):
            if b.cross_section_m2 <= a.cross_section_m2:
                raise ValueError(f"tunnel_resistance[{i}].cross_section_m2: {b.cross_section_m2:g} m^2 does not follow "
                                 f"tunnel_resistance[{i - 1}]'s {a.cross_section_m2:g} m^2 (cross sections strictly "
                                 "increasing)")
        return self

    @model_validator(mode="after")
    def _mass(self) -> Self:
        if (self.rotating_mass_factor is None) == (self.effective_mass_t is None):
            field = "effective_mass_t" if self.effective_mass_t is not None else "rotating_mass_factor"
            raise ValueError(f"{field}: give either 'rotating_mass_factor' or 'effective_mass_t'")
        if self.effective_mass_t is not None and not self.mass_t <= self.effective_mass_t <= 2 * self.mass_t:
            raise ValueError(f"effective_mass_t: {self.effective_mass_t:g} t must lie between mass_t and twice it "
                             f"({self.mass_t:g} to {2 * self.mass_t:g} t): the rotating masses add a share of the "
                             "static mass")
        return self

    @field_validator("das_handle_levels")
    @classmethod
    def _levels(cls, v: list[float]) -> list[float]:
        if any(x < -1 or x > 1 for x in v):
            raise ValueError("handle levels must lie in [-1, 1]")
        if len(set(v)) != len(v):
            raise ValueError("handle levels must differ")
        if not v or min(v) >= 0 or max(v) <= 0:
            raise ValueError("need a braking level (< 0) and a traction level (> 0): advice cannot stop or start "
                             "otherwise")
        return sorted(v)


def mass_out_of_range(mass_kg: float) -> str | None:
    """Why a static mass read from a published file (in kg) is outside :data:`MASS_RANGE_T`, said in
    kg and t (the file's kg against the schema's tonnes), else None."""
    low, high = MASS_RANGE_T
    if low * units.TONNE <= mass_kg <= high * units.TONNE:
        return None
    return f"expected {low * units.TONNE:g} to {high * units.TONNE:g} kg ({low:g} to {high:g} t), got {mass_kg:g} kg"
