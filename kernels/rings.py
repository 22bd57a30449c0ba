"""Kernels over rings of a ragged (coords, ring_offsets) array."""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1_1D, B1_1D_OUT, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT

AREA2_BEYOND_INT64 = -(2**63)
""":func:`ring_area2` of a ring whose twice-area is not in (-2**63, 2**63)."""


@kernel(I64_1D_OUT(I64_2D, I64_1D))
def ring_area2(coords, ring_offsets):
    """Twice the signed area of each ring (exact; CCW > 0).

    Each fan term fits int64 (|coords| < 2**30), but their sum over a ring that
    winds around more than once near the coordinate limit may not: the sum is
    kept exactly in two halves (the terms' high and low 32 bits), and a ring
    whose twice-area is not in (-2**63, 2**63) gives ``AREA2_BEYOND_INT64``
    (-2**63) instead of a wrapped value. Simple rings always fit.

    Preconditions (the caller checks them): |coords| < 2**30; ring_offsets starts at
    0, never decreases and ends at len(coords); rings have < 2**31 vertices.
    """
    n_rings = ring_offsets.shape[0] - 1
    out = np.empty(n_rings, dtype=np.int64)
    for r in range(n_rings):
        start, stop = ring_offsets[r], ring_offsets[r + 1]
        hi = 0  # sum of the terms' t >> 32: |each| <= 2**31
        lo = 0  # sum of their t & (2**32 - 1): each < 2**32
        if stop - start >= 3:
            x0, y0 = coords[start, 0], coords[start, 1]
            for i in range(start + 1, stop - 1):
                ax, ay = coords[i, 0] - x0, coords[i, 1] - y0
                bx, by = coords[i + 1, 0] - x0, coords[i + 1, 1] - y0
                t = ax * by - ay * bx
                hi += t >> 32
                lo += t & 0xFFFFFFFF
        hi += lo >> 32  # the exact sum is hi * 2**32 + lo, 0 <= lo < 2**32
        lo &= 0xFFFFFFFF
        if -(2**31) <= hi < 2**31 and (hi > -(2**31) or lo > 0):
            out[r] = hi * 2**32 + lo
        else:
            out[r] = AREA2_BEYOND_INT64
    return out


@kernel(
    types.Tuple((I64_2D_OUT, I64_1D_OUT, I64_1D_OUT))(
        I64_2D, I64_1D, I64_1D, I64_1D, I64
    ),
)
def group_rings(points, vertex_ids, ring_offsets, ring_key, n_keys):
    """Gather ring vertices from ``points`` and group the rings by key (stable).

    Ring ``i`` has vertices ``points[vertex_ids[ring_offsets[i]:ring_offsets[i+1]]]``
    and key ``ring_key[i]`` in ``[0, n_keys)``. Returns ``(coords, new_ring_offsets,
    key_offsets)``: rings with key ``k`` are ``key_offsets[k]:key_offsets[k + 1]``,
    in their original relative order.

    Preconditions: offsets valid; 0 <= vertex_ids < len(points); 0 <= ring_key <
    n_keys.
    """
    n_rings = ring_offsets.shape[0] - 1
    key_offsets = np.zeros(n_keys + 1, dtype=np.int64)
    for r in range(n_rings):
        key_offsets[ring_key[r] + 1] += 1
    for k in range(n_keys):
        key_offsets[k + 1] += key_offsets[k]
    fill = key_offsets[:-1].copy()
    order = np.empty(n_rings, dtype=np.int64)
    for r in range(n_rings):
        order[fill[ring_key[r]]] = r
        fill[ring_key[r]] += 1
    new_offsets = np.empty(n_rings + 1, dtype=np.int64)
    new_offsets[0] = 0
    for i in range(n_rings):
        r = order[i]
        new_offsets[i + 1] = new_offsets[i] + ring_offsets[r + 1] - ring_offsets[r]
    coords = np.empty((new_offsets[n_rings], 2), dtype=np.int64)
    for i in range(n_rings):
        r = order[i]
        j = new_offsets[i]
        for v in range(ring_offsets[r], ring_offsets[r + 1]):
            p = vertex_ids[v]
            coords[j, 0] = points[p, 0]
            coords[j, 1] = points[p, 1]
            j += 1
    return coords, new_offsets, key_offsets


@kernel(types.Tuple((I64_2D_OUT, I64_1D_OUT))(I64_2D, I64_1D, B1_1D))
def take_rings(coords, ring_offsets, keep):
    """The rings where ``keep`` is true, in order: ``(coords, ring_offsets)``.

    Each kept ring's vertices are copied in order; nothing per vertex but the
    copy (element by element: a slice assignment costs seconds to compile).
    Preconditions: offsets valid; ``len(keep) == len(ring_offsets) - 1``.
    """
    n_rings = ring_offsets.shape[0] - 1
    n_kept = 0
    n_coords = 0
    for r in range(n_rings):
        if keep[r]:
            n_kept += 1
            n_coords += ring_offsets[r + 1] - ring_offsets[r]
    out = np.empty((n_coords, 2), dtype=np.int64)
    offsets = np.empty(n_kept + 1, dtype=np.int64)
    offsets[0] = 0
    j = 0
    i = 0
    for r in range(n_rings):
        if keep[r]:
            for v in range(ring_offsets[r], ring_offsets[r + 1]):
                out[j, 0] = coords[v, 0]
                out[j, 1] = coords[v, 1]
                j += 1
            i += 1
            offsets[i] = j
    return out, offsets


_MIX = np.uint64(0x9E3779B97F4A7C15)  # unsigned: products wrap (defined)
_SHIFT = np.uint64(29)


@kernel(I64_1D_OUT(I64_2D, I64_1D))
def ring_keys(coords, ring_offsets):
    """A 64-bit key of each ring: its index, vertex count and coordinates, mixed.

    Equal keys for ring ``r`` of two arrays when both rings ``r`` have the same
    vertices in the same order. Different rings may share a key (rarely): a
    caller that reuses something by key confirms with :func:`rings_equal`.
    The mixing is unsigned (uint64 products wrap; int64 overflow would be
    undefined to LLVM). Preconditions: offsets valid.
    """
    n_rings = ring_offsets.shape[0] - 1
    out = np.empty(n_rings, dtype=np.int64)
    for r in range(n_rings):
        start, stop = ring_offsets[r], ring_offsets[r + 1]
        h = np.uint64(r + 1) * _MIX
        h = (h ^ np.uint64(stop - start)) * _MIX
        for v in range(start, stop):
            h = (h ^ np.uint64(coords[v, 0])) * _MIX
            h = (h ^ np.uint64(coords[v, 1])) * _MIX
            h ^= h >> _SHIFT
        out[r] = np.int64(h)
    return out


@kernel(B1_1D_OUT(I64_2D, I64_1D, I64_1D, I64_2D, I64_1D, I64_1D))
def rings_equal(a, a_offsets, ia, b, b_offsets, ib):
    """``out[k]``: ring ``ia[k]`` of ``a`` has the vertices of ring ``ib[k]`` of ``b``.

    The same vertex count and the same vertices in the same order.
    Preconditions: offsets valid; the indices within them; ``len(ia) == len(ib)``.
    """
    n = ia.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for k in range(n):
        sa = a_offsets[ia[k]]
        sb = b_offsets[ib[k]]
        m = a_offsets[ia[k] + 1] - sa
        same = m == b_offsets[ib[k] + 1] - sb
        i = 0
        while same and i < m:
            same = a[sa + i, 0] == b[sb + i, 0] and a[sa + i, 1] == b[sb + i, 1]
            i += 1
        out[k] = same
    return out
