"""Scalar integer geometry helpers, bit-exact with CuraEngine's ``linearAlg2D``.

All functions take and return int64 scalars (µm). Integer arithmetic wraps like
int64 machine arithmetic (numba does not check overflow); under the documented
preconditions (|coordinates| < 2**31) nothing overflows except where CuraEngine's
own int64 arithmetic overflows too, and then both wrap the same way.

Conventions reproduced exactly (see ``spec/SIMPLIFY.md``):

* ``tdiv`` truncates toward zero (C semantics), never floor;
* ``vsize`` is ``llrint(sqrt(double(x*x + y*y)))``, round half to even; where the
  int64 sum has wrapped negative, ``sqrt`` gives NaN and x86-64 ``llrint`` gives
  ``INT64_MIN``, which is returned;
* ``line_line_intersection`` rounds every step to float32, with no fused
  multiply-add (no ``fastmath`` anywhere in this package).
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, I64

INT64_MIN = np.iinfo(np.int64).min
INT64_MAX = np.iinfo(np.int64).max
INT32_MAX = 2147483647
# |float32 product| beyond this cannot give an in-range intersection (|a| < 2**31)
_F32_LIMIT = np.float32(2.0**40)



@kernel(I64(I64, I64))
def tdiv(a, b):
    """``a / b`` truncated toward zero (C integer division). Precondition: b != 0."""
    q = a // b
    if q < 0 and q * b != a:
        q += 1
    return q


@kernel(I64(I64, I64))
def vsize2(x, y):
    """Squared length ``x*x + y*y`` (int64, wrapping)."""
    return x * x + y * y


@kernel(I64(I64, I64))
def vsize(x, y):
    """Length rounded half to even: ``llrint(sqrt(double(x*x + y*y)))``."""
    s = x * x + y * y
    if s < 0:
        return INT64_MIN  # llrint(NaN) on x86-64
    return np.int64(np.rint(np.sqrt(np.float64(s))))


@kernel(I64(I64, I64, I64, I64, I64, I64))
def dist_from_line(px, py, ax, ay, bx, by):
    """Distance of p to the infinite line a-b, truncated (CuraEngine getDistFromLine).

    ``ab = double(vsize(b - a))``; a zero-length line gives ``vsize(p - a)``.
    """
    ab = vsize(bx - ax, by - ay)
    if ab == 0:
        return vsize(px - ax, py - ay)
    area2 = (px - bx) * (py - ay) + (ax - px) * (py - by)
    if area2 < 0:
        area2 = -area2
    return np.int64(np.float64(area2) / np.float64(ab))


@kernel(I64(I64, I64, I64, I64, I64, I64))
def dist2_from_line(px, py, ax, ay, bx, by):
    """``dist_from_line(p, a, b) ** 2`` (always a perfect square)."""
    d = dist_from_line(px, py, ax, ay, bx, by)
    return d * d


@kernel(I64(I64, I64, I64, I64, I64, I64))
def dist2_from_segment(ax, ay, bx, by, cx, cy):
    """Squared distance of **b** to segment a-c, CuraEngine integer projection.

    The projection is truncated twice, so the result can be a few units off the
    true squared distance; that is intended (CuraEngine getDist2FromLineSegment).
    """
    acx = cx - ax
    acy = cy - ay
    acs = vsize(acx, acy)
    abx = bx - ax
    aby = by - ay
    if acs == 0:
        return abx * abx + aby * aby
    ax_len = tdiv(abx * acx + aby * acy, acs)
    if ax_len < 0:
        return abx * abx + aby * aby
    if ax_len > acs:
        dx = bx - cx
        dy = by - cy
        return dx * dx + dy * dy
    projx = tdiv(acx * ax_len, acs)
    projy = tdiv(acy * ax_len, acs)
    dx = abx - projx
    dy = aby - projy
    return dx * dx + dy * dy


@kernel(
    types.Tuple((B1, I64, I64))(I64, I64, I64, I64, I64, I64, I64, I64)
)
def line_line_intersection(ax, ay, bx, by, cx, cy, dx, dy):
    """Intersection of the infinite lines a-b and c-d in float32 arithmetic.

    Returns ``(ok, x, y)``. ``ok`` is False when the float32 determinant is zero
    (parallel) or when the result lies beyond the int32 range. Every difference is
    converted to float32 and every product, difference and quotient is rounded to
    float32 (no fused multiply-add), then ``a + rint(float32(b - a) * t)``.

    Where the float32 product is not finite or far beyond the int32 range
    (CuraEngine's ``llrint`` would overflow, undefined behaviour) the result is
    "no intersection".
    """
    x12 = np.float32(ax - bx)
    x13 = np.float32(ax - cx)
    x34 = np.float32(cx - dx)
    y12 = np.float32(ay - by)
    y13 = np.float32(ay - cy)
    y34 = np.float32(cy - dy)
    p1 = x13 * y34
    p2 = y13 * x34
    t = p1 - p2
    q1 = x12 * y34
    q2 = y12 * x34
    div = q1 - q2
    if div == np.float32(0.0):
        return False, np.int64(0), np.int64(0)
    t = t / div
    fx = np.float32(bx - ax) * t
    fy = np.float32(by - ay) * t
    # NaN fails both comparisons
    if not (abs(fx) <= _F32_LIMIT and abs(fy) <= _F32_LIMIT):
        return False, np.int64(0), np.int64(0)
    rx = ax + np.int64(np.rint(fx))
    ry = ay + np.int64(np.rint(fy))
    if abs(rx) > INT32_MAX or abs(ry) > INT32_MAX:
        return False, np.int64(0), np.int64(0)
    return True, rx, ry
