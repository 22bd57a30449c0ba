"""Scalar integer geometry helpers, bit-exact with CuraEngine's ``linearAlg2D``.

All functions take and return int64 scalars (µm). Products and sums that can
overflow under the documented preconditions (|coordinates| < 2**31) wrap like
int64 machine arithmetic, as CuraEngine's own int64 arithmetic does there. They
are written with :func:`wmul`, :func:`wadd` and :func:`wsize2`: numba compiles
signed ``*`` and ``+`` with LLVM's no-signed-wrap flag, so an overflowing plain
``d * d <= 25`` may be folded as if the square could not wrap, and the compiled
kernel would then differ from the same code interpreted
(``NUMBA_DISABLE_JIT=1``) and from the wrap.

Conventions reproduced exactly (see ``spec/SIMPLIFY.md``):

* ``tdiv`` truncates toward zero (C semantics), never floor;
* ``vsize`` is ``llrint(sqrt(double(x*x + y*y)))``, round half to even; where the
  int64 sum has wrapped negative, ``sqrt`` gives NaN and x86-64 ``llrint`` gives
  ``INT64_MIN``, which is returned;
* ``line_line_intersection`` rounds every step to float32, with no fused
  multiply-add (no ``fastmath`` anywhere in this package).
"""

import numpy as np
from numba import config, types

from ._jit import kernel
from ._types import B1, I64

INT64_MIN = np.iinfo(np.int64).min
INT64_MAX = np.iinfo(np.int64).max
INT32_MAX = 2147483647
# |float32 product| beyond this cannot give an in-range intersection (|a| < 2**31)
_F32_LIMIT = np.float32(2.0**40)



if config.DISABLE_JIT:  # plain Python (coverage runs): Python ints, wrapped
    def _wrap(x):
        return np.int64(((int(x) + 2**63) % 2**64) - 2**63)

    def wmul(a, b):
        """``a * b`` in int64, wrapping on overflow."""
        return _wrap(int(a) * int(b))

    def wadd(a, b):
        """``a + b`` in int64, wrapping on overflow."""
        return _wrap(int(a) + int(b))

    def wsize2(x, y):
        """``x*x + y*y`` in int64, wrapping on overflow."""
        return _wrap(int(x) * int(x) + int(y) * int(y))
else:
    @kernel(inline="always")
    def wmul(a, b):
        """``a * b`` in int64, wrapping on overflow.

        Unsigned operations carry no no-wrap flag; the conversions are bit casts.
        """
        return np.int64(np.uint64(a) * np.uint64(b))

    @kernel(inline="always")
    def wadd(a, b):
        """``a + b`` in int64, wrapping on overflow."""
        return np.int64(np.uint64(a) + np.uint64(b))

    @kernel(inline="always")
    def wsize2(x, y):
        """``x*x + y*y`` in int64, wrapping on overflow."""
        ux = np.uint64(x)
        uy = np.uint64(y)
        return np.int64(ux * ux + uy * uy)


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
    return wsize2(x, y)


@kernel(I64(I64, I64))
def vsize(x, y):
    """Length rounded half to even: ``llrint(sqrt(double(x*x + y*y)))``."""
    s = wsize2(x, y)
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
    area2 = wadd(wmul(px - bx, py - ay), wmul(ax - px, py - by))
    if area2 < 0:
        area2 = wmul(area2, -1)
    return np.int64(np.float64(area2) / np.float64(ab))


@kernel(I64(I64, I64, I64, I64, I64, I64))
def dist2_from_line(px, py, ax, ay, bx, by):
    """``dist_from_line(p, a, b) ** 2`` (always a perfect square)."""
    d = dist_from_line(px, py, ax, ay, bx, by)
    return wmul(d, d)


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
        return wsize2(abx, aby)
    ax_len = tdiv(wadd(wmul(abx, acx), wmul(aby, acy)), acs)
    if ax_len < 0:
        return wsize2(abx, aby)
    if ax_len > acs:
        return wsize2(bx - cx, by - cy)
    projx = tdiv(wmul(acx, ax_len), acs)
    projy = tdiv(wmul(acy, ax_len), acs)
    return wsize2(abx - projx, aby - projy)


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
