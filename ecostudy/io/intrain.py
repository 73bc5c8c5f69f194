"""The consist file's in-train physics (``air_brake``, ``draft_gear``, ``notches``) in SI."""
from typing import Any

from ecostudy.core import units
from ecostudy.core.types import AirBrake, DraftGear, Notches

MM = 1e-3  # [m]


def in_train_physics(c: Any) -> dict[str, Any]:
    """{'air_brake': AirBrake | None, 'draft_gear': DraftGear | None, 'notches': Notches | None} of a
    validated consist file ``c``."""
    a, d, n = c.air_brake, c.draft_gear, c.notches
    return {
        "air_brake": None if a is None else AirBrake(a.signal_speed_mps, a.build_up_s, a.release_s),
        "draft_gear": None if d is None else DraftGear(
            d.slack_mm * MM, d.loading_stiffness_kN_per_m * units.KN, d.unloading_stiffness_kN_per_m * units.KN,
            d.transition_speed_mps, d.smoothing_mm * MM),
        "notches": None if n is None else Notches(n.traction, n.dynamic_brake),
    }
