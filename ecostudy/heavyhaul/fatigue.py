"""Rainflow cycle counting (ASTM E1049-85 (2017), "Standard practices for cycle counting in fatigue
analysis", §5.4.4, the three-point method) and a fatigue damage proxy of a coupler force history.

The damage proxy is Miner's sum with a Basquin S-N line of slope m, relative to a reference range:
D = sum_j n_j (range_j / range_ref)^m. m = 3 is the slope of welded steel details (EN 1993-1-9,
and the IIW recommendations); it is a typical value, not a coupler's measured S-N curve, so D
compares runs and couplers and is not a life.
"""
import numpy as np

SLOPE = 3            # m of the S-N line (typical of welded steel)
REFERENCE_RANGE = 1e6  # [N]: a 1000 kN range counts 1 per cycle


def reversals(series):
    """The peaks and valleys of ``series`` in order, its first and last points kept (E1049 §5.4.4
    reads peaks and valleys only; equal neighbours are one point)."""
    x = np.asarray(series, float)
    if x.size == 0:
        return x
    x = x[np.concatenate([[True], np.diff(x) != 0])]
    if x.size < 3:
        return x
    d = np.diff(x)
    turning = np.sign(d[1:]) != np.sign(d[:-1])
    return np.concatenate([[x[0]], x[1:-1][turning], [x[-1]]])


def rainflow(series):
    """Rainflow cycles of ``series`` by E1049's three-point method: a list of (range, mean, count),
    count 1 (a cycle) or 0.5 (a half cycle), in the order they close. X is the range of the two most
    recent points, Y the range before it; when X >= Y, Y is counted: a half cycle if it holds the
    starting point (which then moves on), else a cycle whose two points are discarded; what is left
    at the end counts half a cycle per range."""
    stack, out = [], []
    for point in reversals(series):
        stack.append(point)
        while len(stack) >= 3:
            x, y = abs(stack[-1] - stack[-2]), abs(stack[-2] - stack[-3])
            if x < y:
                break
            a, b = stack[-3], stack[-2]
            if len(stack) == 3:  # Y contains the starting point
                out.append((y, 0.5 * (a + b), 0.5))
                stack.pop(0)
            else:
                out.append((y, 0.5 * (a + b), 1.0))
                del stack[-3:-1]
    out += [(abs(b - a), 0.5 * (a + b), 0.5) for a, b in zip(stack[:-1], stack[1:])]
    return out


def damage(cycles, slope=SLOPE, reference=REFERENCE_RANGE):
    """Miner's sum D = sum n (range / reference)^slope of rainflow ``cycles`` [-] (a proxy)."""
    return float(sum(n * (r / reference) ** slope for r, _, n in cycles))
