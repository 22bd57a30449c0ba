"""Kernels merging equal vertex positions and cleaning the faces that index them."""

import numpy as np
from numba import prange, types

from ._jit import kernel
from ._types import B1, I64, I64_1D_OUT, I64_2D, I64_2D_OUT

# odd 64-bit multipliers (from splitmix64 and the golden ratio) mixing x, y, z
_MIX_X = np.int64(-7046029254386353131)  # 0x9E3779B97F4A7C15
_MIX_Y = np.int64(-4658895280553007687)  # 0xBF58476D1CE4E5B9
_MIX_Z = np.int64(-7723592293110705685)  # 0x94D049BB133111EB


@kernel(inline="always")
def _hash(x, y, z):
    """A well-mixed 64-bit hash of a position (wrapping int64 arithmetic)."""
    h = x * _MIX_X + y * _MIX_Y + z * _MIX_Z
    h ^= h >> 29
    h *= _MIX_X
    return np.uint64(h)


_PART_SIZE = 2048  # about this many vertices per partition: its table stays in cache


@kernel(types.Tuple((I64_1D_OUT, I64_1D_OUT))(I64_2D), parallel=True)
def merge_vertices(vertices):
    """Group vertices with exactly equal positions, in linear expected time.

    Returns ``(group, first)``: ``group[i]`` is the group of vertex ``i``, groups
    numbered in order of first occurrence, and ``first[g]`` the first vertex of
    group ``g`` (increasing).

    The vertices are partitioned by the top bits of a hash of their position
    (a counting sort, keeping index order within each partition), so that equal
    positions share a partition; each partition then finds, with its own small
    hash table (open addressing, linear probing, exact comparison of all three
    coordinates), the first vertex of every position, in parallel. A last pass
    numbers the groups in index order.
    """
    n = vertices.shape[0]
    pbits = 0
    while (np.int64(1) << pbits) * _PART_SIZE < n and pbits < 20:
        pbits += 1
    n_parts = np.int64(1) << pbits
    pshift = np.uint64(64 - pbits) if pbits > 0 else np.uint64(63)
    part_offsets = np.zeros(n_parts + 1, dtype=np.int64)
    for i in range(n):
        h = _hash(vertices[i, 0], vertices[i, 1], vertices[i, 2])
        p = np.int64(h >> pshift) if pbits > 0 else 0
        part_offsets[p + 1] += 1
    for p in range(n_parts):
        part_offsets[p + 1] += part_offsets[p]
    fill = part_offsets[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    hashes = np.empty(n, dtype=np.uint64)  # beside order: no random reads below
    for i in range(n):
        h = _hash(vertices[i, 0], vertices[i, 1], vertices[i, 2])
        p = np.int64(h >> pshift) if pbits > 0 else 0
        order[fill[p]] = i
        hashes[fill[p]] = h
        fill[p] += 1
    rep = np.empty(n, dtype=np.int64)
    for p in prange(n_parts):
        start = part_offsets[p]
        m = part_offsets[p + 1] - start
        if m == 0:
            continue
        tbits = 1
        while (np.int64(1) << tbits) < 2 * m:
            tbits += 1
        mask = (np.int64(1) << tbits) - 1
        table = np.full(mask + 1, -1, dtype=np.int64)  # positions q in order
        for q in range(start, start + m):
            i = order[q]
            h = hashes[q]
            s = np.int64(h >> np.uint64(pbits)) & mask
            while True:
                t = table[s]
                if t < 0:
                    table[s] = q
                    rep[i] = i
                    break
                if hashes[t] == h:
                    j = order[t]
                    if (vertices[j, 0] == vertices[i, 0]
                            and vertices[j, 1] == vertices[i, 1]
                            and vertices[j, 2] == vertices[i, 2]):
                        rep[i] = j  # j < i: a partition is in index order
                        break
                s = (s + 1) & mask
    group = order  # reused: order is no longer needed
    first = np.empty(n, dtype=np.int64)
    n_groups = 0
    for i in range(n):
        j = rep[i]
        if j == i:
            group[i] = n_groups
            first[n_groups] = i
            n_groups += 1
        else:
            group[i] = group[j]
    return group, first[:n_groups].copy()


@kernel(
    types.Tuple((I64_2D_OUT, I64_2D_OUT, I64, I64, I64))(I64_2D, I64_2D, B1),
    parallel=True,
)
def clean_mesh(vertices, faces, merge):
    """Merge equal positions, drop faces with a repeated vertex and unused vertices.

    Returns ``(vertices, faces, n_merged, n_unused, n_degenerate)``. Kept vertices
    are the first occurrence of each position, in their original order; kept faces
    keep their order and winding. Without ``merge`` only repeated indices and
    unused vertices are removed.

    Preconditions: 0 <= faces < len(vertices).
    """
    n_v = vertices.shape[0]
    if merge:
        group, first = merge_vertices(vertices)
    else:
        group = np.arange(n_v)
        first = np.arange(n_v)
    n_groups = first.shape[0]
    used = np.zeros(n_groups + 1, dtype=np.int64)
    n_faces = faces.shape[0]
    # chunks of faces in parallel: mark used groups, count degenerate faces
    n_chunks = 64
    step = (n_faces + n_chunks - 1) // n_chunks
    deg_of = np.zeros(n_chunks + 1, dtype=np.int64)
    for c in prange(n_chunks):
        count = 0
        for f in range(c * step, min(n_faces, (c + 1) * step)):
            a = group[faces[f, 0]]
            b = group[faces[f, 1]]
            e = group[faces[f, 2]]
            if a == b or b == e or e == a:
                count += 1
            else:  # every writer stores the same value
                used[a] = 1
                used[b] = 1
                used[e] = 1
        deg_of[c + 1] = count
    for c in range(n_chunks):
        deg_of[c + 1] += deg_of[c]
    n_deg = deg_of[n_chunks]
    # groups are in order of their first vertex: numbering the used ones in group
    # order keeps the original vertex order
    n_kept = 0
    for g in range(n_groups):
        if used[g]:
            used[g] = n_kept
            n_kept += 1
        else:
            used[g] = -1
    out_v = np.empty((n_kept, 3), dtype=np.int64)
    for g in range(n_groups):
        k = used[g]
        if k >= 0:
            out_v[k, 0] = vertices[first[g], 0]
            out_v[k, 1] = vertices[first[g], 1]
            out_v[k, 2] = vertices[first[g], 2]
    out_f = np.empty((n_faces - n_deg, 3), dtype=np.int64)
    for c in prange(n_chunks):
        j = c * step - deg_of[c]  # kept faces before this chunk
        for f in range(c * step, min(n_faces, (c + 1) * step)):
            a = group[faces[f, 0]]
            b = group[faces[f, 1]]
            e = group[faces[f, 2]]
            if not (a == b or b == e or e == a):
                out_f[j, 0] = used[a]
                out_f[j, 1] = used[b]
                out_f[j, 2] = used[e]
                j += 1
    return out_v, out_f, n_v - n_groups, n_groups - n_kept, n_deg
