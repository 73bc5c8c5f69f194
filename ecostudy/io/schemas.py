"""File schemas: frozen pydantic models that refuse unknown keys. Units are in the field names.

Cross-field rules that concern one file live here as validators; rules that need two files
(a stop missing from the track, a running time below the all-out time) are ``check_*``
functions in :mod:`ecostudy.io.loaders`.
"""
from typing import ClassVar, Literal, Optional

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


def _increasing(values, what):
    if any(b <= a for a, b in zip(values, values[1:])):
        raise ValueError(f"{what} must be strictly increasing")
    return values


class ForceTable(Strict):
    """Speed-force table: linear between points, constant beyond the ends."""

    speed_kmh: list[float] = Field(min_length=2, description="Speeds [km/h], strictly increasing.")
    force_kN: list[float] = Field(min_length=2, description="Maximum force at each speed [kN].")

    @field_validator("speed_kmh")
    @classmethod
    def _speeds(cls, v):
        if v[0] < 0:
            raise ValueError("speeds must be >= 0")
        return _increasing(v, "speeds")

    @field_validator("force_kN")
    @classmethod
    def _forces(cls, v):
        if min(v) < 0:
            raise ValueError("forces must be >= 0")
        return v

    @model_validator(mode="after")
    def _lengths(self):
        if len(self.speed_kmh) != len(self.force_kN):
            raise ValueError("speed_kmh and force_kN must have the same length")
        return self


class Traction(Strict):
    """Traction envelope: a table, or a maximum force with an optional maximum power."""

    table: Optional[ForceTable] = None
    max_force_kN: Optional[float] = Field(None, gt=0)
    max_power_kW: Optional[float] = Field(None, gt=0)

    @model_validator(mode="after")
    def _one_form(self):
        if (self.table is None) == (self.max_force_kN is None):
            raise ValueError("give either 'table' or 'max_force_kN' (with optional 'max_power_kW')")
        if self.table is not None and self.max_power_kW is not None:
            raise ValueError("'max_power_kW' goes with 'max_force_kN', not with 'table'")
        return self


class Braking(Traction):
    """Service braking: a table, a maximum force (and power), or a maximum deceleration."""

    max_deceleration_mps2: Optional[float] = Field(None, gt=0)

    @model_validator(mode="after")
    def _one_form(self):
        forms = [self.table is not None, self.max_force_kN is not None,
                 self.max_deceleration_mps2 is not None]
        if sum(forms) != 1:
            raise ValueError("give one of 'table', 'max_force_kN' or 'max_deceleration_mps2'")
        return self


class Regeneration(Strict):
    """Regenerative (electric) braking limits; braking beyond them goes to friction brakes."""

    max_force_kN: Optional[float] = Field(None, gt=0)
    max_power_kW: Optional[float] = Field(None, gt=0)
    efficiency: float = Field(0.8, gt=0, le=1, description="Wheel to line [-].")


class Davis(Strict):
    """Davis coefficients A + B v + C v^2: exactly one complete triple of one unit system."""

    a_N: Optional[float] = None
    b_N_per_mps: Optional[float] = None
    c_N_per_mps2: Optional[float] = None
    a_kN: Optional[float] = None
    b_kN_per_kmh: Optional[float] = None
    c_kN_per_kmh2: Optional[float] = None
    a_N_per_kg: Optional[float] = None
    b_N_per_kg_per_mps: Optional[float] = None
    c_N_per_kg_per_mps2: Optional[float] = None

    TRIPLES: ClassVar[tuple] = (("a_N", "b_N_per_mps", "c_N_per_mps2"),
               ("a_kN", "b_kN_per_kmh", "c_kN_per_kmh2"),
               ("a_N_per_kg", "b_N_per_kg_per_mps", "c_N_per_kg_per_mps2"))

    @model_validator(mode="after")
    def _one_triple(self):
        given = [t for t in self.TRIPLES if any(getattr(self, f) is not None for f in t)]
        if len(given) != 1 or any(getattr(self, f) is None for f in given[0]):
            raise ValueError("give one complete triple: " + " | ".join("/".join(t) for t in self.TRIPLES))
        for f in given[0]:
            if getattr(self, f) < 0:
                raise ValueError(f"{f} must be >= 0")
        return self


class TrainFile(Strict):
    name: str
    source: str = Field(description="Where the numbers come from.")
    mass_t: float = Field(gt=0, description="Static mass Ms [t].")
    rotating_mass_factor: Optional[float] = Field(None, ge=0, description="M = Ms (1 + factor).")
    effective_mass_t: Optional[float] = Field(None, gt=0, description="Effective mass M [t].")
    length_m: float = Field(ge=0, description="Train length [m]; 0 for a point mass.")
    davis: Davis
    traction: Traction
    braking: Braking
    traction_efficiency: float = Field(1.0, gt=0, le=1, description="Wheel work per line energy [-].")
    regenerative_braking: Optional[Regeneration] = None
    curve_coefficient_m2ps2: float = Field(0.0, ge=0, description="lambda_t of thesis 000 eq. 2.2.")
    max_speed_kmh: Optional[float] = Field(None, gt=0, description="The train's top speed: caps every limit.")
    max_acceleration_mps2: Optional[float] = Field(None, gt=0, description="Bound on the net acceleration.")
    max_deceleration_mps2: Optional[float] = Field(None, gt=0, description="Bound on the net deceleration "
                                                   "(on top of the braking forces; not the brake itself).")
    das_handle_levels: list[float] = Field(default_factory=lambda: [-1.0, 0.0, 0.5, 0.75, 1.0])

    @model_validator(mode="after")
    def _mass(self):
        if (self.rotating_mass_factor is None) == (self.effective_mass_t is None):
            raise ValueError("give either 'rotating_mass_factor' or 'effective_mass_t'")
        if self.effective_mass_t is not None and self.effective_mass_t < self.mass_t:
            raise ValueError("effective_mass_t must be >= mass_t (static mass)")
        return self

    @field_validator("das_handle_levels")
    @classmethod
    def _levels(cls, v):
        if any(x < -1 or x > 1 for x in v):
            raise ValueError("handle levels must lie in [-1, 1]")
        return sorted(v)


class Stop(Strict):
    name: str
    position_m: float = Field(ge=0)


class Gradient(Strict):
    position_m: float = Field(ge=0, description="Start of the gradient section [m].")
    gradient_permille: float = Field(ge=-100, le=100, description="Positive uphill [per mille].")


class Curve(Strict):
    position_m: float = Field(ge=0)
    radius_m: Optional[float] = Field(None, gt=0, description="Radius [m]; null for straight track.")


class SpeedLimit(Strict):
    position_m: float = Field(ge=0)
    speed_kmh: float = Field(gt=0)


class TrackFile(Strict):
    name: str
    source: str
    length_m: float = Field(gt=0)
    stops: list[Stop] = Field(min_length=2)
    gradients: list[Gradient] = Field(default_factory=lambda: [Gradient(position_m=0, gradient_permille=0)])
    curves: list[Curve] = Field(default_factory=list)
    speed_limits: list[SpeedLimit] = Field(min_length=1)

    @model_validator(mode="after")
    def _positions(self):
        for name in ("stops", "gradients", "curves", "speed_limits"):
            items = getattr(self, name)
            _increasing([x.position_m for x in items], f"{name} positions")
            if items and items[-1].position_m > self.length_m:
                raise ValueError(f"{name}: position {items[-1].position_m} m is beyond length_m")
        for name in ("gradients", "speed_limits"):
            if getattr(self, name)[0].position_m != 0:
                raise ValueError(f"{name}: the first entry must start at position_m 0")
        names = [s.name for s in self.stops]
        if len(set(names)) != len(names):
            raise ValueError("stop names must be unique")
        return self


class Window(Strict):
    """A timing point on the way: pass ``position_m`` (track position) within the bounds given."""

    position_m: float = Field(ge=0)
    earliest_s: Optional[float] = Field(None, ge=0, description="Since departure [s].")
    latest_s: Optional[float] = Field(None, ge=0)
    min_speed_kmh: Optional[float] = Field(None, ge=0)
    max_speed_kmh: Optional[float] = Field(None, gt=0)

    @model_validator(mode="after")
    def _order(self):
        if self.earliest_s is not None and self.latest_s is not None and self.earliest_s > self.latest_s:
            raise ValueError("earliest_s must not exceed latest_s")
        if all(x is None for x in (self.earliest_s, self.latest_s, self.min_speed_kmh, self.max_speed_kmh)):
            raise ValueError("give at least one of earliest_s, latest_s, min_speed_kmh, max_speed_kmh")
        return self


class TimetableStop(Strict):
    """A stop of the timetable, by name or by track position; times since the journey's start."""

    stop: Optional[str] = None
    position_m: Optional[float] = Field(None, ge=0, description="Instead of 'stop': the stop at this position.")
    arrival_s: Optional[float] = Field(None, ge=0)
    departure_s: Optional[float] = Field(None, ge=0)
    dwell_s: Optional[float] = Field(None, ge=0)
    earliest_s: Optional[float] = Field(None, ge=0, description="Arrival window: not before [s].")
    latest_s: Optional[float] = Field(None, ge=0, description="Arrival window: not after [s].")

    @model_validator(mode="after")
    def _named(self):
        if (self.stop is None) == (self.position_m is None):
            raise ValueError("give either 'stop' (a name) or 'position_m'")
        if self.earliest_s is not None and self.latest_s is not None and self.earliest_s > self.latest_s:
            raise ValueError("earliest_s must not exceed latest_s")
        if self.arrival_s is not None and (self.earliest_s is not None or self.latest_s is not None):
            raise ValueError("give either 'arrival_s' or an arrival window (earliest_s/latest_s)")
        return self


class TimetableFile(Strict):
    """Stop times (fixed, or arrival windows) and timing points on the way, or one supplement.

    Windows here are passing points between the stops with times since the journey's start
    (the TTOBench journey format, imported by ``ecostudy.imports``)."""

    name: str
    source: str = ""
    stops: list[TimetableStop] = Field(default_factory=list)
    supplement_percent: Optional[float] = Field(None, ge=0)
    windows: list[Window] = Field(default_factory=list)

    @model_validator(mode="after")
    def _one_form(self):
        if bool(self.stops) == (self.supplement_percent is not None):
            raise ValueError("give either 'stops' with times or 'supplement_percent'")
        if self.windows and not self.stops:
            raise ValueError("windows need 'stops'")
        return self

    @property
    def windowed(self):
        """Whether any time is a window rather than a fixed time (solved as one journey NLP)."""
        return bool(self.windows) or any(s.earliest_s is not None or s.latest_s is not None for s in self.stops)


class Weights(Strict):
    time: float = Field(1.0, ge=0, description="w_t [1/s] (thesis 001 eq. 4.1a).")
    energy: float = Field(1.0, ge=0, description="w_e [kg/J], on traction energy per unit mass.")


class Scenario(Strict):
    """A named variant of the base case: other files, train fields overridden, other timing."""

    name: str
    train: Optional[str] = None
    track: Optional[str] = None
    train_overrides: dict[str, object] = Field(default_factory=dict,
                                               description="Top-level train fields, e.g. mass_t.")
    running_time_s: Optional[float] = Field(None, gt=0)
    supplement_percent: Optional[float] = Field(None, ge=0)
    objective: Optional[Literal["energy", "net_energy", "time", "mixed"]] = None
    points: Optional[int] = Field(None, ge=10, le=100000)
    das: Optional[Literal["round", "phases", "minlp"]] = Field(
        None, description="Also a DAS run of every case of this scenario (thesis 000 §3.1.2, Ch. 5).")


class Sweep(Strict):
    """Values to combine (cartesian product) with every scenario."""

    running_time_s: Optional[list[float]] = None
    supplement_percent: Optional[list[float]] = None
    points: Optional[list[int]] = None
    objective: Optional[list[Literal["energy", "net_energy", "time", "mixed"]]] = None

    @model_validator(mode="after")
    def _timing(self):
        if self.running_time_s is not None and self.supplement_percent is not None:
            raise ValueError("sweep either running_time_s or supplement_percent, not both")
        return self


class StudyFile(Strict):
    name: str
    track: str
    train: str
    timetable: Optional[str] = None
    from_stop: Optional[str] = Field(None, alias="from")
    to_stop: Optional[str] = Field(None, alias="to")
    running_time_s: Optional[float] = Field(None, gt=0)
    supplement_percent: Optional[float] = Field(None, ge=0)
    window_s: Optional[tuple[float, float]] = None
    objective: Literal["energy", "net_energy", "time", "mixed"] = "energy"
    weights: Weights = Weights()
    points: int = Field(1000, ge=10, le=100000)
    das: Optional[Literal["round", "phases", "minlp"]] = Field(
        None, description="Also a DAS run of every energy-optimal case: das_ columns in results.csv.")
    das_time_limit_s: float = Field(60.0, gt=0, description="Time limit of each MINLP search (das: minlp).")
    output: Optional[str] = None
    windows: list[Window] = Field(default_factory=list, description="Timing points between the stops.")
    scenarios: list[Scenario] = Field(default_factory=list, description="Variants run by `ecostudy run`.")
    sweep: Optional[Sweep] = None

    @model_validator(mode="after")
    def _timing(self):
        names = [sc.name for sc in self.scenarios]
        if len(set(names)) != len(names):
            raise ValueError("scenario names must be unique")
        given = [self.running_time_s is not None, self.supplement_percent is not None,
                 self.window_s is not None, self.timetable is not None]
        if sum(given) > 1:
            raise ValueError("give at most one of running_time_s, supplement_percent, window_s, timetable")
        if self.window_s is not None and not 0 <= self.window_s[0] <= self.window_s[1]:
            raise ValueError("window_s must be [earliest, latest] with 0 <= earliest <= latest")
        return self


class Substation(Strict):
    """One DC substation and its line (thesis 000 §7.2.1, eq. 7.8)."""

    position_m: float = Field(description="Line position of the substation [m].")
    voltage_V: float = Field(750.0, gt=0, description="Source voltage V_s.")
    internal_resistance_ohm: float = Field(0.01, gt=0, description="R_s.")
    line_resistance_ohm_per_km: float = Field(0.025, ge=0, description="Thesis 000: 25 mOhm/km.")
    max_voltage_V: Optional[float] = Field(None, gt=0, description="Regeneration cut-off; default V_s 685/600.")
    min_voltage_V: Optional[float] = Field(None, gt=0, description="Lowest pantograph voltage; default 2/3 V_s.")
    max_train_current_A: Optional[float] = Field(None, gt=0, description="Largest current a train draws "
                                                 "(thesis 000 Fig. 7.7); default none.")
    max_regen_current_A: Optional[float] = Field(None, gt=0, description="Largest current a train feeds "
                                                 "back (thesis 000 Fig. 7.7); default none.")

    @model_validator(mode="after")
    def _voltages(self):
        hi = self.max_voltage_V if self.max_voltage_V is not None else self.voltage_V * 685 / 600
        lo = self.min_voltage_V if self.min_voltage_V is not None else self.voltage_V * 2 / 3
        if not lo < self.voltage_V < hi:
            raise ValueError("need min_voltage_V < voltage_V < max_voltage_V")
        return self


class FleetTrain(Strict):
    name: str
    offset_s: float = Field(ge=0, description="Departure from the first stop after the first train [s].")


STRATEGIES = ("independent", "receptivity", "triggering", "voltage", "dissension", "joint", "following")


class NetworkStudyFile(Strict):
    """Several trains on one line and one substation: `ecostudy network STUDY.yaml`."""

    name: str
    track: str
    train: str
    stops: Optional[list[str]] = Field(None, description="Stops served, in order (default: all).")
    running_times_s: Optional[list[float]] = Field(None, description="Per segment [s].")
    supplement_percent: Optional[float] = Field(None, ge=0, description="Per segment, over its all-out time.")
    dwell_s: float = Field(20.0, ge=0)
    time_step_s: float = Field(0.5, gt=0, le=5)
    trains: list[FleetTrain] = Field(min_length=1)
    substation: Substation
    strategies: list[Literal[STRATEGIES]] = Field(default_factory=lambda: list(STRATEGIES))
    buffer_m: Optional[float] = Field(None, gt=0, description="Separation kept by `following` (thesis 001 eq. 6.9).")
    points: int = Field(500, ge=10, le=100000, description="Space grid of the per-segment starting runs.")
    output: Optional[str] = None

    @model_validator(mode="after")
    def _choices(self):
        if (self.running_times_s is None) == (self.supplement_percent is None):
            raise ValueError("give exactly one of running_times_s, supplement_percent")
        if "following" in self.strategies and self.buffer_m is None:
            raise ValueError("the following strategy needs buffer_m")
        names = [t.name for t in self.trains]
        if len(set(names)) != len(names):
            raise ValueError("train names must be unique")
        return self
