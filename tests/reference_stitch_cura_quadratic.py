"""Reference for ``kernels/cura_stitch.py``: that kernel before issue 8 (A3).

Kept verbatim (only its imports changed) as the reference the new kernel must
equal on every input. It lists every possible stitch closer than the gap and sorts
them: O(n**2) time and memory when n ends crowd within one gap. Use it on small or
sparse inputs only. The original module docstring follows.

Kernels joining open chains exactly as CuraEngine's slicer does (compat mode).

* :func:`connect_open_polylines` -- ``connectOpenPolylinesImpl``, used by
  ``SlicerLayer::makePolygons`` twice (``spec/CURA_COMPAT.md`` section 4.1).

Unlike :mod:`.stitch` (vecslice's own rules), joints are not de-duplicated, sizes
count every vertex, termini are tracked CuraEngine's way and closed polygons come
out in the order they closed. A polyline is a doubly linked list of the input
chains it is made of (``nxt``, ``prv``, ``flip`` = traversed backwards); joining two
is O(1) and reversing walks the chains of the one reversed.
"""

import numpy as np
from numba import types

from vecslice._kernels._jit import kernel
from vecslice._kernels._types import B1, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT

_W = types.int64[::1]
_W2 = types.int64[:, ::1]
_INVALID = -1
_CELL_OFF = 2**30  # cell + offset in [1, 2**31) for |coords| < 2**30
_CELL_MUL = 2**31  # (x cell) * 2**31 + (y cell) < 2**62: no overflow

_CONNECT_OUT = types.Tuple(
    (I64_2D_OUT, I64_1D_OUT, I64_1D_OUT, I64_2D_OUT, I64_1D_OUT, I64_1D_OUT,
     I64_1D_OUT)
)


@kernel(inline="always")
def _first_row(ring_offsets, c, flipped):
    """Row of chain ``c``'s first vertex as traversed."""
    return ring_offsets[c + 1] - 1 if flipped else ring_offsets[c]


@kernel(inline="always")
def _last_row(ring_offsets, c, flipped):
    """Row of chain ``c``'s last vertex as traversed."""
    return ring_offsets[c] if flipped else ring_offsets[c + 1] - 1


@kernel(inline="always")
def _end_row(ring_offsets, st, p, end):
    """Row in ``coords`` of polyline ``p``'s start (end 0) or end (end 1)."""
    if end == 0:
        h = st[p, 0]
        return _first_row(ring_offsets, h, st[h, 5] == 1)
    t = st[p, 1]
    return _last_row(ring_offsets, t, st[t, 5] == 1)


# state table columns: 0 head chain, 1 tail chain, 2 size (0: empty), 3 nxt,
# 4 prv, 5 flip (chain columns 3-5 belong to the chain, 0-2 to the polyline slot)


@kernel(types.void(_W2, I64))
def _reverse(st, p):
    """Reverse polyline ``p`` in place (walks its chains)."""
    c = st[p, 0]
    while c >= 0:
        n = st[c, 3]
        st[c, 3] = st[c, 4]
        st[c, 4] = n
        st[c, 5] = 1 - st[c, 5]
        c = n
    h = st[p, 0]
    st[p, 0] = st[p, 1]
    st[p, 1] = h


@kernel(types.void(_W2, I64, I64))
def _append(st, p0, p1):
    """Append polyline ``p1`` to ``p0`` (every vertex kept); ``p1`` becomes empty."""
    t = st[p0, 1]
    h = st[p1, 0]
    st[t, 3] = h
    st[h, 4] = t
    st[p0, 1] = st[p1, 1]
    st[p0, 2] += st[p1, 2]
    st[p1, 2] = 0


@kernel(I64(I64_2D, I64_1D, _W2, I64, I64_2D_OUT, I64))
def _emit(coords, ring_offsets, st, p, out, pos):
    """Write polyline ``p``'s vertices to ``out[pos:]``; return the count."""
    w = 0
    c = st[p, 0]
    while c >= 0:
        a = ring_offsets[c]
        b = ring_offsets[c + 1]
        flipped = st[c, 5] == 1
        for k in range(b - a):
            v = b - 1 - k if flipped else a + k
            out[pos + w, 0] = coords[v, 0]
            out[pos + w, 1] = coords[v, 1]
            w += 1
        c = st[c, 3]
    return w


@kernel(I64(I64_2D, I64_2D, I64, I64, B1, I64_2D_OUT, B1))
def _candidates(term, cells, cell, gap2, allow_reverse, out, fill):
    """Count (or, with ``fill``, write) the possible stitches between termini.

    ``term`` rows: (polyline, end, x, y); ``cells`` = (cell key, terminus) sorted.
    A stitch is (end of P0 -> start of P1) for any P0, P1 (P0 == P1 closes it),
    and with ``allow_reverse`` (end, end) and (start, start) with P0 < P1; its
    squared gap must be ``< gap2``. Rows of ``out``: gap², reversed, t0, t1 with
    ``t = 2 * polyline + end``.
    """
    n = term.shape[0]
    keys = np.ascontiguousarray(cells[:, 0])
    m = 0
    for q in range(n):
        qx = term[q, 2]
        qy = term[q, 3]
        cx = qx // cell + _CELL_OFF
        cy = qy // cell + _CELL_OFF
        for dx in range(-1, 2):
            row = (cx + dx) * _CELL_MUL
            lo = np.searchsorted(keys, row + cy - 1, side="left")
            hi = np.searchsorted(keys, row + cy + 1, side="right")
            for k in range(lo, hi):
                r = cells[k, 1]
                ddx = term[r, 2] - qx
                ddy = term[r, 3] - qy
                d2 = ddx * ddx + ddy * ddy
                if d2 >= gap2:
                    continue
                in_order = term[q, 1] == 1 and term[r, 1] == 0
                rev = (allow_reverse and term[q, 1] == term[r, 1]
                       and term[q, 0] < term[r, 0])
                if not (in_order or rev):
                    continue
                if fill:
                    out[m, 0] = d2
                    out[m, 1] = 0 if in_order else 1
                    out[m, 2] = 2 * term[q, 0] + term[q, 1]
                    out[m, 3] = 2 * term[r, 0] + term[r, 1]
                m += 1
    return m


@kernel(I64_1D_OUT(I64_2D_OUT))
def _stitch_order(cand):
    """Order of the stitches by (gap², reversed, t0, t1) ascending (stable passes)."""
    order = np.arange(cand.shape[0])
    for col in (3, 2, 1, 0):
        key = np.empty(cand.shape[0], dtype=np.int64)
        for k in range(cand.shape[0]):
            key[k] = cand[order[k], col]
        order = order[np.argsort(key, kind="mergesort")]
    return order


@kernel(types.void(_W, _W, I64))
def _mark_removed(old_to_cur, cur_to_old, t):
    """Terminus ``t`` (current) no longer exists."""
    old = cur_to_old[t]
    if old != _INVALID:
        old_to_cur[old] = _INVALID
    cur_to_old[t] = _INVALID


@kernel(
    I64(I64_2D, I64_1D, _W2, I64, I64, I64, I64, B1, _W, _W),
)
def _connect_round(coords, ring_offsets, st, c0, c1, max_dist, cell, allow_reverse,
                   closed, counts):
    """One ``connectOpenPolylinesImpl`` call on polylines ``c0:c1`` (one layer).

    Polylines that close are appended to ``closed`` (``counts[0]`` of them so
    far); ``counts[1]`` counts the stitches made. Returns ``counts[0]``.
    """
    n_closed = counts[0]
    n_term = 0
    for p in range(c0, c1):
        if st[p, 2] > 0:
            n_term += 2
    if n_term == 0 or max_dist <= 0:
        return n_closed
    gap2 = max_dist * max_dist
    term = np.empty((n_term, 4), dtype=np.int64)
    cells = np.empty((n_term, 2), dtype=np.int64)
    i = 0
    for p in range(c0, c1):
        if st[p, 2] == 0:
            continue
        for end in range(2):
            v = _end_row(ring_offsets, st, p, end)
            x = coords[v, 0]
            y = coords[v, 1]
            term[i, 0] = p - c0
            term[i, 1] = end
            term[i, 2] = x
            term[i, 3] = y
            cells[i, 0] = (x // cell + _CELL_OFF) * _CELL_MUL + y // cell + _CELL_OFF
            cells[i, 1] = i
            i += 1
    cells = cells[np.argsort(cells[:, 0], kind="mergesort")]
    m = _candidates(term, cells, cell, gap2, allow_reverse,
                    np.empty((0, 4), dtype=np.int64), False)
    if m == 0:
        return n_closed
    cand = np.empty((m, 4), dtype=np.int64)
    _candidates(term, cells, cell, gap2, allow_reverse, cand, True)
    n_local = 2 * (c1 - c0)
    old_to_cur = np.arange(n_local)
    cur_to_old = np.arange(n_local)
    olds = np.empty(4, dtype=np.int64)
    cur = np.empty(4, dtype=np.int64)
    nxt = np.empty(4, dtype=np.int64)
    for k in _stitch_order(cand):
        t0 = old_to_cur[cand[k, 2]]
        t1 = old_to_cur[cand[k, 3]]
        if t0 == _INVALID or t1 == _INVALID:
            continue
        p0 = t0 >> 1
        p1 = t1 >> 1
        counts[1] += 1
        if p0 == p1:
            closed[n_closed] = c0 + p0
            n_closed += 1
            counts[0] = n_closed
            st[c0 + p0, 2] = 0
            _mark_removed(old_to_cur, cur_to_old, t0)
            _mark_removed(old_to_cur, cur_to_old, t1)
            continue
        rev0 = False
        rev1 = False
        s0 = st[c0 + p0, 2]
        s1 = st[c0 + p1, 2]
        if t0 & 1:
            if t1 & 1:  # end to end: the smaller is reversed and appended
                if s0 < s1:
                    t0, t1 = t1, t0
                rev1 = True
        elif t1 & 1:  # start to end: in order the other way round
            t0, t1 = t1, t0
        else:  # start to start: the smaller is reversed, then the other appended
            if s0 > s1:
                t0, t1 = t1, t0
            rev0 = True
        p0 = t0 >> 1
        p1 = t1 >> 1
        if rev0:
            _reverse(st, c0 + p0)
        if rev1:
            _reverse(st, c0 + p1)
        _append(st, c0 + p0, c0 + p1)
        cur[0] = 2 * p0
        cur[1] = 2 * p0 + 1
        cur[2] = 2 * p1
        cur[3] = 2 * p1 + 1
        nxt[0] = 2 * p0
        nxt[1] = _INVALID
        nxt[2] = _INVALID
        nxt[3] = 2 * p0 + 1
        if rev0:
            nxt[0], nxt[1] = nxt[1], nxt[0]
        if rev1:
            nxt[2], nxt[3] = nxt[3], nxt[2]
        for j in range(4):
            olds[j] = cur_to_old[cur[j]]
        for j in range(4):
            if olds[j] != _INVALID:
                old_to_cur[olds[j]] = nxt[j]
        for j in range(4):
            if nxt[j] != _INVALID:
                cur_to_old[nxt[j]] = olds[j]
        cur_to_old[2 * p1] = _INVALID
        cur_to_old[2 * p1 + 1] = _INVALID
    return n_closed


@kernel(_CONNECT_OUT(I64_2D, I64_1D, I64_1D, I64_2D))
def connect_open_polylines(coords, ring_offsets, layer_offsets, rounds):
    """CuraEngine's ``connectOpenPolylinesImpl`` on the open chains of each layer.

    Chain ``i`` is ``coords[ring_offsets[i]:ring_offsets[i + 1]]``; layer ``k``
    holds chains ``layer_offsets[k]:layer_offsets[k + 1]`` in CuraEngine's order
    (polyline index = position in the layer). Each row of ``rounds`` is one call
    ``(max_dist, cell, allow_reverse)``: CuraEngine's slicer runs (20, 20, 0) then
    (10000, 10000, 1).

    Per call: the possible stitches (squared gap ``< max_dist**2``) are an end to
    a start (a polyline's own included: it closes), and with ``allow_reverse`` end
    to end and start to start of two polylines; they are taken by ascending
    (gap², reversed, t0, t1), ``t = 2 * polyline + is_end`` as at the start of the
    call, through CuraEngine's terminus tracking map (a stitch whose terminus was
    consumed is skipped). Both termini on one polyline: it closes (moves to the
    layer's polygons; the polyline becomes empty). Otherwise end+start appends the
    second; end+end reverses the smaller (tie: the second) and appends it;
    start+start reverses the smaller (tie: the first) and appends the other to it.
    Joints keep both vertices.

    Returns ``(closed_coords, closed_ring_offsets, closed_layer_offsets,
    open_coords, open_ring_offsets, open_layer_offsets, stitched)``: per layer the
    closed polygons in the order they closed, then the polylines still open, by
    index; ``stitched[k]`` counts the joins and closures of layer ``k``.

    Preconditions: |coords| < 2**30; offsets valid; ``0 <= max_dist <= 2**31``,
    ``cell >= 1``.
    """
    n = ring_offsets.shape[0] - 1
    n_layers = layer_offsets.shape[0] - 1
    st = np.empty((n, 6), dtype=np.int64)
    for c in range(n):
        st[c, 0] = c
        st[c, 1] = c
        st[c, 2] = ring_offsets[c + 1] - ring_offsets[c]
        st[c, 3] = -1
        st[c, 4] = -1
        st[c, 5] = 0
    closed = np.empty(n, dtype=np.int64)
    closed_layer = np.zeros(n_layers + 1, dtype=np.int64)
    stitched = np.zeros(n_layers, dtype=np.int64)
    counts = np.zeros(2, dtype=np.int64)
    for k in range(n_layers):
        c0 = layer_offsets[k]
        c1 = layer_offsets[k + 1]
        counts[1] = 0
        for r in range(rounds.shape[0]):
            _connect_round(coords, ring_offsets, st, c0, c1, rounds[r, 0],
                           rounds[r, 1], rounds[r, 2] != 0, closed, counts)
        closed_layer[k + 1] = counts[0]
        stitched[k] = counts[1]
    n_closed = counts[0]
    # closed polygons (their slots were emptied, but their chain lists remain)
    n_cv = 0
    for i in range(n_closed):
        c = closed[i]
        w = 0
        h = st[c, 0]
        while h >= 0:
            w += ring_offsets[h + 1] - ring_offsets[h]
            h = st[h, 3]
        n_cv += w
    cl_coords = np.empty((n_cv, 2), dtype=np.int64)
    cl_rings = np.zeros(n_closed + 1, dtype=np.int64)
    for i in range(n_closed):
        cl_rings[i + 1] = cl_rings[i] + _emit(coords, ring_offsets, st, closed[i],
                                              cl_coords, cl_rings[i])
    op_layer = np.zeros(n_layers + 1, dtype=np.int64)
    n_ov = 0
    n_open = 0
    for k in range(n_layers):
        for c in range(layer_offsets[k], layer_offsets[k + 1]):
            if st[c, 2] > 0:
                n_open += 1
                n_ov += st[c, 2]
        op_layer[k + 1] = n_open
    op_coords = np.empty((n_ov, 2), dtype=np.int64)
    op_rings = np.zeros(n_open + 1, dtype=np.int64)
    j = 0
    for c in range(n):
        if st[c, 2] > 0:
            op_rings[j + 1] = op_rings[j] + _emit(coords, ring_offsets, st, c,
                                                  op_coords, op_rings[j])
            j += 1
    return (cl_coords, cl_rings, closed_layer, op_coords, op_rings, op_layer,
            stitched)
