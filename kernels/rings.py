"""Kernels over rings of a ragged (coords, ring_offsets) array."""

import numpy as np
from numba import njit

from ._types import I64_1D, I64_1D_OUT, I64_2D


@njit(I64_1D_OUT(I64_2D, I64_1D), cache=True, nogil=True)
def ring_area2(coords, ring_offsets):
    """Twice the signed area of each ring (exact; CCW > 0).

    Preconditions (the caller checks them): |coords| < 2**30; ring_offsets starts at
    0, never decreases and ends at len(coords).
    """
    n_rings = ring_offsets.shape[0] - 1
    out = np.empty(n_rings, dtype=np.int64)
    for r in range(n_rings):
        start, stop = ring_offsets[r], ring_offsets[r + 1]
        acc = 0
        if stop - start >= 3:
            x0, y0 = coords[start, 0], coords[start, 1]
            for i in range(start + 1, stop - 1):
                ax, ay = coords[i, 0] - x0, coords[i, 1] - y0
                bx, by = coords[i + 1, 0] - x0, coords[i + 1, 1] - y0
                acc += ax * by - ay * bx
        out[r] = acc
    return out
