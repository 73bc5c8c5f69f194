"""What a heavy-haul run reports and when it is not ok: the numbers read from a closed-loop record
(:class:`~ecostudy.heavyhaul.loop.LoopRecord`) and the reasons that flag it.

A run is ``flagged`` (never ``ok``) when the train stalled and rolled back (more than the stop
tolerance, at the sample ends), when it did not arrive (the sample cap came first, or it stood held on
its brakes for good: the same plan twice running, less traction than the grade pulls back), when
it stopped farther from the stop than the tolerance (short or beyond; short where the grade and
resistance exceed the locomotives' utmost traction, a stall, it says so), when it arrived later than the
reference's running time by more than the tolerance (a share of it or seconds, the larger), when a car ran faster than the
train's limit at the head by more than the tolerance, when a coupler carried more than the consist's
limit, when a locomotive asked more of its wheels than dry rail gives (its traction or dynamic
braking as the plant applied it over Curtius & Kniffler's mu(v) m g, by more than :data:`ADHESION`:
only where the plant does not model adhesion, the paper's plant), or when a solve took longer than
Ts (its input was not applied).

Per run also: eq. 4's terms at each sample's optimum, summed over the run (in-train forces,
tracking, the locomotives' efforts, the wagons' braking: the value the controller traded), the
locomotives' dynamic braking against its limit at their speed, and the samples in which the
locomotives pull while a wagon brakes (stretch braking) and about the energy the locomotives put in
there only for the wagons to brake it away (the smaller of the two forces times the mean speed over
the sample): E = int |u v| dt counts it twice.
"""
from typing import NamedTuple

import numpy as np

from ecostudy.core import adhesion
from ecostudy.core.status import off_stop, past
from ecostudy.core.units import KMH, KN, KWH
from ecostudy.heavyhaul.fatigue import damage, rainflow
from ecostudy.heavyhaul.plant import LOSSES
from ecostudy.heavyhaul.rhc import TERMS

RUN_IN = 50 * KN  # a coupler's force from above +this (draft) to below -this (buff) is a slack run-in [N]
PULLING = KN     # a (virtual) car's effort above this pulls, below minus this brakes [N]
AT_LIMIT = 0.99  # dynamic braking at this share of its limit or more is "at the limit"
# a locomotive may ask 1 % more than mu(v) m g before the run is flagged (core.adhesion.TOLERANCE, the
# point-mass trains' share too): the inputs of the ratio are given to about three digits (Curtius &
# Kniffler's 0.161, 7.5, 44; a consist's 126 t, 560 kN), so within 1 % a run is not shown to exceed dry
# rail's grip; the plant's own arithmetic is exact (with adhesion on it clips the effort to the grip)
ADHESION = adhesion.TOLERANCE
# the plant's energy balance closes within 1.6e-4 of traction on every plant and shipped line (the
# integrator's error, docs/heavyhaul.md): a residual beyond 0.1 % of the balance's largest term
# (:func:`balance_scale`) means the run is not to be trusted
BALANCE = 1e-3
# ... the scale at least this [kWh]: a train that barely moves has terms of 1e-23 kWh, and the integrator
# keeps each work only to an absolute plant.ATOL_WORK = 1 J per step (a few kJ over a run of 1000 samples)
BALANCE_FLOOR_KWH = 1.0


class Tolerances(NamedTuple):
    """How far a run may miss before it is flagged."""

    stop_m: float = 1.0        # |head at the end - the stop| [m]
    speed_mps: float = KMH     # fastest car over the train's limit [m/s]
    arrival: float = 0.05      # later than the reference's running time by this share of it [-] ...
    arrival_s: float = 60.0    # ... and by more than this [s]
    adhesion: float = ADHESION  # a locomotive's effort over mu(v) m g by more than this share [-]
    balance: float = BALANCE   # the energy balance's residual beyond this share of its scale (balance_scale) [-]


def braking_samples(efforts, locomotives):
    """Samples in which some (virtual) car brakes and no locomotive pulls (``efforts`` rows [N])."""
    pulls = (efforts[:, locomotives] > PULLING).any(axis=1)
    return (efforts.min(axis=1) < -PULLING) & ~pulls


def ended(record, stop_error, stop_tolerance):
    """How a run ended, one of :data:`ENDS`: ``record`` a :class:`~ecostudy.heavyhaul.loop.LoopRecord`,
    ``stop_error`` the head's end minus the stop [m] (positive beyond), ``stop_tolerance`` [m]."""
    if record.rolling_back:
        return "rolling back"
    if record.held_for_good:
        return "held on its brakes"
    if not record.stood:
        return "sample cap"
    if abs(stop_error) <= stop_tolerance:
        return "at the stop"
    if stop_error > 0:
        return "beyond the stop"
    return "stalled short of the stop" if record.end_forces[0] > record.end_forces[1] else "short of the stop"


# how a run ended (runs.csv ``ended``); ``arrived`` is True for the first alone
ENDS = ("at the stop", "short of the stop", "stalled short of the stop", "beyond the stop", "rolling back",
        "held on its brakes", "sample cap")
STOOD = ENDS[:4]  # the train stood on the reference's final approach (its arrival time is a time it stood)


def run_metrics(record, reference, locomotives, force_limit, stop, stop_tolerance=Tolerances().stop_m):
    """The checked numbers of a run (units in the names): ``locomotives`` the indices of the
    locomotive (virtual) cars, ``force_limit`` the consist's coupler limit [N], ``stop`` the line's
    stop [m] (the segment's length: a reference table may end up to a metre off it, and the stop
    error is the head's from the stop, not from the table's end), ``stop_tolerance`` [m] how far from
    the stop a train that stood has ``arrived``."""
    efforts = record.efforts
    loco = efforts[:, locomotives]
    braking = braking_samples(efforts, locomotives)
    wagons = np.ones(efforts.shape[1], bool)
    wagons[locomotives] = False
    stretch = (loco > PULLING).any(axis=1) & (efforts[:, wagons] < -PULLING).any(axis=1)
    both = np.minimum(np.maximum(loco, 0.0).sum(axis=1), np.maximum(-efforts[:, wagons], 0.0).sum(axis=1))
    speeds = 0.5 * (record.mean_speed + np.concatenate([[0.0], record.mean_speed[:-1]]))  # over each sample
    dynamic = np.maximum(-loco, 0.0).sum(axis=1) / np.maximum(record.dynamic_limits.sum(axis=1), 1.0)
    using = dynamic > 1e-3
    terms = np.nansum(record.terms, axis=0)
    error = float(record.head[-1] - stop)
    end = ended(record, error, stop_tolerance)
    at = float(record.times[-1]) if end in STOOD else np.nan  # a train that never stood has no arrival
    return {
        "arrived": end == ENDS[0], "ended": end, "ended_s": float(record.times[-1]), "arrival_s": at,
        "arrival_late_s": at - reference.running_time, "arrival_late_pct": 100 * (at / reference.running_time - 1),
        "stop_error_m": error,
        **rollback(record.head, reference.distance[0], stop),
        "reference_at_end_kmh": float(record.reference[-1] / KMH),  # v_r where the run ended
        "speed_at_end_kmh": float(record.mean_speed[-1] / KMH), "rolling_back": bool(record.rolling_back),
        "resistance_at_end_kN": record.end_forces[0] / KN, "traction_utmost_at_end_kN": record.end_forces[1] / KN,
        **held_time(record, locomotives),
        "force_max_kN": float(record.largest_coupler.max() / KN),
        "force_max_braking_kN": float(record.largest_coupler[braking].max() / KN) if braking.any() else 0.0,
        "force_limit_kN": force_limit / KN, "braking_samples": int(braking.sum()),
        "stretch_braking_samples": int(stretch.sum()),
        "stretch_braking_kWh": float(np.sum(both * speeds * np.diff(record.times, prepend=0.0)) / KWH),
        "speed_excess_kmh": float(max(record.speed_excess.max(), 0.0) / KMH),
        "dynamic_brake_use_max": float(dynamic.max()),
        "dynamic_brake_use_mean": float(dynamic[using].mean()) if using.any() else 0.0,
        "dynamic_brake_at_limit_samples": int((dynamic >= AT_LIMIT).sum()),
        **adhesion_use(record.adhesion),
        **{f"J_{name}": float(value) for name, value in zip(TERMS, terms)},
        **energy_balance(record),
    }


def held_time(record, locomotives):
    """How long the train stood held on its brakes (a hill start, ``held_s``), whether it was still
    held when the run ended (``held_at_end``), and the traction its locomotives were asked for in the
    last sample (``traction_asked_at_end_kN``, their planned efforts above 0)."""
    held = np.asarray(record.held, bool)
    asked = np.maximum(record.efforts[-1, locomotives], 0.0).sum()
    return {"held_s": float(np.sum(np.diff(record.times, prepend=0.0)[held])), "held_at_end": bool(held[-1]),
            "traction_asked_at_end_kN": float(asked / KN)}


def adhesion_use(samples):
    """The most a locomotive asked of its wheels over the run (``samples`` the loop's rows of
    :meth:`~ecostudy.heavyhaul.plant.CascadePlant.adhesion_use`): its traction or dynamic braking as
    the plant applied it over mu(v) m g (Curtius & Kniffler), where, when, at what speed and effort."""
    use, time, head, speed, effort = samples[int(np.argmax(samples[:, 0]))]
    return {"adhesion_use_max": float(use), "adhesion_use_time_s": float(time), "adhesion_use_head_m": float(head),
            "adhesion_use_kmh": float(speed / KMH), "adhesion_use_effort_kN": float(effort / KN)}


def rollback(head, start, stop):
    """How far the train rolled back at most (the head at a sample end behind the farthest it had
    reached before, ``rollback_m`` [m]), how far before the ``stop`` [m] it stalled there
    (``stalled_before_stop_m``, the farthest point reached; 0 without a roll back) and how far past
    the ``start`` [m] that was (``stalled_after_start_m``: at most 0 when it rolled back from the
    start before it moved off)."""
    farthest = np.maximum.accumulate(np.concatenate([[start], head]))[1:]
    back = farthest - head
    i = int(np.argmax(back))
    moved = back[i] > 0
    return {"rollback_m": float(back[i]), "stalled_before_stop_m": float(stop - farthest[i]) if moved else 0.0,
            "stalled_after_start_m": float(farthest[i] - start) if moved else 0.0}


def energy_balance(record):
    """The plant's energy balance over the run [kWh]: what the efforts put in (traction minus the
    dynamic and wagon brakes) against each named loss (running and curve resistance, the grades,
    the couplers' damping) and the change of kinetic plus coupler elastic energy; the residual is
    the integrator's error."""
    put_in = record.traction_work - record.dynamic_brake_work - record.wagon_brake_work
    out = {f"{name}_kWh": value / KWH for name, value in zip(LOSSES, record.losses)}
    out["stored_change_kWh"] = record.stored_change / KWH
    out["balance_residual_kWh"] = (put_in - sum(record.losses) - record.stored_change) / KWH
    return out


BALANCE_TERMS = ("traction", "dynamic_brake", "wagon_brake", *LOSSES, "stored_change")  # each a ``NAME_kWh`` metric


def balance_scale(metrics):
    """(name, size [kWh]) of the energy balance's largest term (:data:`BALANCE_TERMS`, by magnitude),
    at least :data:`BALANCE_FLOOR_KWH` ("at least" then): what its residual is measured against."""
    sizes = {name.replace("_", " "): abs(metrics.get(f"{name}_kWh", 0.0)) for name in BALANCE_TERMS}
    name = max(sizes, key=sizes.__getitem__)
    return (name, sizes[name]) if sizes[name] >= BALANCE_FLOOR_KWH else ("the floor, every term being smaller", BALANCE_FLOOR_KWH)


def run_ins(forces, threshold=RUN_IN):
    """(run-ins, run-outs) of every coupler: its force going from draft (>= ``threshold``) to buff
    (<= -``threshold``) and back, over a history ``forces`` (points, couplers) [N]."""
    ins, outs = np.zeros(forces.shape[1], int), np.zeros(forces.shape[1], int)
    for j, column in enumerate(forces.T):
        side = np.sign(column[np.abs(column) >= threshold])
        ins[j], outs[j] = np.sum((side[:-1] > 0) & (side[1:] < 0)), np.sum((side[:-1] < 0) & (side[1:] > 0))
    return ins, outs


def in_train_metrics(history, consist):
    """What heavy-haul engineers read from the couplers' force histories (the plant's ``history``:
    per step the integrator's times [s] and forces [N], tension positive): the largest draft
    (tension) and buff (compression) force, at which coupler (1: behind the head car), how far
    behind the head's front [m] and when [s]; the slack run-ins (draft to buff, :data:`RUN_IN`) and
    run-outs summed over the couplers; the rainflow damage proxy (heavyhaul.fatigue) summed over
    the couplers and the largest one's, and the rainflow cycles of 100 kN range or more."""
    times = np.concatenate([t for t, _ in history])
    forces = np.concatenate([f for _, f in history])  # float32 as kept (a long run with slack: 1e7 numbers)
    where = np.cumsum(consist.length)[:-1]
    out = {}
    for name, sign in (("draft", 1.0), ("buff", -1.0)):
        point, coupler = np.unravel_index(np.argmax(sign * forces), forces.shape)
        out |= {f"{name}_max_kN": max(sign * float(forces[point, coupler]), 0.0) / KN, f"{name}_coupler": int(coupler) + 1,
                f"{name}_position_m": float(where[coupler]), f"{name}_time_s": float(times[point])}
    ins, outs = run_ins(forces)
    cycles = [rainflow(column.astype(float)) for column in forces.T]
    damages = np.array([damage(c) for c in cycles])
    return {**out, "run_ins_count": int(ins.sum()), "run_outs_count": int(outs.sum()),
            "fatigue_damage": float(damages.sum()), "fatigue_damage_max": float(damages.max()),
            "fatigue_damage_coupler": int(np.argmax(damages)) + 1,
            "rainflow_cycles_over_100kN_count": float(sum(n for c in cycles for r, _, n in c if r >= 100 * KN))}


def closing_metrics(closest, consist, travel):
    """The most compressed coupling of a run (the plant's ``closest``, a
    :class:`~ecostudy.heavyhaul.plant.Closing`): its compression [m], which coupler (1: behind the
    head car), how far behind the head's front [m], when [s], its coupled spacing [m], and how far a
    coupling closes before its draft gears are solid (``travel``, the plant's) [m]."""
    return {"compression_max_m": closest.compression, "compression_coupler": closest.coupler + 1,
            "compression_position_m": float(np.cumsum(consist.length)[closest.coupler]),  # its cars' ends meet there
            "compression_time_s": closest.time, "compression_spacing_m": closest.spacing, "compression_limit_m": travel}


def reasons(metrics, samples, over_budget_count, tolerances=Tolerances()):
    """Why a run is not ok (empty: ok); ``samples`` the cap it ran under."""
    out = []
    if metrics.get("rollback_m", 0.0) > tolerances.stop_m and metrics.get("stalled_after_start_m", np.inf) <= tolerances.stop_m:
        out.append(f"the train rolled back {metrics['rollback_m']:.0f} m from the start before it moved off")
    elif metrics.get("rollback_m", 0.0) > tolerances.stop_m:
        out.append(f"the train stalled {metrics['stalled_before_stop_m']:.0f} m before the stop and rolled back "
                   f"{metrics['rollback_m']:.0f} m")
    asked = (f" with the reference at {metrics['reference_at_end_kmh']:.1f} km/h there"  # a stall reads as one
             if metrics["stop_error_m"] < 0 and "reference_at_end_kmh" in metrics else "")
    held, utmost = metrics.get("resistance_at_end_kN", 0.0), metrics.get("traction_utmost_at_end_kN", np.inf)
    if metrics["stop_error_m"] < 0 and held > utmost:  # it cannot go on
        asked += (f", stalled: the grade and resistance there ({held:.0f} kN) exceed the locomotives' utmost "
                  f"traction ({utmost:.0f} kN)")
    if metrics.get("held_at_end"):  # it never moved off, or stood held again, to the run's end
        where = ("at the start" if metrics["held_s"] >= metrics["ended_s"] - 1e-6
                 else f"{-metrics['stop_error_m']:.0f} m before the stop")
        good = (" (the same plan twice running from the same standing train: it would stay held to the sample cap)"
                if metrics["ended"] == "held on its brakes" else "")
        out.append(f"held on its brakes {where} for {metrics['held_s']:.0f} s until the run ended{good}: the controller "
                   f"never asked more traction ({metrics['traction_asked_at_end_kN']:.0f} kN) than the grade, curve "
                   f"and resistance pull back ({metrics['resistance_at_end_kN']:.0f} kN)")
    if metrics["ended"] == "rolling back":  # the loop ended the run on the final approach: the train did not stand
        error = metrics["stop_error_m"]
        where = f"{-error:.1f} m before the stop" if error <= 0 else f"{error:.1f} m beyond the stop"
        out.append(f"rolling back at {-metrics['speed_at_end_kmh']:.2f} km/h {where} when the run ended (the loop "
                   f"ends a run on the reference's final approach when the train stands or rolls back){asked}")
    elif metrics["ended"] == "sample cap":
        where = (f"{-metrics['stop_error_m']:.0f} m before the stop" if metrics["stop_error_m"] <= 0
                 else f"with the train {metrics['stop_error_m']:.0f} m beyond the stop, not stopped")
        out.append(f"the sample cap ({samples}) came {where}")
    elif metrics["ended"] in STOOD and abs(metrics["stop_error_m"]) > tolerances.stop_m:
        out.append(off_stop(metrics["stop_error_m"], tolerances.stop_m, 1) + asked)
    late, share = metrics["arrival_late_s"], metrics["arrival_late_pct"]
    if metrics["ended"] in STOOD and share > 100 * tolerances.arrival and late > tolerances.arrival_s:
        out.append(f"arrived {late:.0f} s ({share:.1f} %) after the reference's running time "
                   f"(tolerance {100 * tolerances.arrival:g} % or {tolerances.arrival_s:g} s, the larger)")
    if metrics["force_max_kN"] > metrics["force_limit_kN"]:
        out.append(f"largest coupler force {past(metrics['force_max_kN'], metrics['force_limit_kN'], 1, 'f')} kN above the consist's "
                   f"{metrics['force_limit_kN']:g} kN limit")
    closed = metrics.get("compression_max_m", 0.0)
    travel, spacing = metrics.get("compression_limit_m", np.inf), metrics.get("compression_spacing_m", np.inf)
    beyond = []
    if closed >= travel:  # the gears are solid: the plant's couplers have no end stop
        beyond.append(f"its draft gears' travel of {travel:.3f} m or more (couplers.draft_gear_travel_m; with "
                      "draft_gear on, plus half the slack): draft gear bottomed out, the cars overlap")
    if closed >= spacing:
        beyond.append(f"its cars' {spacing:.2f} m spacing or more: the cars would pass through each other")
    if beyond:
        out.append(f"coupler {metrics['compression_coupler']} ({metrics['compression_position_m']:.0f} m behind the head) "
                   f"closed {closed:.3f} m at {metrics['compression_time_s']:.0f} s, {', and '.join(beyond)} (the "
                   "plant's couplers have no end stop: they are too soft for the forces)")
    if metrics["speed_excess_kmh"] * KMH > tolerances.speed_mps:
        out.append(f"a car ran {past(metrics['speed_excess_kmh'], tolerances.speed_mps / KMH, 1, 'f')} km/h over the line's limit "
                   f"(tolerance {tolerances.speed_mps / KMH:g} km/h)")
    if metrics.get("adhesion_use_max", 0.0) > 1.0 + tolerances.adhesion:
        effort = metrics["adhesion_use_effort_kN"]
        out.append(f"a locomotive asked {past(metrics['adhesion_use_max'], 1.0 + tolerances.adhesion, 2, 'f')} of its adhesion (mu(v) m g, Curtius & Kniffler, "
                   f"tolerance {100 * tolerances.adhesion:g} %), {'pulling' if effort > 0 else 'braking'} {abs(effort):.0f} kN at "
                   f"{metrics['adhesion_use_kmh']:.1f} km/h, {metrics['adhesion_use_time_s']:.0f} s, head at "
                   f"{metrics['adhesion_use_head_m']:.0f} m, which the plant does not limit (adhesion: false): "
                   "set adhesion: true or lower the locomotives' envelopes")  # no ';': it parts the reasons
    residual, (name, scale) = metrics.get("balance_residual_kWh", 0.0), balance_scale(metrics)
    if abs(residual) > tolerances.balance * scale:
        out.append(f"the energy balance does not close: residual {residual:.2f} kWh, {100 * abs(residual) / scale:.2g} % "
                   f"of the {scale:.0f} kWh of {name} (tolerance {100 * tolerances.balance:g} % of the balance's "
                   f"largest term, at least {BALANCE_FLOOR_KWH:g} kWh): the plant's integration is not to be trusted")
    if over_budget_count:
        out.append(f"{over_budget_count} solves over Ts (the previous input was held)")
    return out
