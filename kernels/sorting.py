"""A stable argsort kernel, and the small search helpers other kernels share.

``np.argsort(kind="mergesort")`` inside a kernel costs numba over a second to
compile at every first use; this plain bottom-up merge sort compiles once, in a
fraction of that, and returns the same permutation (the stable order).

:func:`lower_bound` (a binary search), :func:`table_bits` (the size of an
open-addressing hash table) and :func:`mix_hash` (the hash of an integer
triple those tables are keyed by) are inlined into the kernels that call them.
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import I64, I64_1D, I64_1D_OUT

__all__ = ["lower_bound", "mix_hash", "stable_argsort", "table_bits"]

_RUN = 16  # runs of this length are sorted by insertion first


@kernel(inline="always")
def lower_bound(a, lo, hi, x):
    """The first ``i`` in ``lo:hi`` with ``a[i] >= x`` (``hi`` if none).

    ``a[lo:hi]`` ascends.
    """
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@kernel(inline="always")
def table_bits(m):
    """The fewest bits ``b >= 1`` with ``2**b >= 2 * m``.

    A hash table of ``2**b`` slots for ``m`` keys is at most half full.
    """
    b = 1
    while (np.int64(1) << b) < 2 * m:
        b += 1
    return b


# odd 64-bit multipliers (from splitmix64 and the golden ratio) mixing x, y, z
_MIX_X = np.int64(-7046029254386353131)  # 0x9E3779B97F4A7C15
_MIX_Y = np.int64(-4658895280553007687)  # 0xBF58476D1CE4E5B9
_MIX_Z = np.int64(-7723592293110705685)  # 0x94D049BB133111EB


@kernel(inline="always")
def mix_hash(x, y, z):
    """A well-mixed 64-bit hash of an integer triple (wrapping int64 arithmetic).

    Its top bits pick a partition, the bits below them a slot: vertex positions
    (``vertices.merge_vertices``) and CuraEngine's hash cells
    (``cura_mesh.group_cells``).
    """
    h = x * _MIX_X + y * _MIX_Y + z * _MIX_Z
    h ^= h >> 29
    h *= _MIX_X
    return np.uint64(h)


@kernel(types.void(I64_1D, I64_1D, types.int64[::1], I64))
def _merge_runs(key, src, dst, width):
    """Merge each pair of sorted runs of ``width`` in ``src`` into ``dst`` (stable)."""
    n = src.shape[0]
    for lo in range(0, n, 2 * width):
        mid = min(n, lo + width)
        hi = min(n, lo + 2 * width)
        i = lo
        j = mid
        for w in range(lo, hi):
            # take from the left run unless the right one is strictly smaller
            if i < mid and (j >= hi or key[src[j]] >= key[src[i]]):
                dst[w] = src[i]
                i += 1
            else:
                dst[w] = src[j]
                j += 1


@kernel(I64_1D_OUT(I64_1D))
def stable_argsort(key):
    """``np.argsort(key, kind="stable")``: indices that sort ``key``, ties in order.

    Insertion sort of runs of 16, then bottom-up merges between two buffers:
    O(n log n) time, n extra indices.
    """
    n = key.shape[0]
    a = np.empty(n, dtype=np.int64)
    for i in range(n):
        a[i] = i
    for lo in range(0, n, _RUN):
        hi = min(n, lo + _RUN)
        for i in range(lo + 1, hi):
            t = a[i]
            kt = key[t]
            j = i - 1
            while j >= lo and key[a[j]] > kt:
                a[j + 1] = a[j]
                j -= 1
            a[j + 1] = t
    b = np.empty(n, dtype=np.int64)
    width = _RUN
    in_a = True
    while width < n:
        if in_a:
            _merge_runs(key, a, b, width)
        else:
            _merge_runs(key, b, a, width)
        in_a = not in_a
        width *= 2
    if not in_a:
        for i in range(n):
            a[i] = b[i]
    return a
