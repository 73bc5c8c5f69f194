"""File schemas: frozen pydantic models that refuse unknown keys. Units are in the field names.

Cross-field rules that concern one file live here as validators; rules that need two files
(a stop missing from the track, a running time below the all-out time) are ``check_*``
functions in :mod:`ecostudy.io.loaders`.
"""
import math
from typing import Annotated, ClassVar, Literal, Optional, Self, get_args

from pydantic import Field, model_validator

from ecostudy.core.defaults import DAS_TIME_LIMIT_S, FRONT_POINTS, MAX_SUPPLEMENT_PERCENT, RUN_POINTS
from ecostudy.io.schemabase import Name as Name, Strict as Strict, unique as _unique
from ecostudy.io.trainschema import (  # re-exported (X as X): schemas is the one place to look
    Braking as Braking, Davis as Davis, EfficiencyTable as EfficiencyTable, ForceTable as ForceTable,
    Regeneration as Regeneration, Traction as Traction, TrainFile as TrainFile, TunnelResistance as TunnelResistance)



class Stop(Strict):
    name: Name
    position_m: float = Field(ge=0)


class Gradient(Strict):
    position_m: float = Field(ge=0, description="Start of the gradient section [m].")
    gradient_permille: float = Field(ge=-100, le=100, description="Positive uphill [per mille].")


class Curve(Strict):
    """A curve section from ``position_m`` to the next; a clothoid when ``end_radius_m`` differs."""

    position_m: float = Field(ge=0)
    radius_m: Optional[float] = Field(None, description="Radius [m] at the start, signed by direction "
                                      "(TTOBench: positive right, negative left); null for straight track.")
    end_radius_m: Optional[float] = Field(None, allow_inf_nan=True, description="Radius [m] at the end of a "
                                          "clothoid (curvature linear in distance between the two; .inf: ends "
                                          "straight); omitted: constant radius.")

    @model_validator(mode="after")
    def _radii(self) -> Self:
        for name in ("radius_m", "end_radius_m"):
            r = getattr(self, name)
            if r is not None and (math.isnan(r) or abs(r) < 10):
                raise ValueError(f"{name} must be at least 10 m in size (null or .inf for straight track)")
        return self

    def curvatures(self) -> tuple[float, float]:
        """(curvature at the start, at the end) [1/m], signed."""
        start = 0.0 if self.radius_m is None else 1.0 / self.radius_m
        return start, start if self.end_radius_m is None else 1.0 / self.end_radius_m


class Tunnel(Strict):
    position_m: float = Field(ge=0, description="Start of the tunnel [m].")
    length_m: float = Field(gt=0)
    cross_section_m2: float = Field(gt=0)


class SpeedLimit(Strict):
    position_m: float = Field(ge=0)
    speed_kmh: float = Field(gt=0, le=1000, description="Speed limit [km/h], at most 1000.")


MAX_ROWS = 20_000  # sections of one profile: a 2000 km line at 100 m; more is a runaway, not a track


class TrackFile(Strict):
    file_kind: ClassVar[str | None] = "track"
    name: Name
    source: str
    length_m: float = Field(gt=0, le=2_000_000, description="Track length [m], at most 2000 km.")
    stops: list[Stop] = Field(min_length=2, max_length=MAX_ROWS)
    gradients: list[Gradient] = Field(default_factory=lambda: [Gradient(position_m=0, gradient_permille=0)],
                                      min_length=1, max_length=MAX_ROWS)
    curves: list[Curve] = Field(default_factory=list, max_length=MAX_ROWS)
    speed_limits: list[SpeedLimit] = Field(min_length=1, max_length=MAX_ROWS)
    tunnels: list[Tunnel] = Field(default_factory=list, max_length=MAX_ROWS)

    @model_validator(mode="after")
    def _positions(self) -> Self:
        for name in ("stops", "gradients", "curves", "speed_limits"):
            items = getattr(self, name)
            for i, (a, b) in enumerate(zip(items, items[1:]), start=1):
                if b.position_m <= a.position_m:
                    raise ValueError(f"{name}[{i}].position_m: {b.position_m:g} m does not follow {name}[{i - 1}]'s "
                                     f"{a.position_m:g} m (positions must be strictly increasing)")
            if items and items[-1].position_m > self.length_m:
                raise ValueError(f"{name}: position {items[-1].position_m} m is beyond length_m")
        for name in ("gradients", "speed_limits"):
            if getattr(self, name)[0].position_m != 0:
                raise ValueError(f"{name}[0].position_m: the first entry must start at 0 m, not at "
                                 f"{getattr(self, name)[0].position_m:g} m")
        for i, (a, b) in enumerate(zip(self.tunnels, self.tunnels[1:])):
            if b.position_m < a.position_m + a.length_m - 1e-9:
                where = "before" if b.position_m < a.position_m else "inside"
                raise ValueError(f"tunnels[{i + 1}].position_m: {b.position_m:g} m is {where} tunnels[{i}] ({a.position_m:g} "
                                 f"to {a.position_m + a.length_m:g} m): tunnels go along the line, one after another")
        if self.tunnels and self.tunnels[-1].position_m + self.tunnels[-1].length_m > self.length_m + 1e-6:
            raise ValueError("tunnels: the last tunnel ends beyond length_m")
        _unique("stops", [s.name for s in self.stops])
        return self


class Window(Strict):
    """A timing point on the way: pass ``position_m`` (track position) within the bounds given."""

    position_m: float = Field(ge=0)
    earliest_s: Optional[float] = Field(None, ge=0, description="Since departure [s].")
    latest_s: Optional[float] = Field(None, ge=0)
    min_speed_kmh: Optional[float] = Field(None, ge=0)
    max_speed_kmh: Optional[float] = Field(None, gt=0)

    @model_validator(mode="after")
    def _order(self) -> Self:
        if self.earliest_s is not None and self.latest_s is not None and self.earliest_s > self.latest_s:
            raise ValueError("earliest_s must not exceed latest_s")
        if all(x is None for x in (self.earliest_s, self.latest_s, self.min_speed_kmh, self.max_speed_kmh)):
            raise ValueError("give at least one of earliest_s, latest_s, min_speed_kmh, max_speed_kmh")
        return self


WEEK_S = 7 * 86400.0
Clock = Annotated[Optional[float], Field(None, ge=0, le=WEEK_S)]
"""A time on a journey's clock [s]: 0 at the first departure, within a week."""


class TimetableStop(Strict):
    """A stop of the timetable, by name or by track position; times since the journey's start."""

    stop: Optional[Name] = None
    position_m: Optional[float] = Field(None, ge=0, description="Instead of 'stop': the stop at this position.")
    arrival_s: Clock = None
    departure_s: Clock = None
    dwell_s: Optional[float] = Field(None, ge=0, le=86400, description="Dwell [s], within a day.")
    earliest_s: Clock = Field(None, description="Arrival window: not before [s].")
    latest_s: Clock = Field(None, description="Arrival window: not after [s].")
    departure_earliest_s: Clock = Field(None, description="Departure window: not before [s].")
    departure_latest_s: Clock = Field(None, description="Departure window: not after [s].")

    @model_validator(mode="after")
    def _named(self) -> Self:
        if (self.stop is None) == (self.position_m is None):
            raise ValueError("give either 'stop' (a name) or 'position_m'")
        if self.arrival_s is not None and self.departure_s is not None and self.departure_s < self.arrival_s:
            raise ValueError(f"departure_s: {self.departure_s:g} s is before this stop's arrival_s "
                             f"({self.arrival_s:g} s)")
        if (self.arrival_s is not None and self.departure_s is not None and self.dwell_s is not None
                and self.departure_s < self.arrival_s + self.dwell_s):
            raise ValueError(f"departure_s: {self.departure_s:g} s leaves {self.departure_s - self.arrival_s:g} s "
                             f"after arrival_s ({self.arrival_s:g} s), less than dwell_s ({self.dwell_s:g} s)")
        lo, hi = self.departure_earliest_s, self.departure_latest_s
        if self.departure_s is not None and (lo is not None or hi is not None):
            raise ValueError("give either 'departure_s' or a departure window (departure_earliest_s/_latest_s)")
        if lo is not None and hi is not None and lo > hi:
            raise ValueError("departure_earliest_s must not exceed departure_latest_s")
        if self.earliest_s is not None and self.latest_s is not None and self.earliest_s > self.latest_s:
            raise ValueError("earliest_s must not exceed latest_s")
        if self.arrival_s is not None and (self.earliest_s is not None or self.latest_s is not None):
            raise ValueError("give either 'arrival_s' or an arrival window (earliest_s/latest_s)")
        return self


class TimetableFile(Strict):
    """Stop times (fixed, or arrival windows) and timing points on the way, or one supplement.

    Windows here are passing points between the stops with times since the journey's start
    (the TTOBench journey format, imported by ``ecostudy.imports``)."""
    file_kind: ClassVar[str | None] = "timetable"

    name: Name
    source: str = ""
    stops: list[TimetableStop] = Field(default_factory=list)
    supplement_percent: Optional[float] = Field(None, ge=0, le=MAX_SUPPLEMENT_PERCENT)
    windows: list[Window] = Field(default_factory=list)
    track: Optional[str] = Field(None, description="Id of the track the timetable belongs to (TTOBench "
                                 "'associated track'): found beside the timetable when no track is given.")

    @model_validator(mode="after")
    def _one_form(self) -> Self:
        if bool(self.stops) == (self.supplement_percent is not None):
            field = "supplement_percent" if self.stops else "stops"
            raise ValueError(f"{field}: give either 'stops' with times or 'supplement_percent'")
        if self.windows and not self.stops:
            raise ValueError("windows: windows need 'stops'")
        return self

    @property
    def windowed(self) -> bool:
        """Whether any time is a window rather than a fixed time (solved as one journey NLP)."""
        return bool(self.windows) or any(
            x is not None for s in self.stops
            for x in (s.earliest_s, s.latest_s, s.departure_earliest_s, s.departure_latest_s))


class Weights(Strict):
    time: float = Field(1.0, ge=0, description="w_t [1/s] (Yazhemsky 2017 eq. 4.1a).")
    energy: float = Field(1.0, ge=0, description="w_e [kg/J], on traction energy per unit mass.")


class Scenario(Strict):
    """A named variant of the base case: other files, train fields overridden, other timing."""

    name: Name
    train: Optional[str] = None
    track: Optional[str] = None
    train_overrides: dict[str, object] = Field(default_factory=dict,
                                               description="Train fields, e.g. mass_t; a block (regenerative_braking: "
                                               "{efficiency: 0.8}) merged field by field into the train's.")
    running_time_s: Optional[float] = Field(None, gt=0)
    supplement_percent: Optional[float] = Field(None, ge=0, le=MAX_SUPPLEMENT_PERCENT)
    objective: Optional[Literal["energy", "net_energy", "time", "mixed"]] = None
    points: Optional[int] = Field(None, ge=10, le=100000)
    das: Optional[Literal["round", "phases", "minlp"]] = Field(
        None, description="Also a DAS run of every case of this scenario (Farooqi 2018 §3.1.2, Ch. 5).")


class Sweep(Strict):
    """Values to combine (cartesian product) with every scenario."""

    running_time_s: Optional[list[Annotated[float, Field(gt=0)]]] = Field(None, min_length=1)
    supplement_percent: Optional[list[Annotated[float, Field(ge=0, le=MAX_SUPPLEMENT_PERCENT)]]] = Field(
        None, min_length=1)
    points: Optional[list[Annotated[int, Field(ge=10, le=100000)]]] = Field(None, min_length=1)
    objective: Optional[list[Literal["energy", "net_energy", "time", "mixed"]]] = Field(None, min_length=1)

    @model_validator(mode="after")
    def _timing(self) -> Self:
        if self.running_time_s is not None and self.supplement_percent is not None:
            raise ValueError("sweep either running_time_s or supplement_percent, not both")
        for name in ("running_time_s", "supplement_percent", "points", "objective"):
            values = getattr(self, name)
            if values is not None and len(set(values)) != len(values):
                raise ValueError(f"{name}: a value given twice would be the same case twice")
        return self


def _at_most_one(model: Strict, names: tuple[str, ...], place: str = "") -> None:
    """Refuse two of the timings ``names`` given together (one of them would be dropped), naming the
    later at ``place`` (``scenarios[0].``): a study's and a scenario's, the same rule."""
    given = [name for name in names if getattr(model, name) is not None]
    if len(given) > 1:
        raise ValueError(f"{place}{given[-1]}: {' and '.join(given[:-1])} given too; give at most one of "
                         f"{', '.join(names)}")


def _swept_over(scenario: Scenario, sweep: Optional[Sweep]) -> tuple[str, str] | None:
    """(the scenario's field, the sweep's) where a swept value would replace a scenario's own: a
    timing beside a swept timing, its points or objective beside swept ones; else None."""
    if sweep is None:
        return None
    timings = ("running_time_s", "supplement_percent")
    swept_timing = next((n for n in timings if getattr(sweep, n) is not None), None)
    for name in (*timings, "points", "objective"):
        by = swept_timing if name in timings else (name if getattr(sweep, name) is not None else None)
        if getattr(scenario, name) is not None and by is not None:
            return name, by
    return None


class Library(Strict):
    """Every stop-to-stop segment of a TTOBench checkout's tracks, run by each of its trains."""

    path: str = Field(description="A TTOBench checkout (its tracks/ and trains/ folders), relative to the study.")
    tracks: Optional[list[Name]] = Field(None, min_length=1, description="Track ids (default: every track).")
    trains: Optional[list[Name]] = Field(None, min_length=1, description="Train ids (default: every train).")
    min_speed_share: float = Field(0.6, ge=0, le=1, description="Pair a train with a track only when its top "
                                   "speed reaches this share of the line's highest limit (a metro train on an "
                                   "intercity line is another service); 0 pairs all.")


class StudyFile(Strict):
    file_kind: ClassVar[str | None] = "study"
    name: Name
    track: Optional[str] = None
    train: Optional[str] = None
    library: Optional[Library] = Field(None, description="Instead of track/train/from/to: a TTOBench library sweep.")
    timetable: Optional[str] = None
    from_stop: Optional[Name] = Field(None, alias="from")
    to_stop: Optional[Name] = Field(None, alias="to")
    running_time_s: Optional[float] = Field(None, gt=0)
    supplement_percent: Optional[float] = Field(None, ge=0, le=MAX_SUPPLEMENT_PERCENT)
    window_s: Optional[tuple[float, float]] = None
    objective: Literal["energy", "net_energy", "time", "mixed"] = "energy"
    weights: Weights = Weights()
    points: int = Field(RUN_POINTS, ge=10, le=100000)
    das: Optional[Literal["round", "phases", "minlp"]] = Field(
        None, description="Also a DAS run of every case, whatever its objective: das_ columns in results.csv.")
    das_time_limit_s: float = Field(DAS_TIME_LIMIT_S, gt=0, description="Time limit of each MINLP search (das: minlp).")
    output: Optional[str] = None
    windows: list[Window] = Field(default_factory=list, description="Timing points between the stops.")
    scenarios: list[Scenario] = Field(default_factory=list, description="Variants run by `ecostudy run`.")
    sweep: Optional[Sweep] = None

    @model_validator(mode="after")
    def _timing(self) -> Self:
        _unique("scenarios", [sc.name for sc in self.scenarios])
        if "sweep" in self.model_fields_set and (self.sweep is None or not self.sweep.model_dump(exclude_none=True)):
            raise ValueError("sweep: empty: give a list of running_time_s, supplement_percent, points or objective, "
                             "or leave sweep out")  # as an empty list is: not a study of the base case alone
        for i, sc in enumerate(self.scenarios):
            if sc.name == "base":  # the study's own case: two rows of one name, one summarised
                raise ValueError(f"scenarios[{i}].name: 'base' is the study's own case (the fields above): name "
                                 "this scenario otherwise")
            _at_most_one(sc, ("running_time_s", "supplement_percent"), f"scenarios[{i}].")
            swept = _swept_over(sc, self.sweep)
            if swept:
                raise ValueError(f"scenarios[{i}].{swept[0]}: the sweep's {swept[1]} replaces it in every case of "
                                 f"scenario '{sc.name}': give it in one place")
        if self.library is None and (self.track is None or self.train is None):
            raise ValueError(f"{'track' if self.track is None else 'train'}: give 'track' and 'train', or a 'library'")
        if self.library is not None and (self.track or self.train or self.from_stop or self.to_stop
                                         or self.scenarios or self.timetable or self.windows):
            raise ValueError("library: a 'library' study names no track, train, from, to, scenarios, timetable or "
                             "windows")
        given = [name for name in ("running_time_s", "supplement_percent", "window_s", "timetable")
                 if getattr(self, name) is not None]
        _at_most_one(self, ("running_time_s", "supplement_percent", "window_s", "timetable"))
        if self.window_s is not None and not 0 <= self.window_s[0] <= self.window_s[1]:
            raise ValueError("window_s: must be [earliest, latest] with 0 <= earliest <= latest")
        if self.objective == "time" and given:  # the fastest run: a running time it would not keep read as kept
            raise ValueError(f"{given[0]}: objective 'time' finds the fastest run, which takes no {given[0]}: "
                             "remove it, or choose objective energy, net_energy or mixed")
        return self


class Substation(Strict):
    """One DC substation and its line (Farooqi 2018 §7.2.1, eq. 7.8)."""

    position_m: float = Field(description="Line position of the substation [m].")
    voltage_V: float = Field(750.0, ge=100, le=30000, description="Source voltage V_s, 100 V to 30 kV (DC lines: "
                             "600 V to 3 kV).")
    internal_resistance_ohm: float = Field(0.01, gt=0, le=10, description="R_s, at most 10 Ohm.")
    line_resistance_ohm_per_km: float = Field(0.025, gt=0, le=10, description="Farooqi 2018: 25 mOhm/km; above 0 "
                                              "(a line without resistance has no voltage to share regeneration by), "
                                              "at most 10 Ohm/km.")
    max_voltage_V: Optional[float] = Field(None, gt=0, description="Regeneration cut-off; default V_s 685/600, at most "
                                           "1.5 V_s (EN 50163 allows 1.33 V_s for minutes).")
    min_voltage_V: Optional[float] = Field(None, gt=0, description="Lowest pantograph voltage; default 2/3 V_s.")
    max_train_current_A: Optional[float] = Field(None, gt=0, description="Largest current a train draws "
                                                 "(Farooqi 2018 Fig. 7.7); default none.")
    max_regen_current_A: Optional[float] = Field(None, gt=0, description="Largest current a train feeds "
                                                 "back (Farooqi 2018 Fig. 7.7); default none.")

    @model_validator(mode="after")
    def _voltages(self) -> Self:
        hi = self.max_voltage_V if self.max_voltage_V is not None else self.voltage_V * 685 / 600
        lo = self.min_voltage_V if self.min_voltage_V is not None else self.voltage_V * 2 / 3
        if not lo < self.voltage_V < hi:
            raise ValueError("need min_voltage_V < voltage_V < max_voltage_V")
        if hi > 1.5 * self.voltage_V:
            raise ValueError(f"max_voltage_V: {hi:g} V is over 1.5 times voltage_V ({self.voltage_V:g} V): a "
                             "regeneration cut-off of a DC line lies near 1.14-1.33 V_s (EN 50163)")
        return self


class FleetTrain(Strict):
    name: Name
    offset_s: float = Field(ge=0, le=86400, description="Departure from the first stop after the first train [s], "
                            "within a day.")


Strategy = Literal["independent", "receptivity", "triggering", "voltage", "dissension", "joint", "following"]
STRATEGIES = get_args(Strategy)


class NetworkStudyFile(Strict):
    """Several trains on one line and one substation: `ecostudy network STUDY.yaml`."""
    file_kind: ClassVar[str | None] = "network study"

    name: Name
    track: Name
    train: Name
    stops: Optional[list[Name]] = Field(None, description="Stops served, in order (default: all).")
    running_times_s: Optional[list[Annotated[float, Field(gt=0)]]] = Field(None, description="Per segment [s].")
    supplement_percent: Optional[float] = Field(None, ge=0, le=MAX_SUPPLEMENT_PERCENT,
                                                description="Per segment, over its all-out time.")
    dwell_s: float = Field(20.0, ge=0, le=86400, description="Dwell at each stop [s], within a day.")
    time_step_s: float = Field(0.5, ge=0.05, le=5, description="Simulation step [s], 0.05 to 5.")
    trains: list[FleetTrain] = Field(min_length=1)
    substation: Substation
    strategies: list[Strategy] = Field(default_factory=lambda: list(STRATEGIES), min_length=1)
    buffer_m: Optional[float] = Field(None, gt=0, description="Separation kept by `following` (Yazhemsky 2017 eq. 6.9).")
    points: int = Field(FRONT_POINTS, ge=10, le=100000, description="Space grid of the per-segment starting runs.")
    output: Optional[str] = None

    @model_validator(mode="after")
    def _choices(self) -> Self:
        if (self.running_times_s is None) == (self.supplement_percent is None):
            raise ValueError("running_times_s: give exactly one of running_times_s, supplement_percent")
        if "following" in self.strategies and self.buffer_m is None:
            raise ValueError("buffer_m: the following strategy needs it")
        _unique("trains", [t.name for t in self.trains])
        _unique("strategies", [str(n) for n in self.strategies])
        offsets = sorted(t.offset_s for t in self.trains)
        if any(b - a < self.time_step_s for a, b in zip(offsets, offsets[1:])):
            raise ValueError("trains: two trains depart at the same time (offset_s): they would stand on each other")
        return self
