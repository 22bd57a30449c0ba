"""Kernels linking (face, layer) segments into loops and open chains."""

import numpy as np
from numba import njit, types

from ._types import B1_1D_OUT, I64, I64_1D, I64_1D_OUT

_LINK_OUT = types.Tuple(
    (I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT)
)


@njit(types.Tuple((I64_1D_OUT, B1_1D_OUT))(I64_1D, I64_1D, I64), cache=True, nogil=True)
def successors(seg_from, seg_to, n_crossings):
    """Successor of each segment through the crossing it ends at.

    At a crossing where exactly one segment ends and one starts (every crossing of a
    closed edge-manifold mesh) they are joined. Where several end or start (a
    non-manifold edge, duplicate faces) the ``k``-th segment ending there, by
    segment index, is joined to the ``k``-th starting there; surplus ends stay
    unjoined. Returns ``next`` (-1 where a chain ends) and ``has_prev``. ``next`` is
    injective: every segment has at most one predecessor.

    Preconditions: 0 <= seg_from, seg_to < n_crossings.
    """
    n_seg = seg_from.shape[0]
    n_out = np.zeros(n_crossings, dtype=np.int64)
    n_in = np.zeros(n_crossings, dtype=np.int64)
    first_out = np.full(n_crossings, -1, dtype=np.int64)
    for s in range(n_seg):
        c = seg_from[s]
        if n_out[c] == 0:
            first_out[c] = s
        n_out[c] += 1
        n_in[seg_to[s]] += 1
    nxt = np.full(n_seg, -1, dtype=np.int64)
    has_prev = np.zeros(n_seg, dtype=np.bool_)
    n_special = 0
    for s in range(n_seg):
        c = seg_to[s]
        if n_in[c] == 1 and n_out[c] == 1:
            t = first_out[c]
            nxt[s] = t
            has_prev[t] = True
        elif n_out[c] > 0:
            n_special += 1
    if n_special == 0:
        return nxt, has_prev
    # crossings shared by several segments: pair the k-th in with the k-th out
    out_off = np.zeros(n_crossings + 1, dtype=np.int64)
    for c in range(n_crossings):
        k = n_out[c] if not (n_in[c] == 1 and n_out[c] == 1) else 0
        out_off[c + 1] = out_off[c] + k
    out_items = np.empty(out_off[n_crossings], dtype=np.int64)
    fill = out_off[:-1].copy()
    for s in range(n_seg):
        c = seg_from[s]
        if fill[c] < out_off[c + 1]:
            out_items[fill[c]] = s
            fill[c] += 1
    used_in = np.zeros(n_crossings, dtype=np.int64)
    for s in range(n_seg):
        c = seg_to[s]
        if n_in[c] == 1 and n_out[c] == 1:
            continue
        k = used_in[c]
        used_in[c] += 1
        if k < out_off[c + 1] - out_off[c]:
            t = out_items[out_off[c] + k]
            nxt[s] = t
            has_prev[t] = True
    return nxt, has_prev


@njit(_LINK_OUT(I64_1D, I64_1D, I64_1D, I64), cache=True, nogil=True)
def link_segments(seg_from, seg_to, seg_layer, n_crossings):
    """Link directed segments into closed loops and open chains.

    A segment runs from crossing ``seg_from[s]`` to crossing ``seg_to[s]`` on layer
    ``seg_layer[s]``. Returns, with vertices as crossing ids, ``(closed_vertices,
    closed_ring_offsets, closed_ring_layer, open_vertices, open_ring_offsets,
    open_ring_layer)``. A closed loop of n segments has n vertices (its first is not
    repeated); an open chain of n segments has n + 1. Rings come in the order of
    their first segment; open chains start where no segment ends. Rings are not
    grouped by layer (the caller sorts them).

    Preconditions: 0 <= seg_from, seg_to < n_crossings; both crossings of a segment
    belong to its layer.
    """
    n_seg = seg_from.shape[0]
    nxt, has_prev = successors(seg_from, seg_to, n_crossings)
    visited = np.zeros(n_seg, dtype=np.bool_)
    n_open = 0
    for s in range(n_seg):
        if not has_prev[s]:
            n_open += 1
    o_verts = np.empty(n_seg + n_open, dtype=np.int64)
    o_rings = np.zeros(n_open + 1, dtype=np.int64)
    o_layer = np.empty(n_open, dtype=np.int64)
    nov = 0
    nor = 0
    for s in range(n_seg):
        if has_prev[s]:
            continue
        t = s
        last = s
        while t >= 0:
            visited[t] = True
            o_verts[nov] = seg_from[t]
            nov += 1
            last = t
            t = nxt[t]
        o_verts[nov] = seg_to[last]
        nov += 1
        o_layer[nor] = seg_layer[s]
        nor += 1
        o_rings[nor] = nov

    c_verts = np.empty(n_seg + n_open - nov, dtype=np.int64)
    c_rings = np.zeros(c_verts.shape[0] + 1, dtype=np.int64)
    c_layer = np.empty(c_verts.shape[0], dtype=np.int64)
    ncv = 0
    ncr = 0
    for s in range(n_seg):
        if visited[s]:
            continue
        t = s
        while not visited[t]:
            visited[t] = True
            c_verts[ncv] = seg_from[t]
            ncv += 1
            t = nxt[t]
            if t < 0:
                raise RuntimeError("link_segments: a cycle without a successor")
        c_layer[ncr] = seg_layer[s]
        ncr += 1
        c_rings[ncr] = ncv
    return (
        c_verts, c_rings[: ncr + 1].copy(), c_layer[:ncr].copy(),
        o_verts[:nov].copy(), o_rings, o_layer,
    )
