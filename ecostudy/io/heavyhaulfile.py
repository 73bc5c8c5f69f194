"""The schema of a heavy-haul study file (``ecostudy heavyhaul``): Zhang & Zhuan's receding-horizon
controller on a consist's cascade plant, swept over the brake penalty K_b, the fence factor f and
the horizons (Np, Nc). Units are in the field names; defaults are Zhang & Zhuan's (Ts = 20 s, K_f = 10,
K_v = 60, K_e = 10)."""
from typing import Annotated, Any, ClassVar, Literal, Optional, Self

from pydantic import Field, field_validator, model_validator

from ecostudy.core.defaults import MAX_SUPPLEMENT_PERCENT
from ecostudy.io.schemabase import Name, Strict


# the Kalman observer's Q = q I, R = r I in SI (m/s, m): Zhang & Zhuan's q = 50, r = 0.01 leave the middle of
# the ore train's estimate 0.8 m/s off after 8 samples; these converge (docs/heavyhaul.md, "The Kalman observer")
OBSERVER_Q, OBSERVER_R = 1e-3, 1e-4
WEIGHT_MAX = 1e4  # K_b, K_f, K_v, K_e: the paper's are 1 to 80; 1e300 made the QP's setup fail (DAQP flag -5)


class ReferenceSpec(Strict):
    """The reference speed v_r: ecostudy's energy-optimal single-mass run for ``running_time_s`` or
    ``supplement_percent`` over the all-out time, or a user's ``table`` (CSV: distance_m, speed_kmh)."""

    running_time_s: Optional[float] = Field(None, gt=0, le=1e6)
    supplement_percent: Optional[float] = Field(None, ge=0, le=MAX_SUPPLEMENT_PERCENT)
    table: Optional[str] = Field(None, description="CSV with columns distance_m, speed_kmh (relative to the study).")
    points: int = Field(500, ge=50, le=20000, description="K of the single-mass NLP.")
    service_deceleration_mps2: float = Field(0.3, gt=0, le=3, description="The single mass brakes at most this "
                                             "hard (a heavy train's service braking, not its brakes' full force).")
    limit_lead_samples: float = Field(1.0, ge=0, le=10, description="The single mass reaches each lower speed limit "
                                      "this many samples (Ts) of running at it before the drop: the controller tracks "
                                      "v_r only at its samples and crosses a drop between two (0: at the drop).")

    @model_validator(mode="after")
    def _one(self) -> Self:
        given = [x is not None for x in (self.running_time_s, self.supplement_percent, self.table)]
        if sum(given) != 1:
            raise ValueError("give exactly one of running_time_s, supplement_percent or table")
        return self


class Horizon(Strict):
    np: int = Field(ge=1, le=100, description="Np, the prediction horizon [samples].")
    nc: int = Field(ge=1, le=100, description="Nc, the control moves (the last is held to Np).")

    @model_validator(mode="after")
    def _order(self) -> Self:
        if self.nc > self.np:
            raise ValueError(f"nc ({self.nc}) must not exceed np ({self.np})")
        return self


class Weights(Strict):
    """K_f, K_v, K_e of Zhang & Zhuan eq. 4 (K_b is swept: ``brake_penalty``)."""

    force: float = Field(10.0, ge=0, le=WEIGHT_MAX, description="K_f, on in-train forces [per kN^2 / 1e4].")
    speed: float = Field(60.0, ge=0, le=WEIGHT_MAX, description="K_v, on speed tracking [per (m/s)^2].")
    energy: float = Field(10.0, ge=0, le=WEIGHT_MAX, description="K_e, on efforts [per kN^2 / 1e4].")

    @model_validator(mode="after")
    def _objective(self) -> Self:
        if self.force == self.speed == self.energy == 0:  # K_b multiplies K_e's wagon term: it adds nothing
            raise ValueError("force, speed and energy are all 0: eq. 4's objective is identically 0 whatever "
                             "brake_penalty is (every input optimal)")
        if self.speed == 0:
            raise ValueError("speed is 0: K_v's tracking term is the only one that moves the train (the others "
                             "cost forces and efforts), so every run would stand to the sample cap")
        return self


class HeavyhaulFile(Strict):
    file_kind: ClassVar[str | None] = "heavy-haul study"
    name: Name
    consist: Name
    track: Name
    from_stop: Optional[str] = Field(None, alias="from")
    to_stop: Optional[str] = Field(None, alias="to")
    reference: ReferenceSpec = ReferenceSpec(supplement_percent=10.0)
    sample_time_s: float = Field(20.0, gt=0, le=600, description="Ts, also the real-time budget of a solve.")
    brake_penalty: list[Annotated[float, Field(ge=0, le=WEIGHT_MAX)]] = Field(
        [40.0], min_length=1, description="K_b values swept (0 to 1e4).")
    fence: list[Annotated[int, Field(ge=1)]] = Field([10], min_length=1, description="Fence factors f swept (1: every car).")
    horizons: list[Horizon] = Field([Horizon(np=4, nc=2)], min_length=1, description="(Np, Nc) pairs swept.")
    fence_coupling: Literal["series", "single"] = Field("series", description="A virtual coupler: the real couplers "
                                                        "between the virtual cars' centres in series (k / spanned) "
                                                        "or one real coupler (k).")
    fence_sharing: Literal["mass", "equal"] = Field("mass", description="A virtual car's effort shared among its "
                                                    "cars in proportion to mass, or equally.")
    fence_weights: Literal["per_car", "virtual"] = Field(
        "per_car", description="A virtual car's terms in the objective: weighted by the cars and couplers it "
        "stands for (the full train's objective, as nearly as virtual cars allow), or each as one car (Zhang & Zhuan's eq. 11 "
        "read literally: grouped wagons' braking then costs about f times more).")
    objective_scale: Literal["paper", "limits"] = Field(
        "paper", description="The units of Zhang & Zhuan's eq. 4 terms: the paper's (forces and efforts in 100 kN, speeds in m/s) "
        "or each by its physical limit (in-train forces by the coupler limit, each car's effort by its largest, "
        "speed errors by the route's highest speed).")
    effort_penalty: Literal["squared", "magnitude"] = Field(
        "squared", description="Zhang & Zhuan's eq. 4 effort term, K_e (sum u^2 over the locomotives + K_b sum u^2 over the "
        "wagons), or eq. 11's as Zhang & Zhuan print it, with each effort's magnitude |u| in its unit (solved by "
        "qp_solver daqp or condensed).")
    brake_penalty_on: Literal["wagons", "all"] = Field(
        "wagons", description="Where K_b applies: the wagons' braking (Zhang & Zhuan's eq. 5, R) or every "
        "brake, the locomotives' dynamic braking too (K_b u^2 for a braking locomotive; a departure from eq. 5: "
        "otherwise the penalty moves the braking to the dynamic brakes for free). 'all' needs effort_penalty "
        "squared, every K_b >= 1 and qp_solver daqp or condensed.")
    adhesion: bool = Field(False, description="Cap each locomotive's traction and dynamic braking at its adhesion, "
                           "mu(v) m g with Curtius & Kniffler's dry-rail mu (the plant; the controller sees the "
                           "capped envelopes).")
    air_brake: bool = Field(False, description="The plant's wagon brakes delayed along the train and lagged "
                            "(the consist's air_brake data; docs/heavyhaul.md, In-train physics).")
    draft_gear: bool = Field(False, description="The plant's couplers with slack and loading/unloading stiffness "
                             "(the consist's draft_gear data); the controller keeps the linear couplers.")
    notches: bool = Field(False, description="The plant's locomotives apply traction and dynamic braking in the "
                          "consist's notches (the request rounded to the nearest); the controller keeps continuous efforts.")
    weights: Weights = Weights()
    rate_kN_per_sample: float = Field(200.0, gt=0, description="Largest change of a locomotive group's effort "
                                      "per sample (Zhang & Zhuan give none).")
    qp_solver: Literal["daqp", "condensed", "clarabel", "ipopt"] = Field(
        "daqp", description="The same QP four ways: condensed to the inputs (force rows as they bind) and solved "
        "by DAQP warm-started from the last sample (fastest) or by Clarabel, with the states kept (Clarabel), "
        "or Ipopt on its Pyomo model.")
    observer: bool = Field(False, description="Feed the controller the Kalman observer's estimate (Zhang & Zhuan, eq. 10).")
    observer_q: float = Field(OBSERVER_Q, gt=0, description="The observer's process noise, Q = q I (SI: m/s and m; "
                              "Zhang & Zhuan give 50, units unstated).")
    observer_r: float = Field(OBSERVER_R, gt=0, description="The observer's measurement noise, R = r I [(m/s)^2] "
                              "(Zhang & Zhuan give 0.01).")
    max_samples: int = Field(1000, ge=1, le=100000, description="Stop a run after this many samples (a run "
                             "that has not arrived by then is flagged).")
    stop_tolerance_m: float = Field(1.0, gt=0, le=100, description="A run that stops farther from the stop (short "
                                    "or beyond) is flagged; at most 100 m (a larger one would call a train that "
                                    "never reached its stop arrived).")
    speed_tolerance_kmh: float = Field(1.0, ge=0, le=50, description="A run in which a car runs faster than the "
                                       "line's limit by more is flagged; at most 50 km/h.")
    arrival_tolerance_percent: float = Field(5.0, ge=0, le=1000, description="A run that arrives later than the "
                                             "reference's running time by more than this share of it and by more "
                                             "than arrival_tolerance_s is flagged.")
    arrival_tolerance_s: float = Field(60.0, ge=0, le=1e6, description="See arrival_tolerance_percent (the larger "
                                       "of the two is the tolerance).")
    output: Optional[str] = None

    def unused(self) -> list[tuple[list[str], str]]:
        """The fields the file gives that its runs do not read, as (fields, why) groups: the observer's
        noises with the observer off; the single-mass optimum's grid and limit lead with a reference
        table (followed as given)."""
        out: list[tuple[list[str], str]] = []
        noises: list[str] = [name for name in ("observer_q", "observer_r") if name in self.model_fields_set]
        if noises and not self.observer:
            out.append((noises, "not used: the observer is off (the controller reads the plant's true state)"))
        optimum = [f"reference.{name}" for name in ("points", "limit_lead_samples")
                   if name in self.reference.model_fields_set]
        if optimum and self.reference.table is not None:
            out.append((optimum, "not used: they shape ecostudy's single-mass optimum; a reference table is "
                                 "followed as given"))
        return out

    @field_validator("brake_penalty", "fence", "horizons")
    @classmethod
    def _once(cls, values: list[Any]) -> list[Any]:
        seen: list[Any] = []
        for v in values:  # a K_b by its 6 significant digits: a run's name, its key and its figures' names
            key = (v.np, v.nc) if isinstance(v, Horizon) else f"{v:g}" if isinstance(v, float) else v
            if key in seen:
                first = values[seen.index(key)]
                raise ValueError(f"{key} is listed twice (each value is one run)" if first == v else
                                 f"{first!r} and {v!r} both read {key} (a run is named and stored by K_b to 6 "
                                 f"significant digits): give values that differ there")
            seen.append(key)
        return values

