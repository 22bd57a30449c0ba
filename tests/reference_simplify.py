"""Slow pure-Python reference of CuraEngine's simplifier (spec/SIMPLIFY.md).

Written independently of ``kernels/simplify.py``: Python ints with explicit int64
wrap-around (``_w``) where CuraEngine's int64 arithmetic can overflow, ``math`` for
the double sqrt, ``numpy.float32`` for the line intersection, ``heapq`` for the
priority queue and a linear scan of the ``to_delete`` flags for neighbours, as
CuraEngine does.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

INT64_MIN = -(2**63)
INT64_MAX = 2**63 - 1


def _w(x: int) -> int:
    """Wrap a Python int to int64 (two's complement)."""
    return ((x + 2**63) % 2**64) - 2**63


def tdiv(a: int, b: int) -> int:
    """C integer division (truncates toward zero)."""
    q = abs(a) // abs(b)
    return _w(q if (a >= 0) == (b >= 0) else -q)


def vsize2(x: int, y: int) -> int:
    return _w(_w(x * x) + _w(y * y))


def vsize(x: int, y: int) -> int:
    s = vsize2(x, y)
    if s < 0:  # sqrt(negative) = NaN; x86-64 llrint(NaN) = INT64_MIN
        return INT64_MIN
    return round(math.sqrt(float(s)))  # round() on a float is half-to-even


def dist_from_line(p, a, b) -> int:
    ab = vsize(b[0] - a[0], b[1] - a[1])
    if ab == 0:
        return vsize(p[0] - a[0], p[1] - a[1])
    area2 = _w(_w((p[0] - b[0]) * (p[1] - a[1])) + _w((a[0] - p[0]) * (p[1] - b[1])))
    area2 = _w(abs(area2))
    return int(float(area2) / float(ab))  # int() truncates


def dist2_from_line(p, a, b) -> int:
    d = dist_from_line(p, a, b)
    return _w(d * d)


def dist2_from_segment(a, b, c) -> int:
    """Squared distance of b to segment a-c (CuraEngine integer projection)."""
    ac = (c[0] - a[0], c[1] - a[1])
    ab = (b[0] - a[0], b[1] - a[1])
    acs = vsize(*ac)
    if acs == 0:
        return vsize2(*ab)
    ax = tdiv(_w(_w(ab[0] * ac[0]) + _w(ab[1] * ac[1])), acs)
    if ax < 0:
        return vsize2(*ab)
    if ax > acs:
        return vsize2(b[0] - c[0], b[1] - c[1])
    proj = (tdiv(_w(ac[0] * ax), acs), tdiv(_w(ac[1] * ax), acs))
    return vsize2(ab[0] - proj[0], ab[1] - proj[1])


def line_line_intersection(a, b, c, d):
    """Float32 intersection of lines a-b and c-d; None if parallel or out of range."""
    f = np.float32
    with np.errstate(all="ignore"):
        x12, y12 = f(a[0] - b[0]), f(a[1] - b[1])
        x13, y13 = f(a[0] - c[0]), f(a[1] - c[1])
        x34, y34 = f(c[0] - d[0]), f(c[1] - d[1])
        t = f(f(x13 * y34) - f(y13 * x34))
        div = f(f(x12 * y34) - f(y12 * x34))
        if div == 0:
            return None
        t = f(t / div)
        fx = f(f(b[0] - a[0]) * t)
        fy = f(f(b[1] - a[1]) * t)
    if not (math.isfinite(fx) and math.isfinite(fy)):
        return None
    if abs(float(fx)) > 2.0**40 or abs(float(fy)) > 2.0**40:
        return None  # llrint would overflow (undefined in C++): no intersection
    x = a[0] + round(float(fx))
    y = a[1] + round(float(fy))
    if abs(x) > 2147483647 or abs(y) > 2147483647:
        return None
    return (x, y)


def area_deviation(bv, v, av) -> int:
    """bv, v, av are (x, y, w) junctions."""
    ab = vsize(v[0] - bv[0], v[1] - bv[1])
    bc = vsize(av[0] - v[0], av[1] - v[1])
    ac = vsize(av[0] - bv[0], av[1] - bv[1])
    if ab == 0 or ac == 0 or bc == 0:
        return 0
    wd = max(abs(v[2] - bv[2]), abs(av[2] - v[2]))
    if wd > 1:
        ab_w = tdiv(bv[2] + v[2], 2)
        bc_w = tdiv(v[2] + av[2], 2)
        avg = tdiv(_w(_w(ab * ab_w) + _w(bc * bc_w)), ac)
        return _w(_w(_w(abs(ab_w - avg)) * ab) + _w(_w(abs(bc_w - avg)) * bc))
    return _w(wd * bc) if ab > bc else _w(wd * ab)


class _Simplifier:
    def __init__(self, pts, closed, max_res, max_dev, max_area, has_w):
        self.p = [list(q) for q in pts]
        self.n = len(pts)
        self.closed = closed
        self.res2 = max_res * max_res
        self.dev2 = max_dev * max_dev
        self.max_area = max_area
        self.has_w = has_w
        self.deleted = [False] * self.n

    def prev(self, i):
        j = (i - 1) % self.n
        while self.deleted[j]:
            j = (j - 1) % self.n
        return j

    def next(self, i):
        j = (i + 1) % self.n
        while self.deleted[j]:
            j = (j + 1) % self.n
        return j

    def importance(self, i):
        if not self.closed and (i == 0 or i == self.n - 1):
            return INT64_MAX
        bi, ai = self.prev(i), self.next(i)
        v, b, a = self.p[i], self.p[bi], self.p[ai]
        if self.has_w and area_deviation(b, v, a) > self.max_area:
            return INT64_MAX
        d2 = dist2_from_line(v, b, a)
        if d2 <= 25:
            return d2
        if (vsize2(b[0] - v[0], b[1] - v[1]) > self.res2
                and vsize2(a[0] - v[0], a[1] - v[1]) > self.res2):
            return INT64_MAX
        return d2

    def remove(self, i, d2):
        if d2 <= 25:
            self.deleted[i] = True
            return True
        bi, ai = self.prev(i), self.next(i)
        v, b, a = self.p[i], self.p[bi], self.p[ai]
        len_b = vsize2(v[0] - b[0], v[1] - b[1])
        len_a = vsize2(v[0] - a[0], v[1] - a[1])
        if len_b <= self.res2 and len_a <= self.res2:
            self.deleted[i] = True
            return True
        if len_b <= len_a:
            if not self.closed and bi == 0:
                return False
            bb = self.p[self.prev(bi)]
            x = line_line_intersection(bb, b, v, a)
            short_from, short_to, target = b, v, bi
        else:
            if not self.closed and ai == self.n - 1:
                return False
            aa = self.p[self.next(ai)]
            x = line_line_intersection(b, v, a, aa)
            short_from, short_to, target = v, a, ai
        if x is None:
            return False
        if dist2_from_segment(short_from, x, short_to) > self.dev2:
            return False
        self.deleted[i] = True
        new = [x[0], x[1]]
        if self.has_w:
            new.append(tdiv(b[2] + a[2], 2))
        self.p[target] = new
        return True

    def small(self, pts, min_size):
        if len(pts) < min_size:
            return True
        if len(pts) == min_size:
            p0, p1, pl = pts[0], pts[1], pts[-1]
            longest = max(vsize2(p1[0] - p0[0], p1[1] - p0[1]),
                          vsize2(pl[0] - p0[0], pl[1] - p0[1]),
                          vsize2(pl[0] - p1[0], pl[1] - p1[1]))
            return longest < 25
        return False

    def run(self):
        min_size = 3 if self.closed else 2
        if self.small(self.p, min_size):
            return []
        if self.n == min_size:
            return [list(q) for q in self.p]
        removed = -1
        while self.n - removed > min_size and removed != 0:
            removed = 0
            heap = [(self.importance(i), i) for i in range(self.n)
                    if not self.deleted[i]]
            heapq.heapify(heap)
            while heap and self.n - removed > min_size:
                imp, i = heapq.heappop(heap)
                cur = self.importance(i)
                if cur != imp:
                    heapq.heappush(heap, (cur, i))
                    continue
                if cur <= self.dev2 and self.remove(i, cur):
                    removed += 1
        out = [self.p[i] for i in range(self.n) if not self.deleted[i]]
        return [] if self.small(out, min_size) else out


def simplify(pts, *, closed=True, max_resolution=500, max_deviation=25,
             max_area_deviation=50000, widths=None):
    """Simplify one path given as a list of (x, y); returns a list of [x, y].

    With ``widths`` the points are junctions and the result holds [x, y, w].
    """
    pts = [tuple(int(c) for c in q) for q in pts]
    if widths is not None:
        pts = [(q[0], q[1], int(w)) for q, w in zip(pts, widths, strict=True)]
    s = _Simplifier(pts, closed, int(max_resolution), int(max_deviation),
                    int(max_area_deviation), widths is not None)
    return s.run()


def polygon_length(pts) -> int:
    """CuraEngine polygonLength: sum of vsize of the edges incl. the closing edge."""
    if len(pts) < 2:
        return 0
    total = 0
    q = pts[-1]
    for p in pts:
        total += vsize(p[0] - q[0], p[1] - q[1])
        q = p
    return total


def remove_degenerate_verts(pts):
    """CuraEngine removeDegenerateVerts for one closed polygon.

    Returns the new vertex list, or None where CuraEngine removes the polygon.
    """
    pts = [tuple(int(c) for c in q) for q in pts]

    def degenerate(last, now, nxt):
        lx, ly = now[0] - last[0], now[1] - last[1]
        nx, ny = nxt[0] - now[0], nxt[1] - now[1]
        dot = _w(_w(lx * nx) + _w(ly * ny))
        return dot == _w(-1 * _w(vsize(lx, ly) * vsize(nx, ny)))

    result: list = []
    changed = False
    for idx in range(len(pts)):
        last = result[-1] if result else pts[-1]
        if idx + 1 >= len(pts) and not result:
            break
        nxt = result[0] if idx + 1 >= len(pts) else pts[idx + 1]
        if degenerate(last, pts[idx], nxt):
            changed = True
            while len(result) > 1 and degenerate(result[-2], result[-1], nxt):
                result.pop()
        else:
            result.append(pts[idx])
    if not changed:
        return [list(p) for p in pts]
    if len(result) > 2:
        return [list(p) for p in result]
    return None
