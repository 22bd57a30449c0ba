"""Slow pure-Python references for kernels/metrics.py (all pairs, exact sweeps)."""

from __future__ import annotations

import math
from fractions import Fraction


def point_segment(p, a, b) -> float:
    """The kernel's formula: exact int case split, one float64 expression."""
    px, py = int(p[0]), int(p[1])
    ax, ay, bx, by = int(a[0]), int(a[1]), int(b[0]), int(b[1])
    dx, dy, qx, qy = bx - ax, by - ay, px - ax, py - ay
    dot = qx * dx + qy * dy
    len2 = dx * dx + dy * dy
    if dot <= 0 or len2 == 0:
        return math.sqrt(float(qx * qx + qy * qy))
    if dot >= len2:
        return math.sqrt(float((px - bx) ** 2 + (py - by) ** 2))
    return abs(float(dx * qy - dy * qx)) / math.sqrt(float(len2))


def exact_point_segment2(p, a, b) -> Fraction:
    """Squared point-segment distance as an exact rational."""
    px, py = int(p[0]), int(p[1])
    ax, ay, bx, by = int(a[0]), int(a[1]), int(b[0]), int(b[1])
    dx, dy, qx, qy = bx - ax, by - ay, px - ax, py - ay
    len2 = dx * dx + dy * dy
    dot = qx * dx + qy * dy
    if dot <= 0 or len2 == 0:
        return Fraction(qx * qx + qy * qy)
    if dot >= len2:
        return Fraction((px - bx) ** 2 + (py - by) ** 2)
    return Fraction((dx * qy - dy * qx) ** 2, len2)


def max_vertex_distance(a, b) -> float:
    """Largest distance from a vertex of ring a to ring b, over ALL pairs."""
    best = 0.0
    nb = len(b)
    for p in a:
        d = min(point_segment(p, b[i], b[(i + 1) % nb]) for i in range(nb))
        best = max(best, d)
    return best


def winding_area(rings) -> Fraction:
    """``∫ |w| dA`` of closed rings (lists of integer points), exactly.

    Slabs between every vertex and crossing abscissa (rationals); in each slab
    the edges are ordered by y at mid-slab and |w| weights the trapezoids.
    """
    edges = []
    for r in rings:
        n = len(r)
        for i in range(n):
            a = (int(r[i][0]), int(r[i][1]))
            b = (int(r[(i + 1) % n][0]), int(r[(i + 1) % n][1]))
            if a[0] != b[0]:
                edges.append((a, b))
    xs = {Fraction(x) for e in edges for x in (e[0][0], e[1][0])}
    for i, (a, b) in enumerate(edges):
        for c, d in edges[:i]:
            rx, ry = b[0] - a[0], b[1] - a[1]
            sx, sy = d[0] - c[0], d[1] - c[1]
            den = rx * sy - ry * sx
            if den == 0:
                continue
            t = Fraction((c[0] - a[0]) * sy - (c[1] - a[1]) * sx, den)
            u = Fraction((c[0] - a[0]) * ry - (c[1] - a[1]) * rx, den)
            if 0 < t < 1 and 0 < u < 1:
                xs.add(a[0] + t * rx)
    xs = sorted(xs)

    def y_at(e, x):
        (x0, y0), (x1, y1) = e
        return y0 + (y1 - y0) * (x - x0) / Fraction(x1 - x0)

    total = Fraction(0)
    for xa, xb in zip(xs, xs[1:]):
        xm = (xa + xb) / 2
        act = [e for e in edges if min(e[0][0], e[1][0]) <= xa and
               max(e[0][0], e[1][0]) >= xb]
        act.sort(key=lambda e: y_at(e, xm))
        w = 0
        for e, f in zip(act, act[1:]):
            w += 1 if e[1][0] > e[0][0] else -1
            if w:
                h = (y_at(f, xa) - y_at(e, xa)) + (y_at(f, xb) - y_at(e, xb))
                total += abs(w) * h * (xb - xa) / 2
    return total
