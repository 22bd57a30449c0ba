"""Kernels merging equal vertex positions and cleaning the faces that index them."""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, I64, I64_1D_OUT, I64_2D, I64_2D_OUT

# odd 64-bit multipliers (from splitmix64 and the golden ratio) mixing x, y, z
_MIX_X = np.int64(-7046029254386353131)  # 0x9E3779B97F4A7C15
_MIX_Y = np.int64(-4658895280553007687)  # 0xBF58476D1CE4E5B9
_MIX_Z = np.int64(-7723592293110705685)  # 0x94D049BB133111EB


@kernel(inline="always")
def _slot(x, y, z, shift):
    """Hash of a position: the top bits of a multiplicative mix (wrapping int64)."""
    h = x * _MIX_X + y * _MIX_Y + z * _MIX_Z
    h ^= h >> 29
    h *= _MIX_X
    return np.int64(np.uint64(h) >> np.uint64(shift))


@kernel(types.Tuple((I64_1D_OUT, I64_1D_OUT))(I64_2D))
def merge_vertices(vertices):
    """Group vertices with exactly equal positions, in one hashed pass.

    Returns ``(group, first)``: ``group[i]`` is the group of vertex ``i``, groups
    numbered in order of first occurrence, and ``first[g]`` the first vertex of
    group ``g`` (increasing). Open addressing with linear probing in a table of at
    least twice as many slots as vertices: expected O(1) per vertex, exact
    comparison of all three coordinates.
    """
    n = vertices.shape[0]
    bits = 1
    while (1 << bits) < 2 * n:
        bits += 1
    size = np.int64(1) << bits
    mask = size - 1
    shift = 64 - bits
    table = np.full(size, -1, dtype=np.int64)  # a group id per used slot
    group = np.empty(n, dtype=np.int64)
    first = np.empty(n, dtype=np.int64)
    n_groups = 0
    for i in range(n):
        x = vertices[i, 0]
        y = vertices[i, 1]
        z = vertices[i, 2]
        s = _slot(x, y, z, shift)
        while True:
            g = table[s]
            if g < 0:
                table[s] = n_groups
                first[n_groups] = i
                group[i] = n_groups
                n_groups += 1
                break
            j = first[g]
            if vertices[j, 0] == x and vertices[j, 1] == y and vertices[j, 2] == z:
                group[i] = g
                break
            s = (s + 1) & mask
    return group, first[:n_groups].copy()


@kernel(
    types.Tuple((I64_2D_OUT, I64_2D_OUT, I64, I64, I64))(I64_2D, I64_2D, B1)
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
    n_deg = 0
    for f in range(n_faces):
        a = group[faces[f, 0]]
        b = group[faces[f, 1]]
        c = group[faces[f, 2]]
        if a == b or b == c or c == a:
            n_deg += 1
        else:
            used[a] = 1
            used[b] = 1
            used[c] = 1
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
    j = 0
    for f in range(n_faces):
        a = group[faces[f, 0]]
        b = group[faces[f, 1]]
        c = group[faces[f, 2]]
        if not (a == b or b == c or c == a):
            out_f[j, 0] = used[a]
            out_f[j, 1] = used[b]
            out_f[j, 2] = used[c]
            j += 1
    return out_v, out_f, n_v - n_groups, n_groups - n_kept, n_deg
