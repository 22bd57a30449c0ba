"""Kernel of CuraEngine's open-polyline stitcher in ``createLayerWithParts`` (compat).

``spec/CURA_COMPAT.md`` section 6, step 1: the open polylines left after
``makePolygons`` are chained greedily, nearest endpoint first, into longer
polylines and (when a chain comes back to its start) closed polygons.
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .geometry import vsize

_OUT = types.Tuple(
    (I64_2D_OUT, I64_1D_OUT, I64_1D_OUT, I64_2D_OUT, I64_1D_OUT, I64_1D_OUT)
)
_CELL_OFF = 2**30  # cell + offset in [1, 2**31) for |coords| < 2**30
_CELL_MUL = 2**31  # (x cell) * 2**31 + (y cell) < 2**62: no overflow
_I64_MAX = 9223372036854775807


@kernel(inline="always")
def _endpoint_row(ring_offsets, e):
    """Row of endpoint ``e``: line ``e // 2``'s first (e even) or last vertex."""
    line = e >> 1
    return ring_offsets[line] if e & 1 == 0 else ring_offsets[line + 1] - 1


@kernel(
    I64(I64_2D, I64_1D, I64_1D, I64_2D, types.int64[:, ::1], I64, types.boolean[::1],
        types.int64[::1], I64),
)
def _closest(coords, ring_offsets, params, cells, chain, n_chain, used, scratch,
             chain_length):
    """Best endpoint to continue ``chain[:n_chain]`` from its last vertex.

    ``params`` = (first line of the layer, cell size, max_dist, snap). Returns
    ``2 * e + closing`` for the winner (``e`` an endpoint id within the layer), or
    -1. Candidates (endpoints in the cells around the chain's end) are visited by
    endpoint id: line by line, first vertex before last.
    """
    l0 = params[0]
    cell = params[1]
    max_dist = params[2]
    snap = params[3]
    fx = chain[n_chain - 1, 0]
    fy = chain[n_chain - 1, 1]
    keys = cells[:, 0]
    cx = fx // cell + _CELL_OFF
    cy = fy // cell + _CELL_OFF
    m = 0
    for dx in range(-1, 2):
        row = (cx + dx) * _CELL_MUL
        lo = np.searchsorted(keys, row + cy - 1, side="left")
        hi = np.searchsorted(keys, row + cy + 1, side="right")
        for k in range(lo, hi):
            scratch[m] = cells[k, 1]
            m += 1
    cand = np.sort(scratch[:m])
    best = -1
    best_dist = _I64_MAX
    best_closing = 0
    for i in range(m):
        e = cand[i]
        v = _endpoint_row(ring_offsets, 2 * l0 + e)
        px = coords[v, 0]
        py = coords[v, 1]
        dist = vsize(px - fx, py - fy)
        if dist > max_dist:
            continue
        closing = 0
        gx = px - chain[0, 0]
        gy = py - chain[0, 1]
        if gx * gx + gy * gy < snap * snap:
            if chain_length + dist < 3 * max_dist or n_chain <= 2:
                continue
            closing = 1
            dist += 10
        elif used[l0 + (e >> 1)]:
            continue
        if dist < best_dist:
            best_dist = dist
            best = e
            best_closing = closing
        if dist < snap:
            break
    if best < 0:
        return -1
    return 2 * best + best_closing


@kernel(_OUT(I64_2D, I64_1D, I64_1D, I64, I64))
def stitch_open_polylines(coords, ring_offsets, layer_offsets, max_dist, snap):
    """CuraEngine's ``OpenPolylineStitcher`` on the open polylines of each layer.

    Line ``i`` is ``coords[ring_offsets[i]:ring_offsets[i + 1]]``; layer ``k``
    holds lines ``layer_offsets[k]:layer_offsets[k + 1]``. Per layer, each unused
    line (by index) starts a chain, extended from its last vertex:

    * candidates are the first and last vertices of all lines of the layer within
      ``vsize <= max_dist`` of the chain's end, visited line by line (first vertex
      before last; CuraEngine visits its hash grid's order);
    * an endpoint with squared distance ``< snap**2`` to the chain's first vertex
      closes the chain, if the chain length + distance ``>= 3 * max_dist`` and the
      chain has > 2 vertices (else it is skipped); its distance counts 10 µm more;
    * other endpoints of used lines are skipped;
    * the smallest distance wins (first on a tie); one ``< snap`` stops the search;
    * the winner's line is appended (reversed if its last vertex won), without
      its first vertex if the gap is ``< snap``.

    When nothing is found, the chain is reversed and extended from its other end
    (a chain closed in that pass is reversed back). Closed chains end at the
    vertex before the closing gap (explicitly closed polygons); open chains keep
    the direction they ended with.

    Returns ``(closed_coords, closed_ring_offsets, closed_layer_offsets,
    open_coords, open_ring_offsets, open_layer_offsets)``.

    Preconditions: |coords| < 2**30; offsets valid; lines non-empty;
    ``1 <= max_dist < 2**31``, ``snap >= 0``.
    """
    n_lines = ring_offsets.shape[0] - 1
    n_layers = layer_offsets.shape[0] - 1
    n_v = coords.shape[0]
    cl_coords = np.empty((n_v, 2), dtype=np.int64)
    op_coords = np.empty((n_v, 2), dtype=np.int64)
    cl_rings = np.zeros(n_lines + 1, dtype=np.int64)
    op_rings = np.zeros(n_lines + 1, dtype=np.int64)
    cl_layer = np.zeros(n_layers + 1, dtype=np.int64)
    op_layer = np.zeros(n_layers + 1, dtype=np.int64)
    used = np.zeros(n_lines, dtype=np.bool_)
    n_cl = 0
    n_op = 0
    cell = max_dist
    for k in range(n_layers):
        l0 = layer_offsets[k]
        l1 = layer_offsets[k + 1]
        n_end = 2 * (l1 - l0)
        if n_end > 0:
            cells = np.empty((n_end, 2), dtype=np.int64)
            for e in range(n_end):
                v = _endpoint_row(ring_offsets, 2 * l0 + e)
                cells[e, 0] = ((coords[v, 0] // cell + _CELL_OFF) * _CELL_MUL
                               + coords[v, 1] // cell + _CELL_OFF)
                cells[e, 1] = e
            cells = cells[np.argsort(cells[:, 0], kind="mergesort")]
            scratch = np.empty(n_end, dtype=np.int64)
            params = np.array([l0, cell, max_dist, snap], dtype=np.int64)
            n_layer_v = ring_offsets[l1] - ring_offsets[l0]
            chain = np.empty((n_layer_v, 2), dtype=np.int64)
            for start in range(l0, l1):
                if used[start]:
                    continue
                used[start] = True
                n = 0
                for v in range(ring_offsets[start], ring_offsets[start + 1]):
                    chain[n, 0] = coords[v, 0]
                    chain[n, 1] = coords[v, 1]
                    n += 1
                closing = False
                for backwards in range(2):
                    if backwards == 1:
                        chain[:n] = chain[:n][::-1].copy()
                    length = 0
                    for i in range(1, n):
                        length += vsize(chain[i, 0] - chain[i - 1, 0],
                                        chain[i, 1] - chain[i - 1, 1])
                    while True:
                        r = _closest(coords, ring_offsets, params, cells, chain, n,
                                     used, scratch, length)
                        if r < 0:
                            break
                        if r & 1:
                            closing = True
                            break
                        e = r >> 1
                        line = l0 + (e >> 1)
                        a = ring_offsets[line]
                        b = ring_offsets[line + 1]
                        v = _endpoint_row(ring_offsets, 2 * l0 + e)
                        gap = vsize(chain[n - 1, 0] - coords[v, 0],
                                    chain[n - 1, 1] - coords[v, 1])
                        skip = 1 if gap < snap else 0
                        old = n
                        for i in range(skip, b - a):
                            src = a + i if e & 1 == 0 else b - 1 - i
                            chain[n, 0] = coords[src, 0]
                            chain[n, 1] = coords[src, 1]
                            n += 1
                        for i in range(max(old, 1), n):
                            length += vsize(chain[i, 0] - chain[i - 1, 0],
                                            chain[i, 1] - chain[i - 1, 1])
                        used[line] = True
                    if closing:
                        if backwards == 1:
                            chain[:n] = chain[:n][::-1].copy()
                        break
                if closing:
                    p = cl_rings[n_cl]
                    cl_coords[p:p + n] = chain[:n]
                    n_cl += 1
                    cl_rings[n_cl] = p + n
                else:
                    p = op_rings[n_op]
                    op_coords[p:p + n] = chain[:n]
                    n_op += 1
                    op_rings[n_op] = p + n
        cl_layer[k + 1] = n_cl
        op_layer[k + 1] = n_op
    return (cl_coords[:cl_rings[n_cl]].copy(), cl_rings[:n_cl + 1].copy(), cl_layer,
            op_coords[:op_rings[n_op]].copy(), op_rings[:n_op + 1].copy(), op_layer)
