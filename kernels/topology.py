"""Kernels deriving the edge topology of a triangle mesh."""

import numpy as np
from numba import types

from ._jit import kernel, run_serial
from ._types import I64, I64_1D, I64_1D_OUT, I64_1D_W, I64_2D, I64_2D_OUT

_SMALL_BUCKET = 32


@kernel(inline="always")
def _ends(faces, h):
    """(start, end) vertex of half-edge ``h``."""
    f = h // 3
    j = h - 3 * f
    return faces[f, j], faces[f, (j + 1) % 3]


@kernel(inline="always")
def _other(faces, h, v):
    """The vertex of half-edge ``h`` that is not ``v``."""
    a, b = _ends(faces, h)
    return b if a == v else a


@kernel(types.Tuple((I64_1D_OUT, I64_1D_OUT))(I64_2D, I64))
def _buckets(faces, n_vertices):
    """Half-edges bucketed by their smaller vertex (counting sort, stable)."""
    n_half = 3 * faces.shape[0]
    offsets = np.zeros(n_vertices + 1, dtype=np.int64)
    for h in range(n_half):
        a, b = _ends(faces, h)
        offsets[min(a, b) + 1] += 1
    for v in range(n_vertices):
        offsets[v + 1] += offsets[v]
    fill = offsets[:-1].copy()
    items = np.empty(n_half, dtype=np.int64)
    for h in range(n_half):
        a, b = _ends(faces, h)
        v = min(a, b)
        items[fill[v]] = h
        fill[v] += 1
    return offsets, items


@kernel(
    types.int64(I64_2D, I64_1D, I64, I64, I64_1D, types.int64[::1], types.int64[::1],
                types.int64[:, ::1], types.int64[::1], types.boolean),
)
def _bucket_edges(faces, items, v, e0, offsets, out_edge, out_twin, out_verts,
                  scratch, write):
    """Group the half-edges of vertex ``v``'s bucket into edges.

    Returns the number of edges. With ``write``, edge ids start at ``e0`` and
    ``out_edge``, ``out_twin`` and ``out_verts`` are filled. Small buckets are
    scanned pairwise; large ones (non-manifold fans) are sorted first, so no bucket
    costs more than O(d log d) beyond 32 half-edges.
    """
    start = offsets[v]
    stop = offsets[v + 1]
    d = stop - start
    if d == 0:
        return 0
    order = scratch[:d]
    key = scratch[d : 2 * d]
    for i in range(d):
        order[i] = items[start + i]
        key[i] = _other(faces, order[i], v)
    if d > _SMALL_BUCKET:
        perm = np.argsort(key, kind="mergesort")
        sorted_h = order[perm]
        sorted_k = key[perm]
        order[:] = sorted_h
        key[:] = sorted_k
    n_edges = 0
    for i in range(d):
        h = order[i]
        if h < 0:  # taken by an earlier edge of this bucket
            continue
        w = key[i]
        second = -1
        count = 1
        if write:
            out_edge[h] = e0 + n_edges
        for i2 in range(i + 1, d):
            if key[i2] != w:
                if d > _SMALL_BUCKET:
                    break  # sorted: the run of w has ended
                continue
            h2 = order[i2]
            if h2 < 0:
                continue
            count += 1
            if count == 2:
                second = h2
            if write:
                out_edge[h2] = e0 + n_edges
            order[i2] = -1
        if write:
            out_verts[e0 + n_edges, 0] = v
            out_verts[e0 + n_edges, 1] = w
            if count == 2 and _ends(faces, h)[0] != _ends(faces, second)[0]:
                out_twin[h] = second
                out_twin[second] = h
        n_edges += 1
    return n_edges


@kernel(
    types.Tuple((I64_2D_OUT, I64_2D_OUT, I64_1D_OUT))(I64_2D, I64),
)
def edge_topology(faces, n_vertices):
    """Number the undirected edges of a triangle mesh.

    Half-edge ``j`` of face ``f`` runs from ``faces[f, j]`` to
    ``faces[f, (j + 1) % 3]``. Returns ``face_edges`` (F, 3), the undirected edge
    id of every half-edge, and ``edge_vertices`` (E, 2), the two vertex ids of each
    edge (smaller first). Every half-edge with the same pair of vertices gets the
    same id, however many faces share it (non-manifold edges included). Edge ids
    follow the smaller vertex id, then first appearance (by the other vertex id in
    buckets of more than 32 half-edges). The third result, ``twin`` (3F,), gives for
    half-edge ``3 * f + j`` the opposite half-edge of the same edge where the edge
    has exactly two half-edges running in opposite directions (a closed,
    consistently wound edge), and -1 elsewhere (open, non-manifold or
    inconsistently wound edges).

    Linear time: half-edges are bucketed by their smaller vertex (counting sort)
    and matched inside each bucket, in two passes (count, then fill). Serial:
    slicing takes :func:`half_edge_twins` (chunks on threads) unless a mesh has
    2**30 vertices or more.

    Preconditions (the caller checks them): 0 <= faces < n_vertices; no face repeats
    a vertex index.
    """
    n_half = 3 * faces.shape[0]
    offsets, items = _buckets(faces, n_vertices)
    max_d = 0
    for v in range(n_vertices):
        max_d = max(max_d, offsets[v + 1] - offsets[v])
    edge_of = np.empty(n_half, dtype=np.int64)
    twin = np.full(n_half, -1, dtype=np.int64)
    no_verts = np.empty((0, 2), dtype=np.int64)
    per_vertex = np.zeros(n_vertices + 1, dtype=np.int64)
    scratch = np.empty(2 * max_d, dtype=np.int64)
    for v in range(n_vertices):
        per_vertex[v + 1] = _bucket_edges(faces, items, v, 0, offsets, edge_of,
                                          twin, no_verts, scratch, False)
    for v in range(n_vertices):
        per_vertex[v + 1] += per_vertex[v]
    edge_verts = np.empty((per_vertex[n_vertices], 2), dtype=np.int64)
    for v in range(n_vertices):
        _bucket_edges(faces, items, v, per_vertex[v], offsets, edge_of, twin,
                      edge_verts, scratch, True)
    return edge_of.reshape((faces.shape[0], 3)), edge_verts, twin


@kernel(I64_1D_OUT(I64_2D, I64))
def edge_face_counts(face_edges, n_edges):
    """Number of faces that use each edge (2 on a closed manifold)."""
    out = np.zeros(n_edges, dtype=np.int64)
    for f in range(face_edges.shape[0]):
        for j in range(3):
            out[face_edges[f, j]] += 1
    return out



_PACK_LIMIT = 1 << 30  # vertices below this pack into one int64 (with ids < 2**32)
TWIN_LIMIT = 1 << 31  # half-edges: ids below this fit the int32 twins
_CHUNK_VERTICES = 1 << 15  # vertices per chunk of bucket matching (at most 16 chunks)


@kernel(I64_1D_OUT(I64_2D, I64, I64_1D_W))
def _pack_half_edges(faces, n_vertices, packed):
    """Half-edges bucketed by their smaller vertex into ``packed``; returns offsets.

    A counting sort, stable. Each half-edge is one int64: the other vertex, the
    direction (1 when the bucket's vertex is its start) and the half-edge id,
    ``(other << 33) | (direction << 32) | id``. ``packed`` (3F,) is given by the
    caller: allocated by numpy, a large one lies on huge pages (numba's own
    allocations take a page fault per 4 kB of fresh memory).
    """
    n_faces = faces.shape[0]
    offsets = np.zeros(n_vertices + 1, dtype=np.int64)
    for f in range(n_faces):
        for j in range(3):
            a = faces[f, j]
            b = faces[f, (j + 1) % 3]
            offsets[min(a, b) + 1] += 1
    for v in range(n_vertices):
        offsets[v + 1] += offsets[v]
    fill = offsets[:-1].copy()
    for f in range(n_faces):
        for j in range(3):
            a = faces[f, j]
            b = faces[f, (j + 1) % 3]
            if a < b:  # (other vertex, direction, half-edge)
                v = a
                key = (b << 1) | 1
            else:
                v = b
                key = a << 1
            packed[fill[v]] = (key << 32) | (3 * f + j)
            fill[v] += 1
    return offsets


@kernel(types.void(types.int64[::1], I64, I64))
def _heapsort(a, lo, hi):
    """Sort ``a[lo:hi]`` in place, ascending (heapsort: O(n log n), no scratch).

    One loop: first it builds the max-heap (sifting down from the middle), then
    it moves the top to the end and sifts the new root down, until one is left.
    """
    n = hi - lo
    start = n // 2
    end = n
    while end > 1:
        if start > 0:  # building the heap
            start -= 1
        else:  # the largest to the end
            end -= 1
            t = a[lo + end]
            a[lo + end] = a[lo]
            a[lo] = t
        root = start  # sift a[lo + root] down within a[lo:lo + end]
        x = a[lo + root]
        while True:
            child = 2 * root + 1
            if child >= end:
                break
            if child + 1 < end and a[lo + child + 1] > a[lo + child]:
                child += 1
            if a[lo + child] <= x:
                break
            a[lo + root] = a[lo + child]
            root = child
        a[lo + root] = x


@kernel(types.void(I64_1D, types.int64[::1], I64, I64, types.int32[::1]))
def _match_buckets(offsets, packed, v0, v1, out_twin):
    """Twins of the half-edges in the buckets of vertices ``v0:v1``.

    Small buckets are matched pairwise; buckets of more than 32 half-edges are
    sorted in place first (so no bucket costs more than O(d log d)). Writes only
    ``out_twin`` of these half-edges and ``packed`` of these buckets.
    """
    low = np.int64(0xFFFFFFFF)
    for v in range(v0, v1):
        start = offsets[v]
        d = offsets[v + 1] - start
        if d < 2:
            continue
        if d <= _SMALL_BUCKET:
            for i in range(start, start + d):
                wi = packed[i] >> 33
                count = 0
                other = -1
                for i2 in range(start, start + d):
                    if packed[i2] >> 33 == wi:
                        count += 1
                        if i2 != i:
                            other = i2
                if count == 2 and ((packed[i] ^ packed[other]) >> 32) & 1:
                    out_twin[packed[i] & low] = packed[other] & low
            continue
        _heapsort(packed, start, start + d)
        i = start
        stop = start + d
        while i < stop:
            i2 = i + 1
            while i2 < stop and packed[i2] >> 33 == packed[i] >> 33:
                i2 += 1
            if i2 - i == 2 and ((packed[i] ^ packed[i + 1]) >> 32) & 1:
                out_twin[packed[i] & low] = packed[i + 1] & low
                out_twin[packed[i + 1] & low] = packed[i] & low
            i = i2


def half_edge_twins(faces, n_vertices, run=run_serial):
    """The ``twin`` result of :func:`edge_topology` alone, as int32, without edge ids.

    ``twin[3 * f + j]`` is the opposite half-edge of the same edge where the edge
    has exactly two half-edges running in opposite directions, and -1 elsewhere.
    This is all that slicing needs of the topology. It is int32 (half the bytes
    of int64 for the contour kernels to read): a mesh must have fewer than
    ``TWIN_LIMIT`` (2**31) half-edges, about 716 million faces.

    Half-edges are bucketed by their smaller vertex (counting sort) as one int64
    each: the other vertex, the direction and the half-edge id packed together, so
    matching inside a bucket (chunks of vertices, given to ``run``) reads only the
    bucket. Buckets of more than 32 half-edges are sorted first. Meshes too large
    to pack (2**30 vertices or more) take :func:`edge_topology`.

    ``run(fn, bounds)`` calls ``fn(lo, hi)`` for every chunk of vertices
    ``bounds[c]:bounds[c + 1]``, in any order or at once (e.g.
    ``vecslice._threads.run_chunks``); by default one after another.

    Preconditions: as :func:`edge_topology`; ``3 * len(faces) < TWIN_LIMIT``.
    """
    n_half = 3 * faces.shape[0]
    if n_vertices >= _PACK_LIMIT:
        return edge_topology(faces, n_vertices)[2].astype(np.int32)
    packed = np.empty(n_half, dtype=np.int64)
    offsets = _pack_half_edges(faces, n_vertices, packed)
    twin = np.full(n_half, -1, dtype=np.int32)
    n_chunks = max(1, min(16, -(-n_vertices // _CHUNK_VERTICES)))
    bounds = (n_vertices * np.arange(n_chunks + 1, dtype=np.int64)) // n_chunks
    run(lambda v0, v1: _match_buckets(offsets, packed, v0, v1, twin), bounds)
    return twin
