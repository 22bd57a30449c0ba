"""Kernels over the bytes of binary PLY files."""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, I64, I64_1D_OUT, I64_2D, U8_1D


@kernel(types.Tuple((I64_1D_OUT, I64))(U8_1D, I64, I64, I64_2D, B1))
def record_starts(data, start, n_records, props, big_endian):
    """Where each of ``n_records`` records of a PLY element starts in ``data``.

    A record holds the element's properties in order; a list property is its
    count followed by that many values. ``props`` has a row per property:
    ``[bytes of the count (0 for a scalar), bytes of each value, 1 if the count
    is signed, least count accepted]``. Returns ``(starts, done)``: record ``r``
    spans ``data[starts[r]:starts[r + 1]]`` for ``r < done``. ``done`` is
    ``n_records`` unless record ``done`` runs past the end of ``data`` or has a
    count below the least one (a negative count, a face of two corners); the
    later starts are then 0.

    Preconditions: counts are 1, 2 or 4 bytes; ``0 <= start <= len(data)``.
    """
    starts = np.zeros(n_records + 1, dtype=np.int64)
    end = data.shape[0]
    pos = start
    starts[0] = pos
    for r in range(n_records):
        for k in range(props.shape[0]):
            width = props[k, 0]
            if width == 0:
                pos += props[k, 1]
                continue
            if pos + width > end:
                return starts, r
            count = 0
            for b in range(width):
                byte = data[pos + b] if big_endian else data[pos + width - 1 - b]
                count = count * 256 + np.int64(byte)
            if props[k, 2] != 0 and count >= np.int64(1) << (8 * width - 1):
                count -= np.int64(1) << (8 * width)
            if count < props[k, 3]:
                return starts, r
            pos += width + count * props[k, 1]
        if pos > end:
            return starts, r
        starts[r + 1] = pos
    return starts, n_records
