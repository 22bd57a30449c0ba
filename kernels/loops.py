"""Kernels linking (face, layer) segments into loops and open chains."""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1_1D, B1_1D_W, I64_1D, I64_1D_OUT, I64_1D_W

_LINK_OUT = types.Tuple(
    (I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT)
)


@kernel(
    types.void(I64_1D, I64_1D, B1_1D, B1_1D, I64_1D_W, B1_1D_W),
)
def pair_open_ends(seg_from, seg_to, open_in, open_out, out_next, out_has_prev):
    """Join segments at crossings that topology alone does not pair.

    Among the segments flagged ``open_in`` (their end lies on an edge without a
    twin) and ``open_out`` (their start does), the ``k``-th segment ending at a
    crossing, by segment index, is joined to the ``k``-th starting there; surplus
    ends stay unjoined. Writes ``out_next`` and ``out_has_prev`` in place.

    Preconditions: crossing ids of open ends never meet twin-paired segments
    (all half-edges of an edge are twinned or none is).
    """
    ins = np.flatnonzero(open_in)
    outs = np.flatnonzero(open_out)
    if ins.shape[0] == 0 or outs.shape[0] == 0:
        return
    key_in = seg_to[ins]
    key_out = seg_from[outs]
    order_in = np.argsort(key_in, kind="mergesort")
    order_out = np.argsort(key_out, kind="mergesort")
    i = 0
    o = 0
    while i < ins.shape[0] and o < outs.shape[0]:
        ci = key_in[order_in[i]]
        co = key_out[order_out[o]]
        if ci < co:
            i += 1
        elif co < ci:
            o += 1
        else:
            s = ins[order_in[i]]
            t = outs[order_out[o]]
            out_next[s] = t
            out_has_prev[t] = True
            i += 1
            o += 1


@kernel(_LINK_OUT(I64_1D, B1_1D, I64_1D, I64_1D, I64_1D))
def link_segments(nxt, has_prev, seg_from, seg_to, seg_layer):
    """Link directed segments into closed loops and open chains.

    A segment runs from crossing ``seg_from[s]`` to crossing ``seg_to[s]`` on layer
    ``seg_layer[s]``; ``nxt[s]`` is its successor. Returns, with vertices as
    crossing ids, ``(closed_vertices, closed_ring_offsets, closed_ring_layer,
    open_vertices, open_ring_offsets,
    open_ring_layer)``. A closed loop of n segments has n vertices (its first is not
    repeated); an open chain of n segments has n + 1. Rings come in the order of
    their first segment; open chains start where no segment ends. Rings are not
    grouped by layer (the caller sorts them).

    ``nxt`` is the successor of each segment (-1 where a chain ends) and
    ``has_prev`` whether some segment has it as successor.

    Preconditions: ``nxt`` injective and consistent with ``has_prev`` (as
    ``face_segments`` makes it); a segment and its successor share a layer.
    """
    n_seg = seg_from.shape[0]
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
