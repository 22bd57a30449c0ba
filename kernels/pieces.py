"""The pieces between a raw ring and its simplified ring, and whether they overlap.

Between consecutive anchored vertices (shared by both rings) the raw chain and the
simplified chain bound one *piece* (a run); the pieces sum to ``raw - simplified`` as
cycles, so their areas sum to the ring pair's XOR area wherever no two overlap.
These kernels decide that: neighbours by a separating line through their shared
vertex, others by bands around their chords; pieces that may overlap are joined
(union-find) and measured together. Records of the runs live in flat work arrays
(``_NI`` ints and ``_NF`` floats per run) filled by ``metrics._run``.
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, I64, I64_2D
from .planar import _segment_distance

_W1 = types.int64[::1]
_W2 = types.int64[:, ::1]
_WF = types.float64[::1]

_SCALE = 1048576.0  # 2**20: integer bisector directions, products stay < 2**53

# per-run integer record in ``wi`` (_NI entries) and float record in ``wf`` (_NF)
# (_GX, _GY: the separating direction at p, :func:`_separator`; _SIDE: the side
# tests of :func:`_neighbours_apart`)
_P, _Q, _AP, _AQ, _KIND, _X0, _Y0, _X1, _Y1, _KMAX = 0, 1, 2, 3, 4, 5, 6, 7, 8, 9
_GX, _GY, _SIDE = 10, 11, 12
_NI = 13
_X_OFF = np.int64(2**30)  # |x| < 2**30: x + _X_OFF is in [1, 2**31)
_T_MASK = np.int64(2**32 - 1)
_UB, _H, _AREA = 0, 1, 2
_NF = 3


@kernel(inline="always")
def _separator(sc, s0, m, v):
    """Integer direction g of a line through simplified vertex v parting its edges.

    The line is the bisector of the two simplified edges at v, as an integer
    direction of length about 2**20, oriented so that the edge before v lies
    where ``cross(g, x - s_v) > 0`` and the edge after where it is < 0.
    ``(0, 0)`` when no such line is found (a zero-length edge, the ring
    reversing at v, or the rounded direction not parting the two edges).
    """
    vb = v - 1 if v > 0 else m - 1
    va = v + 1 if v + 1 < m else 0
    ox = sc[s0 + v, 0]
    oy = sc[s0 + v, 1]
    ux = np.float64(ox - sc[s0 + vb, 0])
    uy = np.float64(oy - sc[s0 + vb, 1])
    wx = np.float64(sc[s0 + va, 0] - ox)
    wy = np.float64(sc[s0 + va, 1] - oy)
    lu = np.sqrt(ux * ux + uy * uy)
    lw = np.sqrt(wx * wx + wy * wy)
    if lu == 0.0 or lw == 0.0:
        return np.int64(0), np.int64(0)
    bx = ux / lu + wx / lw
    by = uy / lu + wy / lw
    lb = np.sqrt(bx * bx + by * by)
    if lb < 1e-6:  # the ring reverses here: no separating line
        return np.int64(0), np.int64(0)
    dx = np.int64(np.rint(-by / lb * _SCALE))
    dy = np.int64(np.rint(bx / lb * _SCALE))
    sb = dx * (sc[s0 + vb, 1] - oy) - dy * (sc[s0 + vb, 0] - ox)
    sa = dx * (sc[s0 + va, 1] - oy) - dy * (sc[s0 + va, 0] - ox)
    if sb == 0 or sa == 0 or (sb > 0) == (sa > 0):
        return np.int64(0), np.int64(0)
    if sb > 0:
        return dx, dy
    return -dx, -dy


@kernel(inline="always")
def _neighbours_apart(wi, t, npc):
    """Runs t-1 and t lie on either side of a line through their shared vertex.

    The line is :func:`_separator` at run t's first vertex p; ``metrics._run``
    tested every vertex of each run (its raw vertices and its simplified ones)
    against the lines at both of its ends, exactly in int64, and recorded the
    outcome in ``_SIDE``: bit 1, all on the side ``cross(g_p, x - s_p) <= 0``
    (away from the run before); bit 2, all on the side ``cross(g_q, x - s_q)
    >= 0`` (away from the run after). The test is exact: a run's piece lies in
    the convex hull of its vertices.
    """
    tl = t - 1 if t > 0 else npc - 1
    b = _NI * t
    return ((wi[b + _GX] != 0 or wi[b + _GY] != 0) and (wi[b + _SIDE] & 1) != 0
            and (wi[_NI * tl + _SIDE] & 2) != 0)


@kernel(B1(I64_2D, I64, I64, I64_2D, I64, I64, _W1, _WF, I64, I64), inline="always")
def _outside_band(rc, r0, n, sc, s0, m, wi, wf, t, u):
    """All vertices of run t lie beyond one side of run u's band (|h| <= H_u)."""
    bu = _NI * u
    ax = sc[s0 + wi[bu + _P], 0]
    ay = sc[s0 + wi[bu + _P], 1]
    ex = sc[s0 + wi[bu + _Q], 0] - ax
    ey = sc[s0 + wi[bu + _Q], 1] - ay
    lim = wf[_NF * u + _H] * np.sqrt(np.float64(ex * ex + ey * ey)) * (1.0 + 1e-12)
    bt = _NI * t
    lo = np.inf
    hi = -np.inf
    for kk in range(wi[bt + _AP], wi[bt + _AQ] + 1):
        k = kk if kk < n else kk - n
        c = np.float64(ex * (rc[r0 + k, 1] - ay) - ey * (rc[r0 + k, 0] - ax))
        lo = min(lo, c)
        hi = max(hi, c)
    j = wi[bt + _P]
    while j != wi[bt + _Q]:
        c = np.float64(ex * (sc[s0 + j, 1] - ay) - ey * (sc[s0 + j, 0] - ax))
        lo = min(lo, c)
        hi = max(hi, c)
        j = j + 1 if j + 1 < m else 0
    return lo > lim or hi < -lim


@kernel(I64(_W1, I64), inline="always")
def _find(parent, t):
    """Root of t in the union-find forest ``parent`` (path halving)."""
    while parent[t] != t:
        parent[t] = parent[parent[t]]
        t = parent[t]
    return t


@kernel(B1(I64_2D, I64, I64, I64_2D, I64, I64, _W1, _WF, _W1, I64))
def _others_conflicts(rc, r0, n, sc, s0, m, wi, wf, parent, npc):
    """Join (in ``parent``) the runs that are not neighbours and may overlap.

    A run with a single chord lies within ``H`` of it, any run in the convex
    hull of its vertices: boxes first, then chords more than ``H_i + H_j``
    apart, or one run's vertices all beyond the other's band, keep two runs
    apart. Returns False when there are too many candidate pairs to test.
    """
    # runs by box x0, sorted in place after the records (wi has room for
    # _NI * (n + m + 1) entries; npc <= n): (x0 + 2**30) << 32 | t, both
    # parts non-negative and t < 2**32. Which pairs are tested, the budget used
    # and the components joined do not depend on the order among equal x0.
    nz = 0
    base = _NI * npc
    for t in range(npc):
        if wi[_NI * t + _KIND] != 0:
            wi[base + nz] = ((wi[_NI * t + _X0] + _X_OFF) << 32) | t
            nz += 1
    if nz > 64:  # else sorted by insertion in _sorted_pairs (numba's sort
        wi[base:base + nz].sort()  # allocates its stack on every call)
    return _sorted_pairs(rc, r0, n, sc, s0, m, wi, wf, parent, npc, base, nz)


@kernel(B1(I64_2D, I64, I64, I64_2D, I64, I64, _W1, _WF, _W1, I64, I64, I64),
        _nrt=False)
def _sorted_pairs(rc, r0, n, sc, s0, m, wi, wf, parent, npc, base, nz):
    """:func:`_others_conflicts`' pairs, its ``nz`` keys at ``wi[base:]``.

    Sorts the keys by insertion first (linear when they are sorted already).
    Allocates nothing: compiled without reference counting (an array passed to
    an inlined helper otherwise costs an atomic increment and decrement).
    """
    for a in range(base + 1, base + nz):
        key = wi[a]
        c = a - 1
        while c >= base and wi[c] > key:
            wi[c + 1] = wi[c]
            c -= 1
        wi[c + 1] = key
    budget = 8 * npc + 64
    for a in range(nz):
        ti = wi[base + a] & _T_MASK
        bi = _NI * ti
        for c in range(a + 1, nz):
            tj = wi[base + c] & _T_MASK
            bj = _NI * tj
            if wi[bj + _X0] > wi[bi + _X1]:
                break
            dt = abs(ti - tj)
            if dt == 1 or dt == npc - 1:
                continue
            if wi[bj + _Y0] > wi[bi + _Y1] or wi[bi + _Y0] > wi[bj + _Y1]:
                continue
            budget -= 1
            if budget < 0:
                return False
            ri = _find(parent, ti)
            rj = _find(parent, tj)
            if ri == rj:
                continue
            hi = wf[_NF * ti + _H]
            hj = wf[_NF * tj + _H]
            if hi < np.inf and hj < np.inf:
                d = _segment_distance(
                    sc[s0 + wi[bi + _P], 0], sc[s0 + wi[bi + _P], 1],
                    sc[s0 + wi[bi + _Q], 0], sc[s0 + wi[bi + _Q], 1],
                    sc[s0 + wi[bj + _P], 0], sc[s0 + wi[bj + _P], 1],
                    sc[s0 + wi[bj + _Q], 0], sc[s0 + wi[bj + _Q], 1],
                )
                if d > (hi + hj) * (1.0 + 1e-12):
                    continue
            if hj < np.inf and _outside_band(rc, r0, n, sc, s0, m, wi, wf, ti, tj):
                continue
            if hi < np.inf and _outside_band(rc, r0, n, sc, s0, m, wi, wf, tj, ti):
                continue
            parent[max(ri, rj)] = min(ri, rj)
    return True


@kernel(I64(I64_2D, I64, I64, I64_2D, I64, I64, I64, I64, I64, I64, _W2, I64))
def _piece_edges(rc, r0, n, sc, s0, m, p, q, ap, aq, e, ne):
    """Append the piece raw ``ap..aq``, then simplified ``q`` back to ``p``, to ``e``.

    Rows of ``e`` are edges (x0, y0, x1, y1), written from row ``ne``; returns the
    new row count.
    """
    for kk in range(ap, aq):
        k = kk if kk < n else kk - n
        k1 = k + 1 if k + 1 < n else 0
        e[ne, 0] = rc[r0 + k, 0]
        e[ne, 1] = rc[r0 + k, 1]
        e[ne, 2] = rc[r0 + k1, 0]
        e[ne, 3] = rc[r0 + k1, 1]
        ne += 1
    j = q
    while j != p:
        jb = j - 1 if j > 0 else m - 1
        e[ne, 0] = sc[s0 + j, 0]
        e[ne, 1] = sc[s0 + j, 1]
        e[ne, 2] = sc[s0 + jb, 0]
        e[ne, 3] = sc[s0 + jb, 1]
        ne += 1
        j = jb
    return ne


@kernel(I64(I64_2D, I64, I64, I64_2D, I64, I64, _W1, I64, I64, _W2, I64))
def _add_run_edges(rc, r0, n, sc, s0, m, wi, t, root, e, ne):
    """Append run t's piece (raw ap..aq, simplified q back to p) to ``e``."""
    b = _NI * t
    return _piece_edges(rc, r0, n, sc, s0, m, wi[b + _P], wi[b + _Q], wi[b + _AP],
                        wi[b + _AQ], e, ne)
