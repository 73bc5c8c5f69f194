"""Read a heavy-haul consist file (YAML: vehicle types, groups in train order, couplers) into a SI
:class:`~ecostudy.core.types.Consist`, validated by :class:`~ecostudy.io.consistschema.ConsistFile`."""
import warnings
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ecostudy.core import units
from ecostudy.core.errors import EcostudyWarning, problem
from ecostudy.core.physics import Envelope
from ecostudy.core.types import Consist
from ecostudy.io.consistschema import ConsistFile
from ecostudy.io.documents import Where, read_document, validate
from ecostudy.io.intrain import in_train_physics


def load_consist(path: Where) -> Consist:
    """Read a consist file (YAML: vehicle types, groups in train order, couplers) into a :class:`Consist`."""
    return consist_from_document(read_document(path), Path(path))


def consist_from_document(document: Mapping[str, Any], where: Where) -> Consist:
    """A :class:`Consist` (SI) from a consist file's document, validated; ``where`` names it in errors."""
    c = validate(ConsistFile, document, where)
    cars = [c.types[g.type] for g in c.vehicles for _ in range(g.count)]
    if isinstance(where, Path):  # read from its file (not a stored case's copy): said once
        for name in sorted(set(c.types) - {g.type for g in c.vehicles}):  # a typo in a group's type reads like this
            warnings.warn(problem(where, f"types.{name}", "no vehicle group is of this type: it is not in the "
                                  "train"), EcostudyWarning, stacklevel=2)
        for field, what in c.implausible():
            warnings.warn(problem(where, field, what), EcostudyWarning, stacklevel=2)

    def envelope(spec: Any) -> Envelope | None:
        if spec is None:
            return None
        power = spec.max_power_kW * units.KW if spec.max_power_kW else float("inf")
        return Envelope("force_power", max_force=spec.max_force_kN * units.KN, max_power=power)

    return Consist(name=c.name, kinds=tuple(v.kind for v in cars),
                   mass=np.array([v.mass_t * units.TONNE for v in cars]), length=np.array([v.length_m for v in cars]),
                   resistance=np.array([[v.resistance.c0_mps2, v.resistance.c1_per_s, v.resistance.c2_per_m]
                                        for v in cars]),
                   traction=tuple(envelope(v.traction) for v in cars),
                   dynamic_brake=tuple(envelope(v.dynamic_brake) for v in cars),
                   pneumatic_brake=np.array([v.pneumatic_brake_kN * units.KN for v in cars]),
                   stiffness=c.couplers.stiffness_kN_per_m * units.KN, damping=c.couplers.damping_kNs_per_m * units.KN,
                   force_limit=c.couplers.force_limit_kN * units.KN, draft_gear_travel=c.couplers.draft_gear_travel_m,
                   **in_train_physics(c))
