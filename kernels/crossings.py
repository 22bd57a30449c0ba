"""Kernels computing (edge, layer) crossing points and (face, layer) segments.

The layer ranges are computed with numpy beforehand (one ``searchsorted`` per
vertex, counts, cumulative sums); these kernels fill the per-crossing and per-segment
arrays in one pass, each edge or face writing its own slice (count, scan, fill).
Serial: slicing itself takes the fused kernels of :mod:`.contours`; these are the
plain pipeline its tests compare against.
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1_1D_OUT, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .loops import pair_open_ends

# (down edge, up edge) for each above-code (bit j set: vertex j above the plane).
# The down edge j runs from an above vertex j to a below vertex j + 1, the up edge the
# other way round; a segment runs from the down crossing to the up crossing, which
# makes outer loops counter-clockwise seen from +z for outward-wound faces.
DOWN_EDGE = (0, 0, 1, 1, 2, 0, 2, 0)
UP_EDGE = (0, 2, 0, 2, 1, 1, 0, 0)


@kernel(inline="always")
def _round_div(num, den):
    """Num / den rounded to nearest, ties away from zero (den > 0; Python floor //)."""
    q = num // den
    r2 = 2 * (num - q * den)
    if r2 > den or (r2 == den and num >= 0):
        q += 1
    return q


@kernel(
    I64_2D_OUT(I64_2D, I64_2D, I64_1D, I64_1D, I64_1D),
)
def crossing_points(vertices, edge_vertices, vert_layer, edge_offsets, z):
    """The crossing point of every edge with every plane it crosses.

    Edge ``e`` (oriented from its lower to its upper end a -> b) crosses the planes
    ``k`` with ``za <= z[k] < zb``; its crossings are rows
    ``edge_offsets[e]:edge_offsets[e + 1]`` of the result, in increasing ``k``. The
    point is ``a.xy + round((b.xy - a.xy) * (z - za) / (zb - za))``: the offset from
    the lower end a, rounded once, half away from zero, in exact integer
    arithmetic (the same as rounding the point itself except at an exact tie
    where point and offset have opposite signs; rounding the offset keeps
    slicing translation-invariant).

    Preconditions: ``z`` sorted; ``vert_layer[v]`` is the number of planes strictly
    below vertex ``v``; ``edge_offsets`` is the cumulative sum of
    ``|vert_layer[a] - vert_layer[b]|``; |coordinates| < 2**30.
    """
    n_edges = edge_vertices.shape[0]
    out = np.empty((edge_offsets[n_edges], 2), dtype=np.int64)
    for e in range(n_edges):
        start = edge_offsets[e]
        stop = edge_offsets[e + 1]
        if stop == start:
            continue
        a = edge_vertices[e, 0]
        b = edge_vertices[e, 1]
        if vertices[a, 2] > vertices[b, 2]:
            a, b = b, a
        xa = vertices[a, 0]
        ya = vertices[a, 1]
        za = vertices[a, 2]
        dx = vertices[b, 0] - xa
        dy = vertices[b, 1] - ya
        dz = vertices[b, 2] - za
        k0 = vert_layer[a]
        for i in range(start, stop):
            t = z[k0 + i - start] - za
            out[i, 0] = xa + _round_div(dx * t, dz)
            out[i, 1] = ya + _round_div(dy * t, dz)
    return out


@kernel(
    types.Tuple((I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, I64_1D_OUT, B1_1D_OUT))(
        I64_2D, I64_2D, I64_1D, I64_1D, I64_1D, I64_1D
    ),
)
def face_segments(faces, face_edges, vert_layer, edge_base, face_offsets, twin):
    """One directed segment per (face, plane) pair, and its successor.

    Face ``f`` meets the planes ``k`` with ``min(vert_layer) <= k < max(vert_layer)``
    over its vertices; its segments are ``face_offsets[f]:face_offsets[f + 1]`` of the
    results ``(seg_from, seg_to, seg_layer, next, has_prev)``. A segment runs from
    the crossing on the edge where the face goes from above to below the plane to
    the crossing where it goes back up; the crossing of edge ``e`` with plane ``k``
    has id ``edge_base[e] + k``. A vertex is above plane ``k`` iff
    ``k < vert_layer[v]`` (a vertex on the plane counts as below).

    Where the edge a segment ends on has a twin half-edge (a closed, consistently
    wound edge), its successor ``next`` is the twin face's segment on the same
    plane: no search. The remaining ends (open, non-manifold or inconsistently
    wound edges) are paired by :func:`pair_open_ends`. ``next`` is -1 where a chain
    ends and is injective.

    Preconditions: as :func:`crossing_points`; ``face_edges`` and ``twin`` from
    ``edge_topology``; ``face_offsets`` the cumulative sum of the per-face counts.
    """
    n_faces = faces.shape[0]
    n_seg = face_offsets[n_faces]
    seg_from = np.empty(n_seg, dtype=np.int64)
    seg_to = np.empty(n_seg, dtype=np.int64)
    seg_layer = np.empty(n_seg, dtype=np.int64)
    nxt = np.full(n_seg, -1, dtype=np.int64)
    has_prev = np.zeros(n_seg, dtype=np.bool_)
    open_in = np.zeros(n_seg, dtype=np.bool_)
    open_out = np.zeros(n_seg, dtype=np.bool_)
    down_of = np.array(DOWN_EDGE, dtype=np.int64)
    up_of = np.array(UP_EDGE, dtype=np.int64)
    for f in range(n_faces):
        start = face_offsets[f]
        stop = face_offsets[f + 1]
        if stop == start:
            continue
        l0 = vert_layer[faces[f, 0]]
        l1 = vert_layer[faces[f, 1]]
        l2 = vert_layer[faces[f, 2]]
        k = min(l0, min(l1, l2))
        for i in range(start, stop):
            code = (1 if k < l0 else 0) + (2 if k < l1 else 0) + (4 if k < l2 else 0)
            jd = down_of[code]
            ju = up_of[code]
            seg_from[i] = edge_base[face_edges[f, jd]] + k
            seg_to[i] = edge_base[face_edges[f, ju]] + k
            seg_layer[i] = k
            tw = twin[3 * f + ju]
            if tw >= 0:
                g = tw // 3
                lo_g = min(vert_layer[faces[g, 0]],
                           min(vert_layer[faces[g, 1]], vert_layer[faces[g, 2]]))
                t = face_offsets[g] + k - lo_g
                nxt[i] = t
                has_prev[t] = True
            else:
                open_in[i] = True
            if twin[3 * f + jd] < 0:
                open_out[i] = True
            k += 1
    pair_open_ends(seg_from, seg_to, open_in, open_out, nxt, has_prev)
    return seg_from, seg_to, seg_layer, nxt, has_prev


@kernel(I64_1D_OUT(I64_1D, I64_2D))
def range_offsets(vert_layer, elements):
    """Offsets of the ragged (element, plane) ranges of edges or faces.

    Element ``i`` (a row of vertex ids) meets the planes
    ``min(vert_layer[row]) <= k < max(vert_layer[row])``; returns the cumulative
    sum of the range lengths with a leading 0.
    """
    n = elements.shape[0]
    out = np.empty(n + 1, dtype=np.int64)
    out[0] = 0
    for i in range(n):
        lo = vert_layer[elements[i, 0]]
        hi = lo
        for j in range(1, elements.shape[1]):
            x = vert_layer[elements[i, j]]
            lo = min(lo, x)
            hi = max(hi, x)
        out[i + 1] = out[i] + hi - lo
    return out
