"""Kernels computing CuraEngine's per-face slice segments (compat mode).

``spec/CURA_COMPAT.md`` section 3. Each face gives at most one segment per plane,
computed from the face's own vertex order with CuraEngine's biased ``interpolate``;
the two faces sharing an edge compute its crossing separately and may disagree by
a micron (CuraEngine's chaining tolerates gaps up to 10 µm).

Work is batched over (face, plane) *slots*: face ``f`` may cut the planes
``face_lo[f] <= k < face_lo[f] + n`` (``n = slot_offsets[f + 1] -
slot_offsets[f]``: the planes with ``zmin <= z < zmax``, from one ``searchsorted``
per vertex), and slot ``slot_offsets[f] + k - face_lo[f]`` holds its segment on
plane ``k`` or nothing (a vertex only touching the plane gives none). Three passes:
classify the slots, number the segments plane by plane (CuraEngine's order), then
compute each segment straight into its place.
"""

import numpy as np
from numba import types

from ._jit import cost_chunks, kernel, run_serial
from ._types import B1_1D, B1_1D_W, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_W
from .geometry import tdiv

_SLOT_CHUNK = 1 << 16  # (face, plane) slots per chunk of faces


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


@kernel(inline="always")
def _compensated(vertices, faces, f, zz, comp_limit):
    """Heights of face ``f``'s vertices, those on plane ``zz`` 1 µm lower if due."""
    z0 = vertices[faces[f, 0], 2]
    z1 = vertices[faces[f, 1], 2]
    z2 = vertices[faces[f, 2], 2]
    if zz < comp_limit:
        if z0 == zz:
            z0 -= 1
        if z1 == zz:
            z1 -= 1
        if z2 == zz:
            z2 -= 1
    return z0, z1, z2


@kernel(inline="always")
def _row(z0, z1, z2, zz):
    """CuraEngine's case-table row (0-5 for A-F), or -1: no segment."""
    if z0 < zz and z1 > zz and z2 > zz:
        return 0
    if z0 > zz and z1 <= zz and z2 <= zz:
        return 1
    if z1 < zz and z0 > zz and z2 > zz:
        return 2
    if z1 > zz and z0 <= zz and z2 <= zz:
        return 3
    if z2 < zz and z1 > zz and z0 > zz:
        return 4
    if z2 > zz and z1 <= zz and z0 <= zz:
        return 5
    return -1


@kernel(types.Tuple((I64_1D_OUT, I64_1D_OUT))(I64_1D, I64_2D))
def face_ranges(vert_layer, faces):
    """First plane and slot offsets of every face.

    ``vert_layer[v]`` is the number of planes strictly below vertex ``v``; face
    ``f`` may cut planes ``lo <= k < hi`` (``zmin <= z < zmax``) with ``lo``, ``hi``
    the min and max over its vertices. Returns ``(face_lo, slot_offsets)``.
    """
    n = faces.shape[0]
    lo = np.empty(n, dtype=np.int64)
    offsets = np.empty(n + 1, dtype=np.int64)
    offsets[0] = 0
    for f in range(n):
        a = vert_layer[faces[f, 0]]
        b = vert_layer[faces[f, 1]]
        c = vert_layer[faces[f, 2]]
        m = min(a, min(b, c))
        lo[f] = m
        offsets[f + 1] = offsets[f] + max(a, max(b, c)) - m
    return lo, offsets


@kernel(types.void(I64_2D, I64_2D, I64_1D, I64_1D, I64_1D, I64, I64, I64, B1_1D_W))
def _classify_range(vertices, faces, z, face_lo, slot_offsets, comp_limit, f0, f1,
                    out_valid):
    """:func:`classify_slots` of faces ``f0:f1``, into their slots of ``out_valid``."""
    for f in range(f0, f1):
        s0 = slot_offsets[f]
        for s in range(s0, slot_offsets[f + 1]):
            zz = z[face_lo[f] + s - s0]
            z0, z1, z2 = _compensated(vertices, faces, f, zz, comp_limit)
            out_valid[s] = _row(z0, z1, z2, zz) >= 0


def classify_slots(vertices, faces, z, face_lo, slot_offsets, comp_limit,
                   run=run_serial):
    """Whether each (face, plane) slot gives a segment (CuraEngine's case table).

    A vertex on the plane is moved 1 µm down first when the plane is below
    ``comp_limit`` (CuraEngine: ``z <= 0`` for a mesh on the bed; a very small
    value disables it, as CuraEngine's 'inclusive' mode does). A segment needs one
    vertex above the plane and the others at or below it, or two above and one
    strictly below (see :func:`fill_segments`). Chunks of faces of about equal
    slot counts go to ``run`` (``run(fn, bounds)`` calls ``fn(lo, hi)`` for every
    chunk of faces, in any order or at once: e.g.
    ``vecslice._threads.run_chunks``); by default one after another.
    """
    valid = np.zeros(slot_offsets[-1], dtype=np.bool_)
    run(lambda f0, f1: _classify_range(vertices, faces, z, face_lo, slot_offsets,
                                       comp_limit, f0, f1, valid),
        cost_chunks(slot_offsets, _SLOT_CHUNK))
    return valid


@kernel(
    types.Tuple((I64_1D_OUT, I64_1D_OUT))(B1_1D, I64_1D, I64_1D, I64),
)
def order_by_layer(valid, face_lo, slot_offsets, n_layers):
    """Number the segments plane by plane, in face order within a plane.

    Returns ``(layer_offsets, slot_seg)``: plane ``k`` holds segments
    ``layer_offsets[k]:layer_offsets[k + 1]``; ``slot_seg[s]`` is the segment of
    slot ``s`` or -1. This is CuraEngine's per-layer segment order (faces visited
    in mesh order), by a counting sort.
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
    slot_seg = np.full(valid.shape[0], -1, dtype=np.int64)
    for f in range(n_faces):
        for s in range(slot_offsets[f], slot_offsets[f + 1]):
            if valid[s]:
                k = face_lo[f] + s - slot_offsets[f]
                slot_seg[s] = fill[k]
                fill[k] += 1
    return layer_offsets, slot_seg


@kernel(inline="always")
def segment_of(f, k, face_lo, slot_offsets, slot_seg):
    """Segment of face ``f`` on plane ``k`` (``face_idx_to_segment_idx``), or -1."""
    i = k - face_lo[f]
    if i < 0 or i >= slot_offsets[f + 1] - slot_offsets[f]:
        return -1
    return slot_seg[slot_offsets[f] + i]


@kernel(types.void(I64_2D, I64_2D, I64_2D, I64_1D, I64_1D, I64_1D, I64_1D, I64,
                   I64, I64, I64_2D_W, I64_2D_W))
def _fill_range(vertices, faces, neighbours, z, face_lo, slot_offsets, slot_seg,
                comp_limit, f0, f1, out_points, out_links):
    """:func:`fill_segments` of faces ``f0:f1``, into their segments' rows."""
    for f in range(f0, f1):
        s0 = slot_offsets[f]
        v0 = faces[f, 0]
        v1 = faces[f, 1]
        v2 = faces[f, 2]
        for s in range(s0, slot_offsets[f + 1]):
            i = slot_seg[s]
            if i < 0:
                continue
            k = face_lo[f] + s - s0
            zz = z[k]
            z0, z1, z2 = _compensated(vertices, faces, f, zz, comp_limit)
            row = _row(z0, z1, z2, zz)
            ev = -1
            if row == 0:
                sx, sy = _edge_point(vertices, v0, v2, z0, z2, zz)
                ex, ey = _edge_point(vertices, v0, v1, z0, z1, zz)
                edge = 0
            elif row == 1:
                sx, sy = _edge_point(vertices, v0, v1, z0, z1, zz)
                ex, ey = _edge_point(vertices, v0, v2, z0, z2, zz)
                edge = 2
                if z2 == zz:
                    ev = v2
            elif row == 2:
                sx, sy = _edge_point(vertices, v1, v0, z1, z0, zz)
                ex, ey = _edge_point(vertices, v1, v2, z1, z2, zz)
                edge = 1
            elif row == 3:
                sx, sy = _edge_point(vertices, v1, v2, z1, z2, zz)
                ex, ey = _edge_point(vertices, v1, v0, z1, z0, zz)
                edge = 0
                if z0 == zz:
                    ev = v0
            elif row == 4:
                sx, sy = _edge_point(vertices, v2, v1, z2, z1, zz)
                ex, ey = _edge_point(vertices, v2, v0, z2, z0, zz)
                edge = 2
            else:
                sx, sy = _edge_point(vertices, v2, v0, z2, z0, zz)
                ex, ey = _edge_point(vertices, v2, v1, z2, z1, zz)
                edge = 1
                if z1 == zz:
                    ev = v1
            out_points[i, 0] = sx
            out_points[i, 1] = sy
            out_points[i, 2] = ex
            out_points[i, 3] = ey
            g = neighbours[f, edge]
            out_links[i, 0] = -1 if g < 0 else segment_of(
                g, k, face_lo, slot_offsets, slot_seg)
            out_links[i, 1] = ev


def fill_segments(vertices, faces, neighbours, z, face_lo, slot_offsets, slot_seg,
                  comp_limit, run=run_serial):
    """CuraEngine's segments, written in segment order (see :func:`order_by_layer`).

    Returns ``(points, links)``: ``points[i]`` = start x, y, end x, y of segment
    ``i``; ``links[i]`` = (the segment on the same plane of the face across the
    edge the end lies on, ``endOtherFaceIdx``, or -1 if there is none; the vertex
    the end lies on, ``endVertex``, or -1).

    After the compensation of :func:`classify_slots`, the first matching row of
    CuraEngine's table over the face's vertices p0, p1, p2 (z compared with the
    plane z; "pX->pY": the point ``interpolate(z, pX.z, pY.z, pX.x, pY.x)``, and
    the same for y):

    * A: p0 < z, p1 > z, p2 > z: start on p0->p2, end on p0->p1 (edge 0);
    * B: p0 > z, p1 <= z, p2 <= z: p0->p1, p0->p2 (edge 2; endVertex v2 if p2 == z);
    * C: p1 < z, p0 > z, p2 > z: p1->p0, p1->p2 (edge 1);
    * D: p1 > z, p0 <= z, p2 <= z: p1->p2, p1->p0 (edge 0; endVertex v0 if p0 == z);
    * E: p2 < z, p1 > z, p0 > z: p2->p1, p2->p0 (edge 2);
    * F: p2 > z, p1 <= z, p0 <= z: p2->p0, p2->p1 (edge 1; endVertex v1 if p1 == z).

    Chunks of faces go to ``run`` (as in :func:`classify_slots`).

    Preconditions: ``slot_seg`` from :func:`order_by_layer` with the same
    ``comp_limit``; ``z`` sorted; |coordinates| < 2**30.
    """
    n_seg = int(np.count_nonzero(slot_seg >= 0))
    points = np.empty((n_seg, 4), dtype=np.int64)
    links = np.empty((n_seg, 2), dtype=np.int64)
    run(lambda f0, f1: _fill_range(vertices, faces, neighbours, z, face_lo,
                                   slot_offsets, slot_seg, comp_limit, f0, f1, points,
                                   links), cost_chunks(slot_offsets, _SLOT_CHUNK))
    return points, links
