"""Kernels joining open chains exactly as CuraEngine's slicer does (compat mode).

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

from ._jit import kernel
from ._types import B1, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .chain_ends import match_ends

_W = types.int64[::1]
_W2 = types.int64[:, ::1]
_INVALID = -1

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
    i = 0
    for p in range(c0, c1):
        if st[p, 2] == 0:
            continue
        for end in range(2):
            v = _end_row(ring_offsets, st, p, end)
            term[i, 0] = p - c0
            term[i, 1] = end
            term[i, 2] = coords[v, 0]
            term[i, 3] = coords[v, 1]
            i += 1
    # The stitches taken (both termini still valid, by ascending key) are the
    # greedy matching of the termini: each one consumes exactly its two termini.
    # Per terminus the key orders its partners by (gap², reversed, polyline),
    # as match_ends does (polyline = group id, end = role), so only the pairs
    # taken are found, in O(n log n) however the ends crowd, then sorted.
    pairs = match_ends(np.ascontiguousarray(term[:, 2:4]),
                       np.ascontiguousarray(term[:, 0]),
                       np.ascontiguousarray(term[:, 1]), gap2, allow_reverse)
    m = pairs.shape[0]
    if m == 0:
        return n_closed
    cand = np.empty((m, 4), dtype=np.int64)
    for k in range(m):
        a, b = pairs[k, 0], pairs[k, 1]
        # as CuraEngine lists it: an end then a start, or the lower polyline first
        if (term[a, 1] == 0 and term[b, 1] == 1) or (
            term[a, 1] == term[b, 1] and term[a, 0] > term[b, 0]
        ):
            a, b = b, a
        dx = term[b, 2] - term[a, 2]
        dy = term[b, 3] - term[a, 3]
        cand[k, 0] = dx * dx + dy * dy
        cand[k, 1] = 0 if term[a, 1] != term[b, 1] else 1
        cand[k, 2] = 2 * term[a, 0] + term[a, 1]
        cand[k, 3] = 2 * term[b, 0] + term[b, 1]
    n_local = 2 * (c1 - c0)
    old_to_cur = np.arange(n_local)
    cur_to_old = np.arange(n_local)
    olds = np.empty(4, dtype=np.int64)
    cur = np.empty(4, dtype=np.int64)
    nxt = np.empty(4, dtype=np.int64)
    for k in _stitch_order(cand):
        t0 = old_to_cur[cand[k, 2]]
        t1 = old_to_cur[cand[k, 3]]
        if t0 == _INVALID or t1 == _INVALID:  # cannot happen: a matching
            raise RuntimeError("connect_open_polylines: a matched terminus is gone")
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

    CuraEngine's grid ``cell`` only pre-filters its candidates, so the result
    does not depend on it (it is not used). Cost: O(n log n) per call for n
    polylines, however their ends crowd: the stitches taken are the greedy
    matching of the termini (:func:`.chain_ends.match_ends`), so the other
    candidates are never listed.

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
