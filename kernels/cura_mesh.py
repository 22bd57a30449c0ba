"""Kernels building a mesh the way CuraEngine's ``Mesh`` holds it (compat mode).

Three passes, from ``spec/CURA_COMPAT.md`` section 2:

* :func:`group_cells` -- the corners grouped by CuraEngine's 30 µm hash cell, in
  linear time and in short chunks;
* :func:`meld_corners` -- CuraEngine's 30 µm vertex melding (``addFace`` ->
  ``findIndexOfVertex``), one pass over all corners in file order;
* :func:`face_neighbours` -- ``Mesh::finish``: the face across each edge of every
  face, with the smallest-angle rule on non-manifold edges.
"""

import numpy as np
from numba import types

from ._jit import cost_chunks, even_chunks, kernel, run_serial
from ._types import B1_1D_W, I64, I64_1D, I64_1D_OUT, I64_1D_W, I64_2D, I64_2D_W
from .geometry import tdiv
from .sorting import mix_hash, table_bits

_TWO_PI = 2.0 * np.pi
_MELD_CHUNK = 1 << 16  # corners per chunk of cells to meld
_FACE_CHUNK = 1 << 14  # faces per chunk of face_neighbours
_HASH_CHUNK = 1 << 20  # corners per chunk of the partition passes of group_cells
_PART_SIZE = 2048  # about this many corners per partition: its table stays in cache
_PART_CHUNK = 1 << 16  # corners per chunk of partitions to group


@kernel(inline="always")
def _cell(corners, i, reach):
    """CuraEngine's hash cell of corner ``i``: ``trunc((c + reach/2) / reach)``."""
    half = reach // 2
    return (tdiv(corners[i, 0] + half, reach), tdiv(corners[i, 1] + half, reach),
            tdiv(corners[i, 2] + half, reach))


@kernel(inline="always")
def _same_cell(corners, a, b, reach):
    """Whether corners ``a`` and ``b`` lie in the same hash cell."""
    ax, ay, az = _cell(corners, a, reach)
    bx, by, bz = _cell(corners, b, reach)
    return ax == bx and ay == by and az == bz


_U64_1D = types.Array(types.uint64, 1, "C", readonly=True)
_U64_1D_W = types.uint64[::1]


@kernel(types.void(I64_2D, I64, I64, I64, I64, I64, _U64_1D_W, I64_2D_W))
def _hash_range(corners, reach, pbits, size, c0, c1, out_hash, out_hist):
    """The cell hash of corners ``c0:c1``, counted by partition.

    A corner's partition is its hash's top ``pbits`` bits; the counts go to
    column ``c0 // size`` of ``out_hist`` (a row per partition, zero on entry).
    """
    col = c0 // size
    shift = np.uint64(64 - pbits) if pbits > 0 else np.uint64(63)
    for i in range(c0, c1):
        qx, qy, qz = _cell(corners, i, reach)
        h = mix_hash(qx, qy, qz)
        out_hash[i] = h
        out_hist[np.int64(h >> shift) if pbits > 0 else 0, col] += 1


@kernel(types.void(_U64_1D, I64, I64, I64, I64, I64_2D_W, I64_1D_W, _U64_1D_W))
def _scatter_range(hashes, pbits, size, c0, c1, io_pos, out_order, out_hash):
    """Corners ``c0:c1`` (and their hashes) to their partitions' slots, in order.

    Column ``c0 // size`` of ``io_pos`` (a row per partition) holds this
    chunk's next slot in each partition.
    """
    col = c0 // size
    shift = np.uint64(64 - pbits) if pbits > 0 else np.uint64(63)
    for i in range(c0, c1):
        h = hashes[i]
        p = np.int64(h >> shift) if pbits > 0 else 0
        out_order[io_pos[p, col]] = i
        out_hash[io_pos[p, col]] = h
        io_pos[p, col] += 1


@kernel(types.void(I64_2D, I64, I64_1D, I64_1D, _U64_1D, I64, I64, I64_1D_W, B1_1D_W))
def _group_range(corners, reach, part_offsets, by_part, part_hash, p0, p1,
                 out_order, out_cell_start):
    """Group the corners of partitions ``p0:p1`` by cell, file order kept.

    Partition ``p`` holds ``by_part[part_offsets[p]:part_offsets[p + 1]]`` in
    file order (their cell hashes beside them in ``part_hash``); the same slots
    of ``out_order`` get them grouped by cell (cells
    in order of first appearance), ``out_cell_start`` marking each cell's first
    slot (False on entry).
    """
    m_max = 0
    for p in range(p0, p1):
        m_max = max(m_max, part_offsets[p + 1] - part_offsets[p])
    # a cell per slot, for the largest partition
    table = np.full(np.int64(1) << table_bits(m_max), -1, dtype=np.int64)
    first = np.empty(m_max, dtype=np.int64)  # the slot of each cell's first corner
    cell_of = np.empty(m_max, dtype=np.int64)
    fill = np.empty(m_max + 1, dtype=np.int64)
    for p in range(p0, p1):
        start = part_offsets[p]
        m = part_offsets[p + 1] - start
        if m == 0:
            continue
        mask = (np.int64(1) << table_bits(m)) - 1
        table[: mask + 1] = -1
        n_cells = 0
        fill[0] = 0
        for j in range(m):
            i = by_part[start + j]
            h = part_hash[start + j]
            t = np.int64(h & np.uint64(mask))
            while True:
                c = table[t]
                if c < 0:
                    table[t] = n_cells
                    first[n_cells] = start + j
                    fill[n_cells + 1] = 0
                    c = n_cells
                    n_cells += 1
                    break
                if part_hash[first[c]] == h and _same_cell(corners, i,
                                                          by_part[first[c]], reach):
                    break
                t = (t + 1) & mask
            cell_of[j] = c
            fill[c + 1] += 1
        for c in range(n_cells):
            fill[c + 1] += fill[c]
            out_cell_start[start + fill[c]] = True
        for j in range(m):
            c = cell_of[j]
            out_order[start + fill[c]] = by_part[start + j]
            fill[c] += 1


def group_cells(corners, reach, run=run_serial):
    """The corners grouped by CuraEngine's hash cell, file order within a cell.

    The cell of corner ``c`` is ``trunc((c + reach/2) / reach)`` per axis (C
    division). Returns ``(order, cell_offsets)`` for :func:`meld_corners`: cell
    ``k`` is ``order[cell_offsets[k]:cell_offsets[k + 1]]``, its corners in file
    order; the cells come in no particular order.

    In linear expected time, like ``vertices.merge_vertices``: the corners are
    partitioned by the top bits of a hash of their cell (a stable counting sort,
    in chunks of corners: counts per chunk, then each chunk scatters to its own
    slots), then each partition groups its corners with a small hash table
    (chunks of partitions). All passes go to ``run`` in chunks (``run(fn,
    bounds)`` calls ``fn(lo, hi)`` for every chunk, in any order or at once:
    e.g. ``vecslice._threads.run_chunks``); by default one after another. No
    chunk runs long, so Ctrl-C is seen between chunks.

    Preconditions: |corners| < 2**62; ``reach`` > 0.
    """
    n = corners.shape[0]
    pbits = 0
    while (np.int64(1) << pbits) * _PART_SIZE < n and pbits < 20:
        pbits += 1
    n_parts = 1 << pbits
    bounds = even_chunks(n, _HASH_CHUNK)
    hashes = np.empty(n, dtype=np.uint64)
    hist = np.zeros((n_parts, max(len(bounds) - 1, 1)), dtype=np.int64)
    run(lambda c0, c1: _hash_range(corners, reach, pbits, _HASH_CHUNK, c0, c1, hashes,
                                   hist), bounds)
    # partition-major, chunk-minor: each chunk's first slot in each partition,
    # the exclusive prefix sum of the counts in that order (no other temporary:
    # the table grows as corners squared, 0.6 GB at the reader's limit)
    pos = np.empty_like(hist)
    flat = pos.reshape(-1)
    flat[0] = 0
    np.cumsum(hist.reshape(-1)[:-1], out=flat[1:])
    hist = None  # freed before the scatter's arrays are made
    part_offsets = np.append(pos[:, 0], np.int64(n))
    by_part = np.empty(n, dtype=np.int64)
    part_hash = np.empty(n, dtype=np.uint64)
    run(lambda c0, c1: _scatter_range(hashes, pbits, _HASH_CHUNK, c0, c1, pos,
                                      by_part, part_hash), bounds)
    order = np.empty(n, dtype=np.int64)
    cell_start = np.zeros(n, dtype=np.bool_)
    run(lambda p0, p1: _group_range(corners, reach, part_offsets, by_part, part_hash,
                                    p0, p1, order, cell_start),
        cost_chunks(part_offsets, _PART_CHUNK))
    return order, np.append(np.flatnonzero(cell_start), np.int64(n))


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
