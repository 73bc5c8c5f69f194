"""The one status vocabulary of every result of every command: ``ok``, ``flagged: <reason>``,
``failed: <reason>``.

``ok`` means computed, and every check passed (solver converged, the independent re-simulation
agrees, stop, time, speed and force limits kept, and adhesion limits where the train has one).
``flagged`` means computed and written, but a check did not pass: the reason says which.
``failed`` means no usable result: the reason says why. A command exits with status 1 when any of
its results is not ok.

Adhesion, what "kept" means:

- a point-mass train whose file gives ``adhesion`` (:mod:`ecostudy.core.adhesion`): its traction
  envelope and electric brake are capped at mu(v) m_adh g when it is loaded, so every formulation
  and the plant use the capped curve; a run verified by re-simulation (``solve``, ``run``,
  ``pareto``, ``journey``, ``compare``'s ATO run, a network leg) records the largest share of the
  limit its forces asked for (``adhesion_use_max``) and is flagged above :data:`ADHESION_USE`;
  driven runs (``compare``'s strategies, driver advice, closed loop) record and are flagged alike
  (:func:`driven_run`), against the true train's limit (its adhesive mass times the drawn mass):
  they apply at most the capped envelope, and a true train stronger or lighter than its model at
  most that limit itself, so they keep it by construction unless the train was built in code with
  envelopes above its limit;
- a point-mass train without the field has no adhesion limit: nothing is capped or checked (its
  ``max_acceleration_mps2`` bounds the net acceleration, not the wheels' grip);
- a heavy-haul run is flagged when a locomotive asks more than 1 % above its mu(v) m g
  (:mod:`ecostudy.heavyhaul.metrics`), capped by its plant with ``adhesion: true``.
"""
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Iterable, Literal

from ecostudy.core.adhesion import TOLERANCE

Kind = Literal["ok", "flagged", "failed"]
ORDER = {"ok": 0, "flagged": 1, "failed": 2}

# words that per-case tables use, read into the vocabulary ("infeasible": the request cannot be met;
# "missing": a case not computed yet, e.g. left out by ``--only``)
_WORDS: dict[str, Kind] = {"ok": "ok", "flagged": "flagged", "failed": "failed", "infeasible": "failed", "missing": "failed"}


def status_word(text: object) -> str:
    """The word a status text starts with (``"flagged: late"`` -> ``flagged``; ``infeasible``,
    ``missing`` as they are): what a printed table or a report's cell colour shows of it."""
    return str(text).partition(":")[0].strip()


@dataclass(frozen=True)
class Status:
    """A result's status: ``kind`` is ok, flagged or failed; ``reason`` says why it is not ok."""

    kind: Kind
    reason: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ORDER:
            raise ValueError(f"status kind must be one of {', '.join(ORDER)}, not {self.kind!r}")
        if self.kind != "ok" and not self.reason:
            raise ValueError(f"a {self.kind} status needs its reason")

    @property
    def ok(self) -> bool:
        return self.kind == "ok"

    def __str__(self) -> str:
        return self.kind if self.ok else f"{self.kind}: {self.reason}"

    @classmethod
    def parse(cls, text: str, reason: str = "") -> "Status":
        """A status from its text (``"flagged: late"``) or from a table's word and reason column
        (``"infeasible"``, ``"below the all-out time"``)."""
        word, rest = status_word(text), str(text).partition(":")[2]
        if word not in _WORDS:
            raise ValueError(f"not a status: {text!r}")
        kind = _WORDS[word]
        detail = rest.strip() or (reason or "").strip()
        if word in ("infeasible", "missing"):  # a reason that says it already (an InfeasibleError's) is not said twice
            detail = word if not detail else detail if detail.startswith(f"{word}:") else f"{word}: {detail}"
        return cls(kind, "" if kind == "ok" else detail or "no reason recorded")


OK = Status("ok")


class Judged(ABC):
    """A result judged in this vocabulary: its ``status`` (each kind of result judges itself), and
    the ``reason`` and ``ok`` that follow."""

    @property
    @abstractmethod
    def status(self) -> Status:
        """The result's status."""

    @property
    def reason(self) -> str:
        """Why the result is not ok ('' when it is)."""
        return self.status.reason

    @property
    def ok(self) -> bool:
        return self.status.ok

# What a driven run may miss and still be ok (a simulated or closed-loop run, a strategy's run):
STOP_TOLERANCE_M = 1.0        # |stopping position - stop| [m]
LATE_TOLERANCE_S = 1.0        # arrival after the asked time or window [s]
# arrival before the asked time [s], for a run driven to a running time (a strategy, DAS advice): a
# run that cannot use the time it was given is not comparable at that time (eco-drive coasting at a
# running time of 300 s on a 72 s stretch arrived 178 s early)
EARLY_TOLERANCE_S = 1.0
OVERSPEED_TOLERANCE_KMH = 0.5  # largest excess over the speed limit [km/h]
TOLERANCES = {"arrival_time_error_s": 0.5, "stop_error_m": 1.0, "energy_error_pct": 1.0,
              "net_energy_error_pct": 1.0, "overspeed_max_kmh": 0.5}  # the re-simulation's (core.simulate.verify)
STOOD_KMH = 0.1  # a simulated run this slow where its simulation ended stood there (its stop event leaves ~0)
ADHESION_USE = 1.0 + TOLERANCE  # a train with an adhesion limit: the largest share of it any run may ask


def flagged(reason: str) -> Status:
    return Status("flagged", reason)


def failed(reason: str) -> Status:
    return Status("failed", reason)


def cells(word: object, reason: object) -> tuple[str, object]:
    """A stored result's ``status`` and ``reason`` cells as every per-case table writes them: its
    kind, ``ok``, ``flagged`` or ``failed``, and its reason apart (an infeasible request, stored as
    ``infeasible``, is ``failed`` with the reason ``infeasible: ...``); ``missing``, a case not
    computed yet (no result), as it is."""
    if word is None or word == "missing":
        return "missing", reason
    status = Status.parse(str(word), reason if isinstance(reason, str) else "")
    return status.kind, status.reason or None


CALIBRATED = "train calibrated with status flagged: "  # the reason :func:`calibrated` lends a run


def calibrated(reason: str) -> Status:
    """The status a train file lends every run of it: ``ok``, or ``flagged`` when ``ecostudy calibrate``
    wrote the file from a calibration that was not ok (``reason``, the train's ``calibration_reason``:
    its ``calibration`` block), so that a run of a train whose parameters the logs did not bear out
    is not ok either."""
    return OK if not reason else flagged(f"{CALIBRATED}{reason}")


def parsed(names: Iterable[str], words: Iterable[str], reasons: Iterable[object]) -> dict[str, Status]:
    """Statuses by name from a table's ``status`` words and ``reason`` cells (a reason that is not
    text, e.g. an empty cell read as NaN, is none)."""
    return {name: Status.parse(word, reason if isinstance(reason, str) else "")
            for name, word, reason in zip(names, words, reasons)}


def from_checks(checks: dict[str, bool]) -> Status:
    """``ok`` when every named check passed, else ``flagged`` naming the ones that did not."""
    missed = [name for name, passed in checks.items() if not passed]
    return OK if not missed else flagged("; ".join(missed))


def solver_check(ended: str, solver: str = "Ipopt", proven: str = "optimal") -> dict[str, bool]:
    """The check that a ``solver`` proved optimality, for :func:`from_checks`: named by how it
    ``ended`` ('Ipopt ended maxIterations, not optimal'), passed when that is its ``proven`` end
    (Clarabel's: ``Solved``)."""
    return {f"{solver} ended {ended}, not optimal": ended == proven}


# the ends by which a solver proves its optimum: Ipopt's, Clarabel's, SciPy's SLSQP's (its message)
PROVEN = ("optimal", "Solved", "Optimization terminated successfully")


def unproven_columns(ends: list[str]) -> dict[str, object]:
    """A run's columns of the driven solves its solver did not prove optimal, from how each ``ends``:
    ``unproven_solves_count`` and ``unproven_solver_status`` (the distinct ends, None for none)."""
    return {"unproven_solves_count": len(ends), "unproven_solver_status": ", ".join(sorted(set(ends))) or None}


def unproven_solves(count: int, samples: int, ends: str) -> Status:
    """A driven run some of whose samples drove a plan the solver did not prove optimal (usable: within
    the constraints, e.g. Ipopt ``acceptable``, Clarabel ``AlmostSolved``): ``flagged`` with their
    ``count`` among the run's ``samples`` and how the solver ``ended`` them; ``ok`` for none."""
    if not count:
        return OK
    return flagged(f"{count} solve{'s' if count != 1 else ''} in {samples} samples ended {ends} (driven, not proven "
                   "optimal)")


def part(name: str, status: Status) -> Status:
    """``status`` of a part named ``name`` as the whole it belongs to reports it: ``ok``, or ``flagged``
    naming the part (a failed part too: the whole still stands, e.g. a run whose driver advice failed)."""
    if status.ok:
        return OK
    return flagged(f"{name}: {status.reason}" if status.kind == "flagged" else f"{name} failed: {status.reason}")


def solver_part(name: str, ended: str, solver: str = "Ipopt", proven: str = "optimal") -> Status:
    """The status of a part, the program ``name`` that a ``solver`` ``ended`` as a whole's result
    rests on: ``ok`` when that is its ``proven`` end, else ``flagged`` ('NAME: Ipopt ended
    acceptable, not optimal')."""
    return part(name, from_checks(solver_check(ended, solver, proven)))


def worst(statuses: Iterable[Status]) -> Status:
    """The status of a whole: the worst kind, with the reasons of every result of that kind."""
    statuses = list(statuses)
    if not statuses:
        return failed("no results")
    kind = max((s.kind for s in statuses), key=ORDER.__getitem__)
    if kind == "ok":
        return OK
    reasons = list(dict.fromkeys(s.reason for s in statuses if s.kind == kind))
    return Status(kind, "; ".join(reasons))


def past(value: float, tolerance: float, digits: int = 3, kind: str = "g") -> str:
    """``value`` beyond ``tolerance`` formatted with ``digits`` (significant digits for ``kind``
    "g", decimals for "f"), or as many more as it takes to read beyond it (-1.0014 against 1 is
    ``-1.001``, not ``-1``)."""
    for more in range(digits, 16):
        text = f"{value:.{more}{kind}}"
        if not abs(float(text)) <= tolerance:
            return text
    return repr(value)


def off_stop(error_m: float, tolerance_m: float, digits: int = 2) -> str:
    """The reason of a run that stood ``error_m`` [m] off its stop (negative: short of it), beyond
    ``tolerance_m``: 'stopped 1.36 m short of the stop (tolerance 1 m)' (or 'beyond the stop'), with
    as many more ``digits`` (up to 4) as it takes not to read as within the tolerance (1.047 m is
    '1.05', not '1.0')."""
    side = "short of" if error_m < 0 else "beyond"
    while digits < 4 and round(abs(error_m), digits) <= tolerance_m < abs(error_m):
        digits += 1
    return f"stopped {abs(error_m):.{digits}f} m {side} the stop (tolerance {tolerance_m:g} m)"


def at_stop(stop_error_m: Any) -> Any:
    """Whether a driven run stood within :data:`STOP_TOLERANCE_M` of its stop (numbers or arrays): only
    then has it an arrival time, a saving or a gap; short of its stop or past it, it did another run."""
    return abs(stop_error_m) <= STOP_TOLERANCE_M


def driven_run(stop_error_m: float | None = None, late_s: float | None = None,
               overspeed_kmh: float | None = None, adhesion_use: float | None = None,
               early_s: float | None = None, moving_kmh: float = 0.0) -> Status:
    """The status of a driven run from what it missed (``None``: not measured): ``flagged`` when
    it stops more than :data:`STOP_TOLERANCE_M` off, arrives more than :data:`LATE_TOLERANCE_S`
    late (or, given ``early_s``, more than :data:`EARLY_TOLERANCE_S` early), overspeeds by more than
    :data:`OVERSPEED_TOLERANCE_KMH` or asks more than :data:`ADHESION_USE` of its adhesion limit
    (``core.simulate.adhesion_use``). ``moving_kmh``: the speed a simulated run still had where its
    simulation ended past the stop (``core.plant.RUNAWAY_M``; at most :data:`STOOD_KMH`: it stood), said as such, not as a
    place it stood at."""
    reasons = []
    if stop_error_m is not None and moving_kmh > STOOD_KMH and stop_error_m > STOP_TOLERANCE_M:
        reasons.append(f"ran past the stop without stopping: {moving_kmh:.1f} km/h {stop_error_m:.0f} m beyond it, "
                       f"where the simulation ends (tolerance {STOP_TOLERANCE_M:g} m)")
    elif stop_error_m is not None and not abs(stop_error_m) <= STOP_TOLERANCE_M:
        reasons.append(off_stop(stop_error_m, STOP_TOLERANCE_M))
    if stop_error_m is not None and stop_error_m < -STOP_TOLERANCE_M:  # stood short: it never arrived,
        late_s = early_s = None                                          # early or late
    if late_s is not None and not late_s <= LATE_TOLERANCE_S:
        reasons.append(f"arrived {past(late_s, LATE_TOLERANCE_S, 2, 'f')} s late")
    if early_s is not None and not early_s <= EARLY_TOLERANCE_S:
        reasons.append(f"arrived {past(early_s, EARLY_TOLERANCE_S, 2, 'f')} s early (tolerance {EARLY_TOLERANCE_S:g} s)")
    if overspeed_kmh is not None and not overspeed_kmh <= OVERSPEED_TOLERANCE_KMH:
        reasons.append(f"overspeed {past(overspeed_kmh, OVERSPEED_TOLERANCE_KMH, 2, 'f')} km/h")
    if adhesion_use is not None and not adhesion_use <= ADHESION_USE:
        reasons.append(f"adhesion use {past(adhesion_use, ADHESION_USE, 3, 'f')} of mu(v) m_adh g (tolerance {ADHESION_USE:g})")
    return OK if not reasons else flagged("; ".join(reasons))
