"""Writes ``studies/heavyhaul_sags_reference.csv`` and ``studies/heavyhaul_rolling_reference.csv``: the
references of flat pieces of ``studies/heavyhaul_brake_penalty_sags.yaml`` and
``heavyhaul_brake_penalty_rolling.yaml`` (docs/heavyhaul.md, "A line whose descents pass the dynamic
brakes").

Zhang & Zhuan ("Braking penalized receding horizon control of heavy haul trains") track a given
reference of flat pieces (Fig. 2) that is faster after 7000 m (Section III-B) and bound the mean speed
by it (eq. 7). Their pieces and rates are not published; the ones below are assumed: 50 km/h to 7000 m,
then on the sags line 70 km/h to 24 000 m (the top of its steepest descent), 60 km/h to 33 000 m, 70 km/h
to the stop at 40 000 m; on the rolling line 70 km/h to the stop at 40 000 m; rises at 0.05 m/s^2, drops
and the final stop at 0.1 m/s^2 (a drop's lower speed reached one step, 50 m, before its piece starts), every 50 m.

    python bench/heavyhaul_sags_reference.py
"""
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PIECES = [(0.0, 50.0), (7000.0, 70.0), (24000.0, 60.0), (33000.0, 70.0)]  # (from [m], speed [km/h])
TABLES = {"heavyhaul_sags_reference.csv": PIECES, "heavyhaul_rolling_reference.csv": [(0.0, 50.0), (7000.0, 70.0)]}
LENGTH, STEP, RISE, DROP = 40000.0, 50.0, 0.05, 0.1  # [m], [m], [m/s^2], [m/s^2]


def sags_reference(pieces=PIECES, length=LENGTH, step=STEP, rise=RISE, drop=DROP):
    """(distance [m], speed [m/s]) every ``step``: the pieces' speeds, reached from rest and left into
    the stop at constant accelerations in time (v^2 linear in distance), each drop completed one step
    before its piece starts."""
    x = np.arange(0.0, length + step / 2, step)
    starts = np.array([p[0] for p in pieces])
    target = np.array([p[1] for p in pieces])[np.searchsorted(starts, x, side="right") - 1] / 3.6
    forward, backward = target.copy(), target.copy()
    forward[0], backward[-1] = 0.0, 0.0
    for i in range(1, len(x)):
        forward[i] = min(target[i], np.sqrt(forward[i - 1] ** 2 + 2 * rise * step))
    for i in range(len(x) - 2, -1, -1):
        backward[i] = min(backward[i], np.sqrt(backward[i + 1] ** 2 + 2 * drop * step))
    for i in range(len(x) - 2, -1, -1):  # a lower piece's speed from the step before it
        if target[i + 1] < target[i]:
            backward[i] = min(backward[i], target[i + 1])
            for j in range(i - 1, -1, -1):
                backward[j] = min(backward[j], np.sqrt(backward[j + 1] ** 2 + 2 * drop * step))
    return x, np.minimum(forward, backward)


if __name__ == "__main__":
    for name, pieces in TABLES.items():
        x, v = sags_reference(pieces)
        path = ROOT / "studies" / name
        path.write_text("distance_m,speed_kmh\n" + "".join(f"{d:.0f},{s * 3.6:.2f}\n" for d, s in zip(x, v)))
        print(f"{path}: {len(x)} rows, {x[-1]:.0f} m")
