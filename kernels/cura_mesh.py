"""Kernels building a mesh the way CuraEngine's ``Mesh`` holds it (compat mode).

Two passes, both from ``spec/CURA_COMPAT.md`` section 2:

* :func:`meld_corners` -- CuraEngine's 30 µm vertex melding (``addFace`` ->
  ``findIndexOfVertex``), one pass over all corners in file order;
* :func:`face_neighbours` -- ``Mesh::finish``: the face across each edge of every
  face, with the smallest-angle rule on non-manifold edges.
"""

import numpy as np
from numba import types

from ._jit import cost_chunks, even_chunks, kernel, run_serial
from ._types import I64, I64_1D, I64_1D_OUT, I64_1D_W, I64_2D, I64_2D_W

_TWO_PI = 2.0 * np.pi
_MELD_CHUNK = 1 << 16  # corners per chunk of cells to meld
_FACE_CHUNK = 1 << 14  # faces per chunk of face_neighbours


@kernel(inline="always")
def _within(corners, a, b, reach):
    """CuraEngine's ``testLength``: |d| <= reach per axis and d.d <= reach**2."""
    dx = corners[a, 0] - corners[b, 0]
    dy = corners[a, 1] - corners[b, 1]
    dz = corners[a, 2] - corners[b, 2]
    if dx > reach or dx < -reach or dy > reach or dy < -reach:
        return False
    if dz > reach or dz < -reach:
        return False
    return dx * dx + dy * dy + dz * dz <= reach * reach


@kernel(types.void(I64_2D, I64_1D, I64_1D, I64, I64, I64, I64_1D_W, I64_1D_W))
def _meld_range(corners, order, cell_offsets, reach, c0, c1, out_rep, created):
    """:func:`meld_corners` of cells ``c0:c1``: writes ``out_rep`` of their corners.

    ``created`` (N,) is scratch: a cell's created corners go to its own slots
    ``cell_offsets[c]:``, so disjoint cell ranges can run on several threads.
    """
    for c in range(c0, c1):
        start = cell_offsets[c]
        count = 0
        for k in range(start, cell_offsets[c + 1]):
            i = order[k]
            found = -1
            for m in range(count):
                e = created[start + m]
                if _within(corners, e, i, reach):
                    found = e
                    break
            if found < 0:
                created[start + count] = i
                count += 1
                found = i
            out_rep[i] = found


def meld_corners(corners, order, cell_offsets, reach, run=run_serial):
    """The corner whose vertex each corner reuses, CuraEngine's melding.

    ``corners`` (N, 3) are the triangle corners in file order. ``order`` lists
    them grouped by CuraEngine's hash cell ``q = trunc((c + reach/2) / reach)``
    per axis, in file order within a cell; cell ``i`` is
    ``order[cell_offsets[i]:cell_offsets[i + 1]]``. Returns ``rep`` (N,): corner
    ``i`` uses the vertex created by corner ``rep[i]`` (``rep[i] == i`` where
    corner ``i`` creates a new vertex).

    CuraEngine checks only the vertices stored under the same 32-bit hash
    ``qx ^ (qy << 10) ^ (qz << 20)``, in creation order, and reuses the first one
    within ``reach`` (``|d| <= reach`` per axis and ``d.d <= reach**2``). Two
    vertices within reach have cell indices that differ by at most 1 per axis; if
    any differ, their hashes differ in bit 0, 10 or 20 (``n ^ (n + 1)`` is odd).
    So the candidates that can match are exactly the earlier-created vertices of
    the same cell, which is what this kernel scans: the same result as the hash
    buckets, but no bucket can hold more than the few vertices that fit in one
    cell pairwise farther apart than ``reach`` (no quadratic worst case).

    The cells are melded in chunks of about equal corner counts given to ``run``
    (``run(fn, bounds)`` calls ``fn(lo, hi)`` for every chunk of cells, in any
    order or at once: e.g. ``vecslice._threads.run_chunks``); by default one
    after another.

    Preconditions: |corners| < 2**30; ``order`` and ``cell_offsets`` as above.
    """
    n = corners.shape[0]
    rep = np.empty(n, dtype=np.int64)
    created = np.empty(n, dtype=np.int64)  # per cell: created corners at its slots
    run(lambda c0, c1: _meld_range(corners, order, cell_offsets, reach, c0, c1, rep,
                                   created), cost_chunks(cell_offsets, _MELD_CHUNK))
    return rep


@kernel(inline="always")
def _third(faces, g, a, b):
    """The vertex of face ``g`` that is neither ``a`` nor ``b``."""
    for j in range(3):
        v = faces[g, j]
        if v != a and v != b:
            return v
    return faces[g, 0]


@kernel(inline="always")
def _has(faces, g, v):
    """Whether face ``g`` has vertex ``v``."""
    return faces[g, 0] == v or faces[g, 1] == v or faces[g, 2] == v


@kernel(
    I64(I64_2D, I64_2D, I64, I64, I64, I64_1D, I64, I64),
    error_model="numpy",
)
def _smallest_angle(vertices, faces, f, a, b, cands, lo, hi):
    """CuraEngine's choice among several faces across edge a -> b of face ``f``.

    Candidates are the faces ``cands[lo:hi]`` (in face order) other than ``f``
    that contain ``a`` and ``b``; the winner has the smallest angle in [0, 2 pi)
    from face ``f`` (first one on a tie).

    Floats follow IEEE rules as CuraEngine's doubles do (``error_model="numpy"``):
    an edge of length zero (two vertex indices at one position, which a mesh not
    loaded the CuraEngine way can hold) divides by zero into NaN angles, which
    no comparison prefers, so no candidate wins (-1), as in CuraEngine; Python's
    rules would raise ZeroDivisionError inside the kernel.
    """
    w = _third(faces, f, a, b)
    v0x = (vertices[b, 0] - vertices[a, 0]) / 1000.0
    v0y = (vertices[b, 1] - vertices[a, 1]) / 1000.0
    v0z = (vertices[b, 2] - vertices[a, 2]) / 1000.0
    norm = np.sqrt(v0x * v0x + v0y * v0y + v0z * v0z)
    nx = v0x / norm
    ny = v0y / norm
    nz = v0z / norm
    px = (vertices[w, 0] - vertices[a, 0]) / 1000.0
    py = (vertices[w, 1] - vertices[a, 1]) / 1000.0
    pz = (vertices[w, 2] - vertices[a, 2]) / 1000.0
    # n0 = (w - a) x v0
    n0x = py * v0z - pz * v0y
    n0y = pz * v0x - px * v0z
    n0z = px * v0y - py * v0x
    best = -1
    best_angle = 1000.0
    for k in range(lo, hi):
        g = cands[k]
        if g == f or not (_has(faces, g, a) and _has(faces, g, b)):
            continue
        t = _third(faces, g, a, b)
        qx = (vertices[t, 0] - vertices[a, 0]) / 1000.0
        qy = (vertices[t, 1] - vertices[a, 1]) / 1000.0
        qz = (vertices[t, 2] - vertices[a, 2]) / 1000.0
        # n1 = v0 x (t - a)
        n1x = v0y * qz - v0z * qy
        n1y = v0z * qx - v0x * qz
        n1z = v0x * qy - v0y * qx
        dot = n0x * n1x + n0y * n1y + n0z * n1z
        cx = n0y * n1z - n0z * n1y
        cy = n0z * n1x - n0x * n1z
        cz = n0x * n1y - n0y * n1x
        det = nx * cx + ny * cy + nz * cz
        angle = np.arctan2(det, dot)
        if angle < 0.0:
            angle += _TWO_PI
        if angle < best_angle:
            best_angle = angle
            best = g
    return best


@kernel(types.Tuple((I64_1D_OUT, I64_1D_OUT))(I64_2D, I64))
def vertex_faces(faces, n_vertices):
    """The faces around every vertex, in face order (CuraEngine's ``connected_faces_``).

    Returns ``(offsets, items)``: vertex ``v``'s faces are
    ``items[offsets[v]:offsets[v + 1]]`` (a stable counting sort).
    """
    n_faces = faces.shape[0]
    offsets = np.zeros(n_vertices + 1, dtype=np.int64)
    for f in range(n_faces):
        for j in range(3):
            offsets[faces[f, j] + 1] += 1
    for v in range(n_vertices):
        offsets[v + 1] += offsets[v]
    fill = offsets[:-1].copy()
    items = np.empty(3 * n_faces, dtype=np.int64)
    for f in range(n_faces):
        for j in range(3):
            v = faces[f, j]
            items[fill[v]] = f
            fill[v] += 1
    return offsets, items


@kernel(
    I64(I64_2D, I64_2D, I64, I64, I64, I64_1D, I64_1D),
)
def _across(vertices, faces, f, a, b, vf_offsets, vf_faces):
    """The face across edge a -> b of face ``f``, or -1 (``getFaceIdxWithPoints``)."""
    # the faces with both ends are in both ends' lists: scan the shorter one
    lo = vf_offsets[a]
    hi = vf_offsets[a + 1]
    if vf_offsets[b + 1] - vf_offsets[b] < hi - lo:
        lo = vf_offsets[b]
        hi = vf_offsets[b + 1]
    found = -1
    count = 0
    for i in range(lo, hi):
        g = vf_faces[i]
        if g != f and _has(faces, g, a) and _has(faces, g, b):
            count += 1
            found = g
    if count <= 1:
        return found
    return _smallest_angle(vertices, faces, f, a, b, vf_faces, lo, hi)


@kernel(types.void(I64_2D, I64_2D, I64_1D, I64_1D, I64, I64, I64_2D_W))
def _neighbours_range(vertices, faces, vf_offsets, vf_faces, f0, f1, out_neighbours):
    """:func:`face_neighbours` of faces ``f0:f1``, into their rows of the output."""
    for f in range(f0, f1):
        for j in range(3):
            out_neighbours[f, j] = _across(vertices, faces, f, faces[f, j],
                                           faces[f, (j + 1) % 3], vf_offsets, vf_faces)


def face_neighbours(vertices, faces, vf_offsets, vf_faces, run=run_serial):
    """CuraEngine's ``connected_face_index``: the face across each face edge.

    Entry ``[f, j]`` is the face across edge ``j`` of face ``f`` (edge 0 runs
    from corner 0 to 1, edge 1 from 1 to 2, edge 2 from 2 to 0), or -1 where no
    other face has that edge. The candidates are the other faces containing both
    ends, in face order (CuraEngine scans the first end's ``connected_faces_``;
    here the shorter of the two ends' lists from :func:`vertex_faces`, which
    holds the same faces in the same order).

    One candidate: that face, whatever its vertex order. Several (a non-manifold
    edge a -> b): the one with the smallest angle ``atan2(n . (n0 x n1), n0 . n1)``
    in [0, 2 pi), where ``n`` is the unit vector a -> b, ``v0 = b - a``,
    ``n0 = (w - a) x v0`` with ``w`` the third vertex of face ``f``, and
    ``n1 = v0 x (t - a)`` with ``t`` the candidate's third vertex; differences
    taken in integer µm, then converted to mm (/ 1000) in double precision; the
    first candidate in face order wins a tie.

    Chunks of faces go to ``run`` (as in :func:`meld_corners`).

    Preconditions: faces have three distinct vertices in [0, V); |vertices| <
    2**30; ``vf_offsets``, ``vf_faces`` from :func:`vertex_faces`.
    """
    n_faces = faces.shape[0]
    out = np.empty((n_faces, 3), dtype=np.int64)
    run(lambda f0, f1: _neighbours_range(vertices, faces, vf_offsets, vf_faces, f0,
                                         f1, out), even_chunks(n_faces, _FACE_CHUNK))
    return out
