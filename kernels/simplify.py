"""CuraEngine-exact simplification of rings and polylines, plus ring clean-up kernels.

One call processes a whole ragged array ``(coords, ring_offsets)``. Each ring is
simplified independently into a buffer the size of the input (ring ``r`` writes at
``ring_offsets[r]``), and the buffer is then compacted in place; rings whose
result is empty keep a zero-length range, so output ring ``r`` still belongs to
input ring ``r``.

The algorithm is CuraEngine's ``Simplify::simplify`` (see ``spec/SIMPLIFY.md``):
a min-heap of ``(importance, index)`` with stale entries re-pushed, passes until
one removes nothing, size guards that use the ORIGINAL vertex count, and the
replacement of a short edge by the intersection of its neighbouring edges.
CuraEngine walks a ``to_delete`` array to find the nearest kept neighbours; here a
doubly linked list over the kept vertices gives the same neighbours in O(1).

Preconditions (the caller checks them): |coords| < 2**30; ring_offsets starts at
0, never decreases and ends at len(coords); 0 <= thresholds < 2**31; widths, where
given, satisfy |w| < 2**30.
"""

import numpy as np
from numba import njit, prange, types

from ._types import B1, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .geometry import (
    dist2_from_line,
    dist2_from_segment,
    line_line_intersection,
    tdiv,
    vsize,
)

INT64_MAX = np.iinfo(np.int64).max
MIN_RES2 = 25  # CuraEngine's min_resolution (5 µm), squared

_OPTS = {"cache": True, "nogil": True}
_INL = {"cache": True, "nogil": True, "inline": "always"}  # hot helpers
_W1 = types.int64[::1]  # writable work arrays


@njit(I64(_W1, _W1, _W1, I64, I64, I64), **_INL)
def _area_deviation(px, py, pw, b, v, a):
    """Extrusion-area deviation of removing vertex ``v`` between ``b`` and ``a``."""
    ab = vsize(px[v] - px[b], py[v] - py[b])
    bc = vsize(px[a] - px[v], py[a] - py[v])
    ac = vsize(px[a] - px[b], py[a] - py[b])
    if ab == 0 or ac == 0 or bc == 0:
        return 0
    wd = max(abs(pw[v] - pw[b]), abs(pw[a] - pw[v]))
    if wd > 1:
        ab_w = tdiv(pw[b] + pw[v], 2)
        bc_w = tdiv(pw[v] + pw[a], 2)
        avg = tdiv(ab * ab_w + bc * bc_w, ac)
        return abs(ab_w - avg) * ab + abs(bc_w - avg) * bc
    if ab > bc:
        return wd * bc
    return wd * ab


@njit(I64(_W1, _W1, _W1, B1, _W1, _W1, I64, I64, B1, I64, I64), **_INL)
def _importance(px, py, pw, has_w, prv, nxt, i, n, closed, max_res2, max_area):
    """CuraEngine's importance of kept vertex ``i`` (lower is removed first)."""
    if not closed and (i == 0 or i == n - 1):
        return INT64_MAX
    b = prv[i]
    a = nxt[i]
    if has_w and _area_deviation(px, py, pw, b, i, a) > max_area:
        return INT64_MAX
    d2 = dist2_from_line(px[i], py[i], px[b], py[b], px[a], py[a])
    if d2 <= MIN_RES2:
        return d2
    lb = (px[b] - px[i]) * (px[b] - px[i]) + (py[b] - py[i]) * (py[b] - py[i])
    la = (px[a] - px[i]) * (px[a] - px[i]) + (py[a] - py[i]) * (py[a] - py[i])
    if lb > max_res2 and la > max_res2:
        return INT64_MAX
    return d2


@njit(types.void(_W1, _W1, _W1, I64), **_INL)
def _unlink(prv, nxt, dele, i):
    p = prv[i]
    q = nxt[i]
    nxt[p] = q
    prv[q] = p
    dele[i] = 1


@njit(B1(_W1, _W1, _W1, B1, _W1, _W1, _W1, I64, I64, I64, B1, I64, I64), **_INL)
def _remove(px, py, pw, has_w, prv, nxt, dele, i, d2, n, closed, max_res2, max_dev2):
    """Try to remove vertex ``i`` (CuraEngine ``Simplify::remove``); True if removed."""
    if d2 <= MIN_RES2:
        _unlink(prv, nxt, dele, i)
        return True
    b = prv[i]
    a = nxt[i]
    lb = (px[i] - px[b]) * (px[i] - px[b]) + (py[i] - py[b]) * (py[i] - py[b])
    la = (px[i] - px[a]) * (px[i] - px[a]) + (py[i] - py[a]) * (py[i] - py[a])
    if lb <= max_res2 and la <= max_res2:
        _unlink(prv, nxt, dele, i)
        return True
    before_short = lb <= la
    if before_short:
        if not closed and b == 0:
            return False
        bb = prv[b]
        ok, x, y = line_line_intersection(
            px[bb], py[bb], px[b], py[b], px[i], py[i], px[a], py[a]
        )
        if not ok:
            return False
        dev = dist2_from_segment(px[b], py[b], x, y, px[i], py[i])
        moved = b
    else:
        if not closed and a == n - 1:
            return False
        aa = nxt[a]
        ok, x, y = line_line_intersection(
            px[b], py[b], px[i], py[i], px[a], py[a], px[aa], py[aa]
        )
        if not ok:
            return False
        dev = dist2_from_segment(px[i], py[i], x, y, px[a], py[a])
        moved = a
    if dev > max_dev2:
        return False
    _unlink(prv, nxt, dele, i)
    if has_w:
        pw[moved] = tdiv(pw[b] + pw[a], 2)
    px[moved] = x
    py[moved] = y
    return True


@njit(types.void(_W1, _W1, I64, I64), **_INL)
def _sift_down(hk, hi, pos, size):
    """Restore the heap below ``pos``; entries ordered by (key, index)."""
    k = hk[pos]
    v = hi[pos]
    while True:
        c = 2 * pos + 1
        if c >= size:
            break
        r = c + 1
        if r < size and (hk[r] < hk[c] or (hk[r] == hk[c] and hi[r] < hi[c])):
            c = r
        if hk[c] < k or (hk[c] == k and hi[c] < v):
            hk[pos] = hk[c]
            hi[pos] = hi[c]
            pos = c
        else:
            break
    hk[pos] = k
    hi[pos] = v


@njit(types.void(_W1, _W1, I64, I64, I64), **_INL)
def _push(hk, hi, size, key, idx):
    """Insert (key, idx) into a heap holding ``size`` entries."""
    pos = size
    while pos > 0:
        parent = (pos - 1) >> 1
        if hk[parent] < key or (hk[parent] == key and hi[parent] < idx):
            break
        hk[pos] = hk[parent]
        hi[pos] = hi[parent]
        pos = parent
    hk[pos] = key
    hi[pos] = idx


@njit(
    I64(_W1, _W1, _W1, B1, I64, B1, I64, I64, I64, _W1, _W1, _W1, _W1, _W1),
    **_OPTS,
)
def _simplify_one(px, py, pw, has_w, n, closed, max_res2, max_dev2, max_area,
                  prv, nxt, dele, hk, hi):
    """Simplify the ring held in ``px[:n], py[:n]`` in place; return its new size.

    Kept vertices are compacted to the front of px/py/pw, in their original order.
    Work arrays (length >= n): prv, nxt, dele, hk, hi.
    """
    min_size = 3 if closed else 2
    if n < min_size:
        return 0
    if n == min_size:
        d1 = (px[1] - px[0]) * (px[1] - px[0]) + (py[1] - py[0]) * (py[1] - py[0])
        d2 = (px[n - 1] - px[0]) * (px[n - 1] - px[0]) + (
            py[n - 1] - py[0]) * (py[n - 1] - py[0])
        d3 = (px[n - 1] - px[1]) * (px[n - 1] - px[1]) + (
            py[n - 1] - py[1]) * (py[n - 1] - py[1])
        if max(max(d1, d2), d3) < MIN_RES2:
            return 0
        return n
    for i in range(n):
        prv[i] = i - 1
        nxt[i] = i + 1
        dele[i] = 0
    prv[0] = n - 1
    nxt[n - 1] = 0
    removed = -1
    # every pass that continues removes >= 1 vertex, so at most n passes
    while n - removed > min_size and removed != 0:
        removed = 0
        size = 0
        for i in range(n):
            if dele[i] == 0:
                hk[size] = _importance(px, py, pw, has_w, prv, nxt, i, n, closed,
                                       max_res2, max_area)
                hi[size] = i
                size += 1
        for pos in range(size // 2 - 1, -1, -1):
            _sift_down(hk, hi, pos, size)
        # each vertex has at most one heap entry; an entry is re-pushed only when
        # its importance changed, which needs a removal in between, so this ends
        while size > 0 and n - removed > min_size:
            imp = hk[0]
            i = hi[0]
            size -= 1
            if size > 0:
                hk[0] = hk[size]
                hi[0] = hi[size]
                _sift_down(hk, hi, 0, size)
            cur = _importance(px, py, pw, has_w, prv, nxt, i, n, closed,
                              max_res2, max_area)
            if cur != imp:
                _push(hk, hi, size, cur, i)
                size += 1
                continue
            if cur <= max_dev2:
                if _remove(px, py, pw, has_w, prv, nxt, dele, i, cur, n, closed,
                           max_res2, max_dev2):
                    removed += 1
    m = 0
    for i in range(n):
        if dele[i] == 0:
            px[m] = px[i]
            py[m] = py[i]
            pw[m] = pw[i]
            m += 1
    if m < min_size:
        return 0
    if m == min_size:
        d1 = (px[1] - px[0]) * (px[1] - px[0]) + (py[1] - py[0]) * (py[1] - py[0])
        d2 = (px[m - 1] - px[0]) * (px[m - 1] - px[0]) + (
            py[m - 1] - py[0]) * (py[m - 1] - py[0])
        d3 = (px[m - 1] - px[1]) * (px[m - 1] - px[1]) + (
            py[m - 1] - py[1]) * (py[m - 1] - py[1])
        if max(max(d1, d2), d3) < MIN_RES2:
            return 0
    return m


@njit(
    types.Tuple((I64_2D_OUT, I64_1D_OUT, I64_1D_OUT))(
        I64_2D, I64_1D, I64_1D, B1, B1, I64, I64, I64
    ),
    cache=True, nogil=True, parallel=True,
)
def _simplify_core(coords, widths, ring_offsets, has_w, closed, max_resolution,
                   max_deviation, max_area_deviation):
    """Simplify all rings: chunks of rings in parallel, then compact serially.

    Ring ``r`` writes its result at its own input offset (a result is never
    longer than its input), so chunks never overlap; counts are then scanned and
    the rings moved forward in order.
    """
    n_rings = ring_offsets.shape[0] - 1
    n_all = coords.shape[0]
    max_res2 = max_resolution * max_resolution
    max_dev2 = max_deviation * max_deviation
    # chunks of consecutive rings with about equal vertex counts
    n_chunks = min(n_rings, 64)
    bounds = np.zeros(n_chunks + 1, np.int64)
    r = 0
    for c in range(1, n_chunks):
        target = (n_all * c) // n_chunks
        while r < n_rings and ring_offsets[r] < target:
            r += 1
        bounds[c] = r
    bounds[n_chunks] = n_rings
    buf = np.empty((n_all, 2), np.int64)
    buf_w = np.empty(n_all if has_w else 0, np.int64)
    counts = np.zeros(n_rings, np.int64)
    for c in prange(n_chunks):
        r0 = bounds[c]
        r1 = bounds[c + 1]
        max_len = 0
        for rr in range(r0, r1):
            max_len = max(max_len, ring_offsets[rr + 1] - ring_offsets[rr])
        px = np.empty(max_len, np.int64)
        py = np.empty(max_len, np.int64)
        pw = np.zeros(max_len, np.int64)
        prv = np.empty(max_len, np.int64)
        nxt = np.empty(max_len, np.int64)
        dele = np.empty(max_len, np.int64)
        hk = np.empty(max_len, np.int64)
        hi = np.empty(max_len, np.int64)
        for rr in range(r0, r1):
            start = ring_offsets[rr]
            n = ring_offsets[rr + 1] - start
            for k in range(n):
                px[k] = coords[start + k, 0]
                py[k] = coords[start + k, 1]
                if has_w:
                    pw[k] = widths[start + k]
            m = _simplify_one(px, py, pw, has_w, n, closed, max_res2, max_dev2,
                              max_area_deviation, prv, nxt, dele, hk, hi)
            for k in range(m):
                buf[start + k, 0] = px[k]
                buf[start + k, 1] = py[k]
                if has_w:
                    buf_w[start + k] = pw[k]
            counts[rr] = m
    new_offsets = np.empty(n_rings + 1, np.int64)
    new_offsets[0] = 0
    for rr in range(n_rings):
        new_offsets[rr + 1] = new_offsets[rr] + counts[rr]
    j = new_offsets[n_rings]
    out = np.empty((j, 2), np.int64)
    out_w = np.empty(j if has_w else 0, np.int64)
    for rr in range(n_rings):
        src = ring_offsets[rr]
        dst = new_offsets[rr]
        for k in range(counts[rr]):
            out[dst + k, 0] = buf[src + k, 0]
            out[dst + k, 1] = buf[src + k, 1]
            if has_w:
                out_w[dst + k] = buf_w[src + k]
    return out, out_w, new_offsets


@njit(
    types.Tuple((I64_2D_OUT, I64_1D_OUT))(I64_2D, I64_1D, B1, I64, I64, I64),
    **_OPTS,
)
def simplify_rings(coords, ring_offsets, closed, max_resolution, max_deviation,
                   max_area_deviation):
    """Simplify every ring (``closed``) or polyline (not ``closed``) like CuraEngine.

    Returns ``(new_coords, new_ring_offsets)`` with one (possibly empty) output
    ring per input ring. ``max_area_deviation`` has no effect without widths.
    """
    widths = np.empty(0, np.int64)
    out, _, offs = _simplify_core(coords, widths, ring_offsets, False, closed,
                                  max_resolution, max_deviation,
                                  max_area_deviation)
    return out, offs


@njit(
    types.Tuple((I64_2D_OUT, I64_1D_OUT, I64_1D_OUT))(
        I64_2D, I64_1D, I64_1D, B1, I64, I64, I64
    ),
    **_OPTS,
)
def simplify_rings_w(coords, widths, ring_offsets, closed, max_resolution,
                     max_deviation, max_area_deviation):
    """Variable-width variant of :func:`simplify_rings` (CuraEngine ExtrusionLine).

    ``widths`` (N,) holds each vertex's line width. Returns ``(new_coords,
    new_widths, new_ring_offsets)``; an intersection vertex gets the truncated
    mean width of the removed vertex's two neighbours.
    """
    return _simplify_core(coords, widths, ring_offsets, True, closed,
                          max_resolution, max_deviation, max_area_deviation)


@njit(I64_1D_OUT(I64_2D, I64_1D), **_OPTS)
def ring_perimeters(coords, ring_offsets):
    """Perimeter of each closed ring as CuraEngine's ``polygonLength``.

    The sum of ``vsize`` (rounded) of every edge including the closing edge; 0 for
    rings of fewer than 2 vertices.
    """
    n_rings = ring_offsets.shape[0] - 1
    out = np.zeros(n_rings, np.int64)
    for r in range(n_rings):
        start = ring_offsets[r]
        stop = ring_offsets[r + 1]
        if stop - start < 2:
            continue
        acc = 0
        qx = coords[stop - 1, 0]
        qy = coords[stop - 1, 1]
        for i in range(start, stop):
            acc += vsize(coords[i, 0] - qx, coords[i, 1] - qy)
            qx = coords[i, 0]
            qy = coords[i, 1]
        out[r] = acc
    return out


@njit(B1(I64, I64, I64, I64, I64, I64), **_OPTS)
def _reverses(lx, ly, cx, cy, nx, ny):
    """CuraEngine's isDegenerate: dot(now-last, next-now) == -|now-last|*|next-now|."""
    ax = cx - lx
    ay = cy - ly
    bx = nx - cx
    by = ny - cy
    return ax * bx + ay * by == -1 * vsize(ax, ay) * vsize(bx, by)


@njit(types.Tuple((I64_2D_OUT, I64_1D_OUT))(I64_2D, I64_1D), **_OPTS)
def remove_degenerate_vertices(coords, ring_offsets):
    """Remove vertices where a closed ring exactly reverses, as CuraEngine does.

    CuraEngine's ``removeDegenerateVerts`` for closed polygons: one pass over the
    ring with the output as a stack; a vertex ``now`` is dropped when
    ``dot(now - last, next - now) == -vsize(now - last) * vsize(next - now)``
    (``last`` = top of the stack, or the ring's last vertex while the stack is
    empty; ``next`` = the following input vertex, or the first kept vertex at the
    end), and after each drop the stack is popped while its top vertex is
    degenerate towards ``next``. A changed ring left with <= 2 vertices becomes
    empty (a zero-length range); an unchanged ring is copied as is. Returns
    ``(new_coords, new_ring_offsets)`` with one output ring per input ring.
    """
    n_rings = ring_offsets.shape[0] - 1
    out = np.empty((coords.shape[0], 2), np.int64)
    new_offsets = np.empty(n_rings + 1, np.int64)
    new_offsets[0] = 0
    j = 0
    for r in range(n_rings):
        start = ring_offsets[r]
        stop = ring_offsets[r + 1]
        n = stop - start
        top = 0  # stack out[j:j + top]
        changed = False
        for idx in range(n):
            if top == 0:
                lx = coords[stop - 1, 0]
                ly = coords[stop - 1, 1]
            else:
                lx = out[j + top - 1, 0]
                ly = out[j + top - 1, 1]
            if idx + 1 >= n:
                if top == 0:
                    break
                nx = out[j, 0]
                ny = out[j, 1]
            else:
                nx = coords[start + idx + 1, 0]
                ny = coords[start + idx + 1, 1]
            cx = coords[start + idx, 0]
            cy = coords[start + idx, 1]
            if _reverses(lx, ly, cx, cy, nx, ny):
                changed = True
                while top > 1 and _reverses(
                    out[j + top - 2, 0], out[j + top - 2, 1],
                    out[j + top - 1, 0], out[j + top - 1, 1], nx, ny,
                ):
                    top -= 1
            else:
                out[j + top, 0] = cx
                out[j + top, 1] = cy
                top += 1
        if not changed:
            for k in range(n):
                out[j + k, 0] = coords[start + k, 0]
                out[j + k, 1] = coords[start + k, 1]
            top = n
        elif top <= 2:
            top = 0
        j += top
        new_offsets[r + 1] = j
    return out[:j].copy(), new_offsets
