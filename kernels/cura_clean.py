"""Kernels of CuraEngine's per-layer clean-up that differ for open paths (compat mode).

``spec/CURA_COMPAT.md`` section 4, steps 7, 9 and 10: the length of a path without
its closing segment (explicitly closed polygons and open polylines), and
``removeDegenerateVerts`` for open polylines (closed polygons use
``simplify.remove_degenerate_vertices``).
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .geometry import vsize
from .simplify import _reverses


@kernel(I64_1D_OUT(I64_2D, I64_1D))
def path_lengths(coords, ring_offsets):
    """Length of each path without a closing segment: the sum of ``vsize`` (rounded).

    CuraEngine's ``polylineLength``, and its perimeter of an explicitly closed
    polygon (whose last point already repeats the first). 0 for < 2 vertices.
    """
    n = ring_offsets.shape[0] - 1
    out = np.zeros(n, dtype=np.int64)
    for r in range(n):
        acc = 0
        for i in range(ring_offsets[r] + 1, ring_offsets[r + 1]):
            acc += vsize(coords[i, 0] - coords[i - 1, 0],
                         coords[i, 1] - coords[i - 1, 1])
        out[r] = acc
    return out


@kernel(types.Tuple((I64_2D_OUT, I64_1D_OUT))(I64_2D, I64_1D))
def remove_degenerate_polyline_vertices(coords, ring_offsets):
    """CuraEngine's ``removeDegenerateVerts`` for open polylines.

    The first and last vertex are kept; vertices 1 .. n-2 are scanned with the
    output as a stack: vertex ``now`` is dropped when ``dot(now - last, next -
    now) == -vsize(now - last) * vsize(next - now)`` (``last`` = top of the stack,
    ``next`` = the following input vertex), and after a drop the stack is popped
    while it holds two or more vertices and its top is degenerate towards
    ``next``. Polylines are never deleted. Returns ``(coords, ring_offsets)``,
    one output path per input path.
    """
    n_paths = ring_offsets.shape[0] - 1
    out = np.empty((coords.shape[0], 2), np.int64)
    offsets = np.zeros(n_paths + 1, np.int64)
    j = 0
    for r in range(n_paths):
        start = ring_offsets[r]
        n = ring_offsets[r + 1] - start
        if n < 3:
            for k in range(n):
                out[j + k, 0] = coords[start + k, 0]
                out[j + k, 1] = coords[start + k, 1]
            j += n
            offsets[r + 1] = j
            continue
        out[j, 0] = coords[start, 0]
        out[j, 1] = coords[start, 1]
        top = 1
        for idx in range(1, n - 1):
            lx = out[j + top - 1, 0]
            ly = out[j + top - 1, 1]
            cx = coords[start + idx, 0]
            cy = coords[start + idx, 1]
            nx = coords[start + idx + 1, 0]
            ny = coords[start + idx + 1, 1]
            if _reverses(lx, ly, cx, cy, nx, ny):
                while top > 1 and _reverses(
                    out[j + top - 2, 0], out[j + top - 2, 1],
                    out[j + top - 1, 0], out[j + top - 1, 1], nx, ny,
                ):
                    top -= 1
            else:
                out[j + top, 0] = cx
                out[j + top, 1] = cy
                top += 1
        out[j + top, 0] = coords[start + n - 1, 0]
        out[j + top, 1] = coords[start + n - 1, 1]
        top += 1
        j += top
        offsets[r + 1] = j
    return out[:j].copy(), offsets
