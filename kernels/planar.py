"""Planar integer geometry for the metrics kernels: distances, crossings, winding.

Points are int64 µm with |coordinate| < 2**30, so every difference fits 31 bits and
every cross or dot product of two differences fits int64 exactly; floats enter
only for square roots and rational intersection points.
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, F64, I64, I64_2D

_W2 = types.int64[:, ::1]


@kernel(inline="always")
def _segment_case(px, py, ax, ay, bx, by):
    """``(v, len2)`` in int64, the case of p against the closed segment a-b.

    Decided exactly: ``len2 == 0`` when an end point is nearest (then ``v`` is
    the squared distance to it), else ``v`` is the cross product ``(b - a) x
    (p - a)`` and ``len2 = |b - a|²`` (the distance is ``|v| / sqrt(len2)``).
    """
    dx = bx - ax
    dy = by - ay
    qx = px - ax
    qy = py - ay
    dot = qx * dx + qy * dy
    len2 = dx * dx + dy * dy
    if dot <= 0 or len2 == 0:
        return qx * qx + qy * qy, np.int64(0)
    if dot >= len2:
        rx = px - bx
        ry = py - by
        return rx * rx + ry * ry, np.int64(0)
    return dx * qy - dy * qx, len2


@kernel(F64(I64, I64, I64, I64, I64, I64), inline="always")
def _point_segment(px, py, ax, ay, bx, by):
    """Distance from p to the closed segment a-b, µm (float64).

    Which of the three cases applies is decided exactly in int64
    (:func:`_segment_case`); the distance is ``sqrt(float(d2))`` to an end point
    or ``|float(cross)| / sqrt(float(len2))``.
    """
    v, len2 = _segment_case(px, py, ax, ay, bx, by)
    if len2 == 0:
        return np.sqrt(np.float64(v))
    return abs(np.float64(v)) / np.sqrt(np.float64(len2))


@kernel(inline="always")
def _near_edge(px, py, c, start, n, i, count):
    """The nearest of edges ``i .. i+count-1`` of a ring to p: ``(num, den, k)``.

    The ring is ``c[start:start + n]`` (edge k joins vertex k to k+1, mod n;
    ``0 <= i < n``). The edge is chosen by squared distance without a square
    root or a division (``num1 * den2 < num2 * den1``, float64); ``num / den``
    is the chosen edge's squared distance (``den`` 1 when an end point is
    nearest), ``k`` the edge, or -1 (and ``num`` inf) when ``count`` is 0.
    """
    bn = np.inf
    bd = 1.0
    near = -1
    k = i
    for _ in range(count):
        k1 = k + 1 if k + 1 < n else 0
        v, len2 = _segment_case(px, py, c[start + k, 0], c[start + k, 1],
                                c[start + k1, 0], c[start + k1, 1])
        num = np.float64(v)
        den = 1.0
        if len2 != 0:
            num = num * num
            den = np.float64(len2)
        if num * bd < bn * den:
            bn = num
            bd = den
            near = k
        k = k1
    return bn, bd, near


@kernel(inline="always")
def _edge_distance(px, py, c, start, n, k):
    """:func:`_point_segment` from p to edge ``k`` of the ring; inf when k < 0."""
    if k < 0:
        return np.inf
    k1 = k + 1 if k + 1 < n else 0
    return _point_segment(px, py, c[start + k, 0], c[start + k, 1],
                          c[start + k1, 0], c[start + k1, 1])


@kernel(inline="always")
def _near_edge_distance(px, py, c, start, n, i, count):
    """Distance from p to the nearest of edges ``i .. i+count-1`` of a ring.

    The edge of :func:`_near_edge`, measured by :func:`_point_segment`: that
    value bounds the true minimum over these edges from above, whichever edge
    rounding chose. ``inf`` when ``count`` is 0.
    """
    return _edge_distance(px, py, c, start, n,
                          _near_edge(px, py, c, start, n, i, count)[2])


@kernel(F64(I64, I64, I64_2D, I64, I64), inline="always")
def _to_ring(px, py, c, start, n):
    """Distance from p to ring ``c[start:start + n]`` (closed), all edges."""
    best = np.inf
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        d = _point_segment(px, py, c[start + i, 0], c[start + i, 1],
                           c[start + j, 0], c[start + j, 1])
        if d < best:
            best = d
    return best


@kernel(F64(I64, I64, I64_2D, I64, I64, F64), inline="always")
def _to_ring_within(px, py, c, start, n, bound):
    """:func:`_to_ring`, bit for bit, given some edge's distance ``bound``.

    ``bound`` is one edge's ``_point_segment`` value. An edge with both ends
    more than ``r = floor(bound) + 1`` beyond p in x or in y is skipped without
    measuring it: with integer coordinates it lies at least ``r + 1 > bound + 1``
    away, so it cannot hold the minimum.
    """
    if not bound < 2.0**40:  # inf, or too far for the integer window
        return _to_ring(px, py, c, start, n)
    r = np.int64(bound) + 1
    x0 = px - r
    x1 = px + r
    y0 = py - r
    y1 = py + r
    best = np.inf
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        ax = c[start + i, 0]
        ay = c[start + i, 1]
        bx = c[start + j, 0]
        by = c[start + j, 1]
        if ((ax < x0 and bx < x0) or (ax > x1 and bx > x1)
                or (ay < y0 and by < y0) or (ay > y1 and by > y1)):
            continue
        d = _point_segment(px, py, ax, ay, bx, by)
        if d < best:
            best = d
    return best


_WALK = 64  # most steps of directed_distance's walk per vertex
_WF = types.float64[::1]


@kernel(F64(I64_2D, I64, I64, I64_2D, I64, I64, _WF))
def directed_distance(ac, a0, na, bc, b0, nb, ub):
    """Largest distance from a vertex of ring a to ring b, without correspondence.

    Bit for bit the maximum over all vertex-edge pairs of
    :func:`_point_segment`.

    A walk bounds every vertex: from the previous vertex's edge, along b's edges
    while the distance decreases (at most ``_WALK`` steps), so a vertex near the
    previous one's edge costs a few distances (the first vertex's edge is found
    over all edges). Then vertices are measured against all edges
    (:func:`_to_ring_within`), largest bound first, until no bound exceeds the
    best exact distance: a vertex whose bound does not cannot raise the maximum.
    Linear plus a sort when the bounds are tight (a ring against its reversal, a
    shifted copy, another tool's output); all pairs at worst. ``ub`` is scratch
    of length >= ``na``.
    """
    if na == 0 or nb == 0:
        best = 0.0
        for i in range(na):
            best = max(best, _to_ring(ac[a0 + i, 0], ac[a0 + i, 1], bc, b0, nb))
        return best
    k = _near_edge(ac[a0, 0], ac[a0, 1], bc, b0, nb, 0, nb)[2]
    top = 0
    for i in range(na):
        px = ac[a0 + i, 0]
        py = ac[a0 + i, 1]
        d = _edge_distance(px, py, bc, b0, nb, k)
        for _ in range(_WALK):
            kn = k + 1 if k + 1 < nb else 0
            dn = _edge_distance(px, py, bc, b0, nb, kn)
            if dn >= d:
                kn = k - 1 if k > 0 else nb - 1
                dn = _edge_distance(px, py, bc, b0, nb, kn)
                if dn >= d:
                    break
            k = kn
            d = dn
        ub[i] = d
        if d > ub[top]:
            top = i
    bound = ub[top]
    best = _to_ring_within(ac[a0 + top, 0], ac[a0 + top, 1], bc, b0, nb, bound)
    if best == bound:  # every other bound is <= it
        return best
    return settle_bounds(ac, a0, na, bc, b0, nb, ub, best)


@kernel(inline="always")
def settle_bounds(pc, p0, npts, rc, r0, n, ub, best):
    """The largest distance from points ``pc[p0:p0 + npts]`` to ring ``rc[r0:r0 + n]``.

    Given each point's bound ``ub[j]`` (some edge's distance, so at least the
    point's own) and ``best``, an exact distance already found: the points whose
    bound exceeds the best so far are measured against all edges, largest bound
    first, until none does.
    """
    order = np.argsort(-ub[:npts])
    for t in range(npts):
        j = order[t]
        if ub[j] <= best:
            break
        best = max(best, _to_ring_within(pc[p0 + j, 0], pc[p0 + j, 1], rc, r0, n,
                                         ub[j]))
    return best


@kernel(I64(I64, I64, I64, I64, I64, I64), inline="always")
def _orient(ax, ay, bx, by, cx, cy):
    """Sign of the turn a -> b -> c (exact)."""
    v = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    if v > 0:
        return np.int64(1)
    if v < 0:
        return np.int64(-1)
    return np.int64(0)


@kernel(F64(_W2, I64, F64), inline="always")
def _y_at(e, i, x):
    """Y of (non-vertical) edge ``e[i]`` at abscissa x."""
    x0 = np.float64(e[i, 0])
    y0 = np.float64(e[i, 1])
    return y0 + (np.float64(e[i, 3]) - y0) * ((x - x0) / (np.float64(e[i, 2]) - x0))


@kernel(F64(_W2, I64))
def winding_area(e, ne):
    """``∫ |w| dA`` (µm²) of the directed edges ``e[:ne]`` = (x0, y0, x1, y1).

    The edges must form closed cycles; ``w`` is their winding number. A sweep over
    x: the slabs between consecutive vertex and crossing abscissae hold no
    crossing, so within a slab the edges are ordered by y and ``w`` is constant
    between neighbours. Time O((E + I) * A log A) for E edges, I crossings and at
    most A edges over one abscissa. Vertical edges bound no slab area and are
    dropped (``e`` is compacted in place).
    """
    k = 0
    for i in range(ne):
        if e[i, 0] != e[i, 2]:
            for c in range(4):
                e[k, c] = e[i, c]
            k += 1
    ne = k
    if ne == 0:
        return 0.0
    xmin = np.empty(ne, np.int64)
    xmax = np.empty(ne, np.int64)
    for i in range(ne):
        xmin[i] = min(e[i, 0], e[i, 2])
        xmax[i] = max(e[i, 0], e[i, 2])
    order = np.argsort(xmin)
    cap = 2 * ne + 16
    ev = np.empty(cap, np.float64)
    nev = 0
    for i in range(ne):
        ev[nev] = np.float64(e[i, 0])
        ev[nev + 1] = np.float64(e[i, 2])
        nev += 2
    active = np.empty(ne, np.int64)
    na = 0
    for ii in range(ne):
        f = order[ii]
        c = 0
        for a in range(na):
            g = active[a]
            if xmax[g] > xmin[f]:
                active[c] = g
                c += 1
        na = c
        ax = e[f, 0]
        ay = e[f, 1]
        bx = e[f, 2]
        by = e[f, 3]
        for a in range(na):
            g = active[a]
            cx = e[g, 0]
            cy = e[g, 1]
            dx = e[g, 2]
            dy = e[g, 3]
            if (_orient(ax, ay, bx, by, cx, cy) * _orient(ax, ay, bx, by, dx, dy) < 0
                    and _orient(cx, cy, dx, dy, ax, ay)
                    * _orient(cx, cy, dx, dy, bx, by) < 0):
                rx = bx - ax
                ry = by - ay
                num = (cx - ax) * (dy - cy) - (cy - ay) * (dx - cx)
                den = rx * (dy - cy) - ry * (dx - cx)
                if nev == cap:
                    cap *= 2
                    grown = np.empty(cap, np.float64)
                    grown[:nev] = ev[:nev]
                    ev = grown
                ev[nev] = np.float64(ax) + np.float64(rx) * (
                    np.float64(num) / np.float64(den))
                nev += 1
        active[na] = f
        na += 1
    ev = np.sort(ev[:nev])
    ym = np.empty(ne, np.float64)
    total = 0.0
    ptr = 0
    na = 0
    for s in range(nev - 1):
        xa = ev[s]
        xb = ev[s + 1]
        if not xb > xa:
            continue
        while ptr < ne and np.float64(xmin[order[ptr]]) <= xa:
            active[na] = order[ptr]
            na += 1
            ptr += 1
        c = 0
        for a in range(na):
            g = active[a]
            if np.float64(xmax[g]) > xa:
                active[c] = g
                c += 1
        na = c
        xm = 0.5 * (xa + xb)
        for a in range(na):  # insertion sort by y at mid-slab (nearly sorted)
            g = active[a]
            y = _y_at(e, g, xm)
            b = a
            while b > 0 and ym[b - 1] > y:
                ym[b] = ym[b - 1]
                active[b] = active[b - 1]
                b -= 1
            ym[b] = y
            active[b] = g
        w = 0
        acc = 0.0
        for a in range(na - 1):
            g = active[a]
            w += 1 if e[g, 2] > e[g, 0] else -1
            if w != 0:
                h = active[a + 1]
                acc += abs(w) * ((_y_at(e, h, xa) - _y_at(e, g, xa))
                                 + (_y_at(e, h, xb) - _y_at(e, g, xb)))
        total += acc * (xb - xa) * 0.5
    return total


@kernel(B1(I64, I64, I64, I64, I64, I64), inline="always")
def _on_box(ax, ay, bx, by, cx, cy):
    """C (collinear with a-b) lies on the closed segment a-b."""
    return (min(ax, bx) <= cx <= max(ax, bx)) and (min(ay, by) <= cy <= max(ay, by))


@kernel(B1(I64, I64, I64, I64, I64, I64, I64, I64), inline="always")
def _touch(ax, ay, bx, by, cx, cy, dx, dy):
    """Closed segments a-b and c-d share a point (exact)."""
    o1 = _orient(ax, ay, bx, by, cx, cy)
    o2 = _orient(ax, ay, bx, by, dx, dy)
    o3 = _orient(cx, cy, dx, dy, ax, ay)
    o4 = _orient(cx, cy, dx, dy, bx, by)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    return ((o1 == 0 and _on_box(ax, ay, bx, by, cx, cy))
            or (o2 == 0 and _on_box(ax, ay, bx, by, dx, dy))
            or (o3 == 0 and _on_box(cx, cy, dx, dy, ax, ay))
            or (o4 == 0 and _on_box(cx, cy, dx, dy, bx, by)))


@kernel(F64(I64, I64, I64, I64, I64, I64, I64, I64), inline="always")
def _segment_distance(ax, ay, bx, by, cx, cy, dx, dy):
    """Distance between closed segments a-b and c-d, µm (0 if they touch)."""
    if _touch(ax, ay, bx, by, cx, cy, dx, dy):
        return 0.0
    d = _point_segment(ax, ay, cx, cy, dx, dy)
    d = min(d, _point_segment(bx, by, cx, cy, dx, dy))
    d = min(d, _point_segment(cx, cy, ax, ay, bx, by))
    return min(d, _point_segment(dx, dy, ax, ay, bx, by))
