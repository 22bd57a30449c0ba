"""Kernels deriving the edge topology of a triangle mesh."""

import numpy as np
from numba import njit, types

from ._types import I64, I64_1D_OUT, I64_2D, I64_2D_OUT

_SMALL_BUCKET = 32


@njit(cache=True, nogil=True, inline="always")
def _count_half_edge(e, h, edge_count, edge_first, edge_second):
    if edge_count[e] == 0:
        edge_first[e] = h
    elif edge_count[e] == 1:
        edge_second[e] = h
    edge_count[e] += 1


@njit(
    types.Tuple((I64_2D_OUT, I64_2D_OUT, I64_1D_OUT))(I64_2D, I64),
    cache=True, nogil=True,
)
def edge_topology(faces, n_vertices):
    """Number the undirected edges of a triangle mesh.

    Half-edge ``j`` of face ``f`` runs from ``faces[f, j]`` to
    ``faces[f, (j + 1) % 3]``.
    Returns ``face_edges`` (F, 3), the undirected edge id of every half-edge, and
    ``edge_vertices`` (E, 2), the two vertex ids of each edge (smaller first). Every
    half-edge with the same pair of vertices gets the same id, however many faces
    share it (non-manifold edges included). Edge ids follow the smaller vertex id,
    then first appearance. The third result, ``twin`` (3F,), gives for half-edge
    ``3 * f + j`` the opposite half-edge of the same edge where the edge has exactly
    two half-edges running in opposite directions (a closed, consistently wound
    edge), and -1 elsewhere (open, non-manifold or inconsistently wound edges).
    Linear time: half-edges are bucketed by their smaller vertex (counting sort)
    and matched inside each bucket.

    Preconditions (the caller checks them): 0 <= faces < n_vertices; no face repeats
    a vertex index.
    """
    n_faces = faces.shape[0]
    n_half = 3 * n_faces
    lo_v = np.empty(n_half, dtype=np.int64)
    hi_v = np.empty(n_half, dtype=np.int64)
    counts = np.zeros(n_vertices + 1, dtype=np.int64)
    for f in range(n_faces):
        for j in range(3):
            a = faces[f, j]
            b = faces[f, (j + 1) % 3]
            h = 3 * f + j
            if a < b:
                lo_v[h] = a
                hi_v[h] = b
            else:
                lo_v[h] = b
                hi_v[h] = a
            counts[lo_v[h] + 1] += 1
    for v in range(n_vertices):
        counts[v + 1] += counts[v]
    fill = counts[:-1].copy()
    bucket = np.empty(n_half, dtype=np.int64)
    for h in range(n_half):
        v = lo_v[h]
        bucket[fill[v]] = h
        fill[v] += 1

    edge_of = np.empty(n_half, dtype=np.int64)
    edge_count = np.zeros(n_half, dtype=np.int64)
    edge_first = np.empty(n_half, dtype=np.int64)
    edge_second = np.empty(n_half, dtype=np.int64)
    edge_verts = np.empty((n_half, 2), dtype=np.int64)
    n_edges = 0
    for v in range(n_vertices):
        start = counts[v]
        stop = counts[v + 1]
        if stop - start <= _SMALL_BUCKET:
            for i in range(start, stop):
                h = bucket[i]
                found = -1
                for i2 in range(start, i):
                    h2 = bucket[i2]
                    if hi_v[h2] == hi_v[h]:
                        found = edge_of[h2]
                        break
                if found < 0:
                    found = n_edges
                    edge_verts[n_edges, 0] = v
                    edge_verts[n_edges, 1] = hi_v[h]
                    n_edges += 1
                edge_of[h] = found
                _count_half_edge(found, h, edge_count, edge_first, edge_second)
        else:
            keys = np.empty(stop - start, dtype=np.int64)
            for i in range(start, stop):
                keys[i - start] = hi_v[bucket[i]]
            order = np.argsort(keys, kind="mergesort")
            prev = -1
            for i in range(stop - start):
                h = bucket[start + order[i]]
                if hi_v[h] != prev:
                    edge_verts[n_edges, 0] = v
                    edge_verts[n_edges, 1] = hi_v[h]
                    n_edges += 1
                    prev = hi_v[h]
                edge_of[h] = n_edges - 1
                _count_half_edge(n_edges - 1, h, edge_count, edge_first, edge_second)
    twin = np.full(n_half, -1, dtype=np.int64)
    for e in range(n_edges):
        if edge_count[e] == 2:
            h1 = edge_first[e]
            h2 = edge_second[e]
            # opposite directions: the two half-edges start at different vertices
            if faces[h1 // 3, h1 % 3] != faces[h2 // 3, h2 % 3]:
                twin[h1] = h2
                twin[h2] = h1
    face_edges = edge_of.reshape((n_faces, 3))
    return face_edges, edge_verts[:n_edges].copy(), twin


@njit(I64_1D_OUT(I64_2D, I64), cache=True, nogil=True)
def edge_face_counts(face_edges, n_edges):
    """Number of faces that use each edge (2 on a closed manifold)."""
    out = np.zeros(n_edges, dtype=np.int64)
    for f in range(face_edges.shape[0]):
        for j in range(3):
            out[face_edges[f, j]] += 1
    return out
