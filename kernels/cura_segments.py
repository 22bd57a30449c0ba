"""Kernels computing CuraEngine's per-face slice segments (compat mode).

``spec/CURA_COMPAT.md`` section 3. Each face gives at most one segment per plane,
computed from the face's own vertex order with CuraEngine's biased ``interpolate``;
the two faces sharing an edge compute its crossing separately and may disagree by
a micron (CuraEngine's chaining tolerates gaps up to 10 µm).

Work is batched over (face, plane) *slots*: face ``f`` may cut the planes
``face_lo[f] <= k < face_lo[f] + n`` (``n = slot_offsets[f + 1] -
slot_offsets[f]``: the planes with ``zmin <= z < zmax``, found with one
``searchsorted``), and slot ``slot_offsets[f] + k - face_lo[f]`` holds its segment
on plane ``k`` or nothing (a vertex only touching the plane gives none).
"""

import numpy as np
from numba import prange, types

from ._jit import kernel
from ._types import B1_1D, B1_1D_OUT, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .geometry import tdiv

_SEG_OUT = types.Tuple((I64_2D_OUT, I64_2D_OUT, B1_1D_OUT))


@kernel(I64(I64, I64, I64, I64, I64))
def interpolate(x, x0, x1, y0, y1):
    """CuraEngine's ``interpolate``: y at x on the line (x0, y0)-(x1, y1), in µm.

    ``dx = x1 - x0``; ``num = (y1 - y0) * (x - x0)``, plus ``dx / 4`` if
    ``num > 0`` else minus ``dx / 4``; result ``y0 + num / dx``. Every division
    truncates toward zero, so the "rounding" bias is asymmetric when ``dx < 0``:
    ``interpolate(100, 10000, 0, 0, 10000) == 9899`` (exact: 9900).

    Preconditions: ``x1 != x0``; the product fits in int64 (|values| < 2**31).
    """
    dx = x1 - x0
    num = (y1 - y0) * (x - x0)
    if num > 0:
        num += tdiv(dx, 4)
    else:
        num -= tdiv(dx, 4)
    return y0 + tdiv(num, dx)


@kernel(inline="always")
def _edge_point(vertices, a, b, za, zb, z):
    """Point on the edge a -> b at height z (``za``, ``zb``: compensated z)."""
    x = interpolate(z, za, zb, vertices[a, 0], vertices[b, 0])
    y = interpolate(z, za, zb, vertices[a, 1], vertices[b, 1])
    return x, y


@kernel(
    _SEG_OUT(I64_2D, I64_2D, I64_2D, I64_1D, I64_1D, I64_1D, I64), parallel=True,
)
def slot_segments(vertices, faces, neighbours, z, face_lo, slot_offsets, comp_limit):
    """CuraEngine's segment of every (face, plane) slot.

    Returns ``(points, links, valid)`` per slot: ``points`` (S, 4) = start x, y,
    end x, y; ``links`` (S, 2) = ``endOtherFaceIdx`` (``neighbours[f, end edge]``)
    and ``endVertex`` (the vertex the end lies on, or -1); ``valid`` whether the
    slot has a segment.

    A vertex on the plane is moved 1 µm down first when the plane is below
    ``comp_limit`` (CuraEngine: ``z <= 0`` for a mesh on the bed; pass a very
    small value to disable, as CuraEngine's 'inclusive' mode does). Then the first
    matching row of CuraEngine's table, over the face's vertices p0, p1, p2:

    ====  ======================  =========  =======  =====  ==============
    row   condition               start on   end on   edge   endVertex
    ====  ======================  =========  =======  =====  ==============
    A     p0 < z, p1 > z, p2 > z  p0->p2     p0->p1   0
    B     p0 > z, p1 <= z, p2 <= z p0->p1    p0->p2   2      v2 if p2 == z
    C     p1 < z, p0 > z, p2 > z  p1->p0     p1->p2   1
    D     p1 > z, p0 <= z, p2 <= z p1->p2    p1->p0   0      v0 if p0 == z
    E     p2 < z, p1 > z, p0 > z  p2->p1     p2->p0   2
    F     p2 > z, p1 <= z, p0 <= z p2->p0    p2->p1   1      v1 if p1 == z
    ====  ======================  =========  =======  =====  ==============

    "Start on pX->pY" means ``interpolate(z, pX.z, pY.z, pX.x, pY.x)`` (and y).

    Preconditions: ``z`` sorted; ``face_lo`` and ``slot_offsets`` as in the module
    docstring; |coordinates| < 2**30.
    """
    n_faces = faces.shape[0]
    n_slots = slot_offsets[n_faces]
    points = np.empty((n_slots, 4), dtype=np.int64)
    links = np.empty((n_slots, 2), dtype=np.int64)
    valid = np.zeros(n_slots, dtype=np.bool_)
    for f in prange(n_faces):
        s0 = slot_offsets[f]
        s1 = slot_offsets[f + 1]
        if s1 == s0:
            continue
        v0 = faces[f, 0]
        v1 = faces[f, 1]
        v2 = faces[f, 2]
        for s in range(s0, s1):
            zz = z[face_lo[f] + s - s0]
            z0 = vertices[v0, 2]
            z1 = vertices[v1, 2]
            z2 = vertices[v2, 2]
            if zz < comp_limit:
                if z0 == zz:
                    z0 -= 1
                if z1 == zz:
                    z1 -= 1
                if z2 == zz:
                    z2 -= 1
            ev = -1
            if z0 < zz and z1 > zz and z2 > zz:  # A
                sx, sy = _edge_point(vertices, v0, v2, z0, z2, zz)
                ex, ey = _edge_point(vertices, v0, v1, z0, z1, zz)
                edge = 0
            elif z0 > zz and z1 <= zz and z2 <= zz:  # B
                sx, sy = _edge_point(vertices, v0, v1, z0, z1, zz)
                ex, ey = _edge_point(vertices, v0, v2, z0, z2, zz)
                edge = 2
                if z2 == zz:
                    ev = v2
            elif z1 < zz and z0 > zz and z2 > zz:  # C
                sx, sy = _edge_point(vertices, v1, v0, z1, z0, zz)
                ex, ey = _edge_point(vertices, v1, v2, z1, z2, zz)
                edge = 1
            elif z1 > zz and z0 <= zz and z2 <= zz:  # D
                sx, sy = _edge_point(vertices, v1, v2, z1, z2, zz)
                ex, ey = _edge_point(vertices, v1, v0, z1, z0, zz)
                edge = 0
                if z0 == zz:
                    ev = v0
            elif z2 < zz and z1 > zz and z0 > zz:  # E
                sx, sy = _edge_point(vertices, v2, v1, z2, z1, zz)
                ex, ey = _edge_point(vertices, v2, v0, z2, z0, zz)
                edge = 2
            elif z2 > zz and z1 <= zz and z0 <= zz:  # F
                sx, sy = _edge_point(vertices, v2, v0, z2, z0, zz)
                ex, ey = _edge_point(vertices, v2, v1, z2, z1, zz)
                edge = 1
                if z1 == zz:
                    ev = v1
            else:
                continue
            points[s, 0] = sx
            points[s, 1] = sy
            points[s, 2] = ex
            points[s, 3] = ey
            links[s, 0] = neighbours[f, edge]
            links[s, 1] = ev
            valid[s] = True
    return points, links, valid


@kernel(
    types.Tuple((I64_1D_OUT, I64_1D_OUT, I64_1D_OUT))(B1_1D, I64_1D, I64_1D, I64),
)
def order_by_layer(valid, face_lo, slot_offsets, n_layers):
    """Number the segments plane by plane, in face order within a plane.

    Returns ``(layer_offsets, seg_slot, slot_seg)``: segment ``i`` (plane ``k``
    holds ``layer_offsets[k]:layer_offsets[k + 1]``) is slot ``seg_slot[i]``;
    ``slot_seg[s]`` is the segment of slot ``s`` or -1. This is CuraEngine's
    per-layer segment order (faces visited in mesh order), by a counting sort.
    """
    n_faces = slot_offsets.shape[0] - 1
    layer_offsets = np.zeros(n_layers + 1, dtype=np.int64)
    for f in range(n_faces):
        for s in range(slot_offsets[f], slot_offsets[f + 1]):
            if valid[s]:
                layer_offsets[face_lo[f] + s - slot_offsets[f] + 1] += 1
    for k in range(n_layers):
        layer_offsets[k + 1] += layer_offsets[k]
    fill = layer_offsets[:-1].copy()
    seg_slot = np.empty(layer_offsets[n_layers], dtype=np.int64)
    slot_seg = np.full(valid.shape[0], -1, dtype=np.int64)
    for f in range(n_faces):
        for s in range(slot_offsets[f], slot_offsets[f + 1]):
            if valid[s]:
                k = face_lo[f] + s - slot_offsets[f]
                seg_slot[fill[k]] = s
                slot_seg[s] = fill[k]
                fill[k] += 1
    return layer_offsets, seg_slot, slot_seg
