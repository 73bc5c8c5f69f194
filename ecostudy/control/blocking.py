"""Move blocking of the shrinking-horizon controller SBPC (Farooqi 2018 §4.2, Farooqi, Fagiano & Colaneri).

The horizon runs from sample k to the final sample kf; the predicted inputs are held over blocks
of L samples aligned to absolute multiples of L (Fig. 4.2), so the first block shrinks as k
advances and the number of free values N(k) falls from N(0) to 1.

Eq. 4.8 puts the predicted input u(j|k), j = 0 .. kf - k - 1, in block

    b(j, k) = floor((j + k - floor(k / L) L) / L) + 1,

which is the absolute block floor((k + j) / L) counted from the block holding k. The count
printed as eq. 4.7, N(k) = ceil((kf - k) / L), disagrees with eq. 4.8 when L does not divide kf
(kf = 50, L = 20, k = 15: eq. 4.7 gives 2, eq. 4.8 uses 3 blocks); the count that agrees is

    N(k) = floor((kf - 1) / L) - floor(k / L) + 1.
"""


def free_moves(k, kf, block):
    """N(k): free input values at sample ``k`` of a horizon ending at ``kf`` with blocks of ``block``."""
    if not 0 <= k < kf or block < 1:
        raise ValueError(f"need 0 <= k < kf and a block of at least 1 (k={k}, kf={kf}, L={block})")
    return (kf - 1) // block - k // block + 1


def block_of(j, k, block):
    """b(j, k) of eq. 4.8: the (1-based) free value holding the input predicted for sample k + j."""
    return (j + k - (k // block) * block) // block + 1


def blocks(k, kf, block):
    """The block of every predicted input u(j|k), j = 0 .. kf - k - 1 (eq. 4.8)."""
    return [block_of(j, k, block) for j in range(kf - k)]
