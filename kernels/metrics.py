"""Kernels measuring how far simplified rings are from the raw rings they came from.

Ring ``r`` of ``simp`` is the simplification of ring ``r`` of ``raw`` (or empty,
when the ring was dropped). Simplification keeps the raw ring's vertex order: a
simplified ring is a subsequence of its raw ring, except that the short-edge ->
intersection rule moves some kept vertices. ``_match`` recovers that
correspondence (the *anchor* of a simplified vertex is the raw vertex it equals,
or -1 for a moved one), and both metrics use it to be fast, never to be right:

* **Deviation** (largest distance from a vertex of one ring to the other ring).
  The distance of a vertex to a ring is the minimum over the ring's edges of one
  float64 point-segment formula over exact int64 pieces (``planar``). Candidate
  edges from the correspondence bound every vertex in one linear pass; the vertex
  with the largest bound is measured against *all* edges, then only vertices whose
  bound still exceeds the best exact value. The result is exactly the maximum over
  all vertex-edge pairs (the brute force), whatever the correspondence. Without
  one, walks along the other ring give the bounds (``planar.directed_distance``).
* **XOR area** ``∫ |w_raw - w_simp| dA`` (winding numbers; the area of the
  symmetric difference for simple rings). The runs between consecutive anchored
  vertices bound pieces (``pieces``) that sum to ``raw - simp`` as cycles. A
  piece's ``∫|w|`` is ``∫ |h| dt`` along its chord when its raw chain is monotone
  along it (split where the chain crosses the chord); a piece whose simplified
  side has several edges (moved vertices) is ``∫ |h_raw - h_simp| dt`` when both
  chains are monotone along its chord; else the sweep (``planar.winding_area``).
  Pieces that may overlap are measured together by the sweep; the whole ring
  pair is swept when too many may.

Preconditions (the caller checks them): |coords| < 2**30; both offset arrays are
valid and have the same number of rings.
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, F64, I64, I64_1D, I64_2D
from .pieces import (
    _AP,
    _AQ,
    _AREA,
    _GX,
    _GY,
    _H,
    _KIND,
    _KMAX,
    _NF,
    _NI,
    _P,
    _Q,
    _SIDE,
    _UB,
    _X0,
    _X1,
    _Y0,
    _Y1,
    _add_run_edges,
    _find,
    _neighbours_apart,
    _others_conflicts,
    _piece_edges,
    _separator,
)
from .planar import (
    _edge_distance,
    _near_edge,
    _near_edge_distance,
    _to_ring_within,
    directed_distance,
    settle_bounds,
    winding_area,
)

_W1 = types.int64[::1]
_W2 = types.int64[:, ::1]
_WF = types.float64[::1]
_WB = types.boolean[::1]
_F64_OUT = types.float64[::1]
_B1_OUT = types.boolean[::1]
_NONE = np.int64(2**62)  # no coordinate (|coordinates| < 2**30)
_BELOW = 1.0 - 2.0**-40  # see the multi-edge runs of _run


@kernel(I64(I64_2D, I64, I64, I64_2D, I64, I64))
def _match_start(rc, r0, n, sc, s0, m):
    """The raw vertex where matching starts: the first equal to ``sc[s0]``.

    Else the first equal to the second simplified vertex, else to the third
    (moved vertices equal none); 0 if none is found. A simplified ring that
    starts elsewhere in its raw ring than vertex 0 (a ring from another
    simplifier) is then matched from there, in one pass, instead of failing
    the match and falling back to measuring all pairs. At most ``3 * n`` reads.
    """
    for j in range(min(m, 3)):
        sx = sc[s0 + j, 0]
        sy = sc[s0 + j, 1]
        for k in range(n):
            if rc[r0 + k, 0] == sx and rc[r0 + k, 1] == sy:
                return k
    return 0


@kernel(B1(I64_2D, I64, I64, I64_2D, I64, I64, _W1))
def _match(rc, r0, n, sc, s0, m, anchor):
    """Anchor each simplified vertex to the raw vertex it equals, in order.

    ``anchor[j]`` is a local raw index or -1 (moved, or not found before the
    next one or two simplified vertices). The raw ring is read once round from
    :func:`_match_start`, so the anchored indices increase cyclically from
    there, wrapping past ``n - 1`` at most once. Returns False when the scan
    exceeds its linear budget.
    """
    start = _match_start(rc, r0, n, sc, s0, m)
    k = 0  # raw vertices read, counted from start
    budget = 4 * n + 4 * m + 16
    for j in range(m):
        sx = sc[s0 + j, 0]
        sy = sc[s0 + j, 1]
        # the next two simplified vertices (_NONE, equal to no coordinate,
        # past the end)
        ax = sc[s0 + j + 1, 0] if j + 1 < m else _NONE
        ay = sc[s0 + j + 1, 1] if j + 1 < m else _NONE
        bx = sc[s0 + j + 2, 0] if j + 2 < m else _NONE
        by = sc[s0 + j + 2, 1] if j + 2 < m else _NONE
        anchor[j] = -1
        kk = k
        while kk < n:
            budget -= 1
            if budget < 0:
                return False
            i = start + kk
            if i >= n:
                i -= n
            x = rc[r0 + i, 0]
            # one test of x against all three first (& and |: one branch)
            if (x == sx) | (x == ax) | (x == bx):
                y = rc[r0 + i, 1]
                if x == sx and y == sy:
                    anchor[j] = i
                    k = kk + 1
                    break
                if (x == ax and y == ay) or (x == bx and y == by):
                    break
            kk += 1
    return True


@kernel(F64(I64_2D, I64, I64, I64_2D, I64, I64, _W2))
def _ring_area(rc, r0, n, sc, s0, m, e):
    """``∫ |w_raw - w_simp|`` of a whole ring pair by the sweep (any geometry)."""
    ne = 0
    for i in range(n):
        i1 = i + 1 if i + 1 < n else 0
        e[ne, 0] = rc[r0 + i, 0]
        e[ne, 1] = rc[r0 + i, 1]
        e[ne, 2] = rc[r0 + i1, 0]
        e[ne, 3] = rc[r0 + i1, 1]
        ne += 1
    for j in range(m):
        j1 = j + 1 if j + 1 < m else 0
        e[ne, 0] = sc[s0 + j1, 0]
        e[ne, 1] = sc[s0 + j1, 1]
        e[ne, 2] = sc[s0 + j, 0]
        e[ne, 3] = sc[s0 + j, 1]
        ne += 1
    return winding_area(e, ne)


@kernel(F64(I64_2D, I64, I64, I64_2D, I64, I64, I64, I64, I64, I64, _W2))
def _piece_area(rc, r0, n, sc, s0, m, p, q, ap, aq, e):
    """``∫ |w|`` of the piece: raw ``ap..aq``, then simplified ``q, q-1, ..., p``."""
    return winding_area(e, _piece_edges(rc, r0, n, sc, s0, m, p, q, ap, aq, e, 0))


@kernel(F64(I64, I64, I64), inline="always")
def _strip(dd, c0, c1):
    """``∫ |C| dD`` over a step of ``dd`` from height c0 to c1 (split at C = 0).

    Both formulas are evaluated and one selected (fewer mispredicted branches
    where the raw chain crosses its chord: callgrind 3.9M -> 3.4M on five
    Benchies); each is the same float expression as when it alone was evaluated.
    """
    f0 = abs(np.float64(c0))
    f1 = abs(np.float64(c1))
    fd = np.float64(dd)
    same = fd * (f0 + f1) * 0.5
    crossing = (c0 ^ c1) < 0 and c0 != 0 and c1 != 0
    den = 2.0 * (f0 + f1) if crossing else 1.0  # both formulas, no branch
    split = fd * (f0 * f0 + f1 * f1) / den
    return split if crossing else same


@kernel(F64(F64, F64, F64), inline="always")
def _strip_f(dd, c0, c1):
    """:func:`_strip` for float heights."""
    f0 = abs(c0)
    f1 = abs(c1)
    if (c0 >= 0.0 and c1 >= 0.0) or (c0 <= 0.0 and c1 <= 0.0):
        return dd * (f0 + f1) * 0.5
    return dd * (f0 * f0 + f1 * f1) / (2.0 * (f0 + f1))


@kernel(F64(I64, I64, I64, I64, F64), inline="always")
def _h_at(t0, h0, t1, h1, t):
    """Height at ``t`` of the segment (t0, h0)-(t1, h1), t0 < t1, exact at its ends."""
    if t == np.float64(t0):
        return np.float64(h0)
    if t == np.float64(t1):
        return np.float64(h1)
    return np.float64(h0) + np.float64(h1 - h0) * ((t - np.float64(t0))
                                                    / np.float64(t1 - t0))


@kernel(F64(I64_2D, I64, I64, I64_2D, I64, I64, I64, I64, I64, I64), inline="always")
def _two_chain_area(rc, r0, n, sc, s0, m, p, q, ap, aq):
    """``∫|w|`` of the piece raw ap..aq + simplified q..p, or -1.

    -1 unless both chains are monotone along the chord s_p -> s_q. In
    coordinates along the chord (t) and across it (h), both exact integers
    scaled by the chord vector, each chain is then a function h(t) from t = 0
    to t = |chord|², and the winding number is ±1 exactly between them: the
    area is ``∫ |h_raw - h_simp| dt`` (merged breakpoints, a strip per
    interval).
    """
    ax = sc[s0 + p, 0]
    ay = sc[s0 + p, 1]
    ex = sc[s0 + q, 0] - ax
    ey = sc[s0 + q, 1] - ay
    len2 = ex * ex + ey * ey
    if len2 == 0:
        return -1.0
    t0 = np.int64(0)  # monotone: t never decreases along either chain
    for kk in range(ap + 1, aq + 1):
        k = kk if kk < n else kk - n
        t1 = (rc[r0 + k, 0] - ax) * ex + (rc[r0 + k, 1] - ay) * ey
        if t1 < t0:
            return -1.0
        t0 = t1
    t0 = 0
    j = p
    while j != q:
        j = j + 1 if j + 1 < m else 0
        t1 = (sc[s0 + j, 0] - ax) * ex + (sc[s0 + j, 1] - ay) * ey
        if t1 < t0:
            return -1.0
        t0 = t1
    # raw segment (ra -> rb) and simplified segment (sa -> sb) under the
    # interval (cur, nxt); rt*/rh*, st*/sh*: their ends' t and h
    acc = 0.0
    i = ap
    rtb = np.int64(0)
    rhb = np.int64(0)
    rta = np.int64(0)
    rha = np.int64(0)
    j = p
    stb = np.int64(0)
    shb = np.int64(0)
    sta = np.int64(0)
    sha = np.int64(0)
    cur = np.int64(0)
    while cur < len2:
        while rtb <= cur:  # next raw segment reaching beyond cur
            rta = rtb
            rha = rhb
            i += 1
            k = i if i < n else i - n
            qx = rc[r0 + k, 0] - ax
            qy = rc[r0 + k, 1] - ay
            rtb = qx * ex + qy * ey
            rhb = ex * qy - ey * qx
        while stb <= cur:
            sta = stb
            sha = shb
            j = j + 1 if j + 1 < m else 0
            qx = sc[s0 + j, 0] - ax
            qy = sc[s0 + j, 1] - ay
            stb = qx * ex + qy * ey
            shb = ex * qy - ey * qx
        nxt = min(rtb, stb)
        fa = np.float64(cur)
        fb = np.float64(nxt)
        c0 = _h_at(rta, rha, rtb, rhb, fa) - _h_at(sta, sha, stb, shb, fa)
        c1 = _h_at(rta, rha, rtb, rhb, fb) - _h_at(sta, sha, stb, shb, fb)
        acc += _strip_f(np.float64(nxt - cur), c0, c1)
        cur = nxt
    return acc / np.float64(len2)


@kernel(inline="always")
def _run(rc, r0, n, sc, s0, m, wi, wf, t, npc):
    """Measure run ``t`` (simplified p..q, raw ap..aq): deviation bound, piece area.

    Fills the run's records: ``_UB`` the largest distance bound of its raw
    vertices (to the simplified edges p..q) and ``_KMAX`` that vertex; ``_H`` a
    radius around the segment s_p-s_q holding the piece; the box of that
    neighbourhood; ``_KIND`` 1 for a single monotone chord, else 2; ``_SIDE``
    the run's side of the separating lines at p and q (every vertex tested, see
    ``pieces._neighbours_apart``; ``_GX``, ``_GY`` of runs t and t+1 must be
    set). Returns the
    piece's ``∫|w|``, or -1 where the sweep must measure it (the caller calls
    ``_piece_area``). Inlined into :func:`_runs_pass`, which is compiled
    without reference counting: a kernel call per run, or an inlined helper in a
    reference-counted kernel, costs reference count updates of its array
    arguments.
    """
    b = _NI * t
    p = wi[b + _P]
    q = wi[b + _Q]
    ap = wi[b + _AP]
    aq = wi[b + _AQ]
    ax = sc[s0 + p, 0]
    ay = sc[s0 + p, 1]
    bx = sc[s0 + q, 0]
    by = sc[s0 + q, 1]
    ex = bx - ax
    ey = by - ay
    len2 = ex * ex + ey * ey
    single = q == (p + 1 if p + 1 < m else 0) and len2 > 0
    # side tests: cross(g_p, v - s_p) <= 0 and cross(g_q, v - s_q) >= 0 for all
    # vertices v; with w = v - s_p, the latter is cross(g_q, w) >= cross(g_q, e)
    # (|g| <= 2**20, |w| < 2**31: exact in int64). A full scan: the former
    # scans stopped early where a float bound kept the rest on the right side,
    # which was sound (tests/kernels/test_pieces.py compares both)
    bn = _NI * (t + 1 if t + 1 < npc else 0)
    gpx = wi[b + _GX]
    gpy = wi[b + _GY]
    gqx = wi[bn + _GX]
    gqy = wi[bn + _GY]
    kq = gqx * ey - gqy * ex
    spmax = np.int64(0)  # at v = s_p
    sqmin = np.int64(0)
    area = 0.0
    kmax = ap
    mono = False
    x0 = min(ax, bx)  # the box of the piece's vertices
    y0 = min(ay, by)
    x1 = max(ax, bx)
    y1 = max(ay, by)
    if single:
        mono = True
        acc = 0.0
        d0 = np.int64(0)
        c0 = np.int64(0)
        cmax = np.int64(0)
        kc = ap
        e2max = np.int64(0)
        ke = ap
        for kk in range(ap + 1, aq + 1):
            k = kk if kk < n else kk - n
            vx = rc[r0 + k, 0]
            vy = rc[r0 + k, 1]
            x0 = min(x0, vx)
            y0 = min(y0, vy)
            x1 = max(x1, vx)
            y1 = max(y1, vy)
            qx = vx - ax
            qy = vy - ay
            d1 = qx * ex + qy * ey
            c1 = ex * qy - ey * qx
            spmax = max(spmax, gpx * qy - gpy * qx)
            sqmin = min(sqmin, gqx * qy - gqy * qx)
            if d1 <= 0:
                e2 = qx * qx + qy * qy
                if e2 > e2max:
                    e2max = e2
                    ke = k
            elif d1 >= len2:
                rx = vx - bx
                ry = vy - by
                e2 = rx * rx + ry * ry
                if e2 > e2max:
                    e2max = e2
                    ke = k
            elif abs(c1) > cmax:
                cmax = abs(c1)
                kc = k
            if mono:
                if d1 < d0:
                    mono = False
                else:
                    acc += _strip(d1 - d0, c0, c1)
                    d0 = d1
                    c0 = c1
        hc = np.float64(cmax) / np.sqrt(np.float64(len2))
        he = np.sqrt(np.float64(e2max))
        ub = hc if hc >= he else he
        kmax = kc if hc >= he else ke
        h = ub
        area = acc / np.float64(len2) if mono else -1.0
    else:
        ub = 0.0
        un = 0.0  # num / den: the squared distance _near_edge chose for ub
        ud = 1.0
        for kk in range(ap, aq + 1):
            k = kk if kk < n else kk - n
            px = rc[r0 + k, 0]
            py = rc[r0 + k, 1]
            # the nearest simplified edge p..q-1, measured exactly: at least
            # the vertex's distance to the ring. Measured only when its squared
            # distance is not below ub's by the margin _BELOW: the measured
            # distances square to num / den within a few roundings (2**-50), so
            # a vertex below the margin cannot exceed ub (ub and kmax are those
            # of measuring every vertex)
            bn, bd, near = _near_edge(px, py, sc, s0, m, p, (q - p) % m)
            if bn * ud >= un * bd * _BELOW:
                best = _edge_distance(px, py, sc, s0, m, near)
                if best > ub:
                    ub = best
                    kmax = k
                    un = bn
                    ud = bd
        h = np.inf  # no band: the piece has no single chord
        # box and sides over the piece's vertices: raw ap..aq, then simplified
        # p..q-1 (one loop over both chains)
        n_raw = aq - ap + 1
        j = p
        for i in range(n_raw + (q - p) % m):
            if i < n_raw:
                k = ap + i if ap + i < n else ap + i - n
                vx = rc[r0 + k, 0]
                vy = rc[r0 + k, 1]
            else:
                vx = sc[s0 + j, 0]
                vy = sc[s0 + j, 1]
                j = j + 1 if j + 1 < m else 0
            x0 = min(x0, vx)
            y0 = min(y0, vy)
            x1 = max(x1, vx)
            y1 = max(y1, vy)
            spmax = max(spmax, gpx * (vy - ay) - gpy * (vx - ax))
            sqmin = min(sqmin, gqx * (vy - ay) - gqy * (vx - ax))
        area = _two_chain_area(rc, r0, n, sc, s0, m, p, q, ap, aq)
    wi[b + _X0] = x0
    wi[b + _Y0] = y0
    wi[b + _X1] = x1
    wi[b + _Y1] = y1
    wi[b + _KIND] = 1 if single and mono else 2  # the caller sets 0 for no area
    wi[b + _KMAX] = kmax
    wi[b + _SIDE] = (1 if spmax <= 0 else 0) + (2 if sqmin >= kq else 0)
    wf[_NF * t + _UB] = ub
    wf[_NF * t + _H] = h
    return area


@kernel(F64(I64_2D, I64, I64, I64_2D, I64, I64, _W1, I64, _W1, _WF, _W2, I64),
        _nrt=False)
def _runs_pass(rc, r0, n, sc, s0, m, anchor, first, wi, wf, e, npc):
    """Record the ``npc`` runs from the anchors, then measure each (:func:`_run`).

    ``first``: the first anchored simplified vertex. Returns the sum of the
    pieces' areas. Allocates nothing, so it is compiled without reference
    counting: an array passed to an inlined helper otherwise costs an atomic
    increment and decrement per run.
    """
    p = first
    for t in range(npc):
        q = p + 1 if p + 1 < m else 0
        while anchor[q] < 0:
            q = q + 1 if q + 1 < m else 0
        b = _NI * t
        wi[b + _P] = p
        wi[b + _Q] = q
        wi[b + _AP] = anchor[p]
        wi[b + _AQ] = anchor[q] if anchor[q] > anchor[p] else anchor[q] + n
        gx, gy = _separator(sc, s0, m, p)
        wi[b + _GX] = gx
        wi[b + _GY] = gy
        p = q
    total = 0.0
    for t in range(npc):
        b = _NI * t
        area = _run(rc, r0, n, sc, s0, m, wi, wf, t, npc)
        if area < 0.0:  # a chain folds back along the chord: the sweep
            area = _piece_area(rc, r0, n, sc, s0, m, wi[b + _P], wi[b + _Q],
                               wi[b + _AP], wi[b + _AQ], e)
        if not area > 0.0:
            wi[b + _KIND] = 0
        wf[_NF * t + _AREA] = area
        total += area
    return total


@kernel(I64(_W1, _W1, I64), _nrt=False)
def _join_neighbours(wi, parent, npc):
    """Join (in a fresh ``parent`` forest) neighbouring runs no line separates.

    Returns the number of joins. Allocates nothing: compiled without reference
    counting (see :func:`_runs_pass`).
    """
    for t in range(npc):
        parent[t] = t
    joined = 0
    for t in range(npc):
        tl = t - 1 if t > 0 else npc - 1
        if (wi[_NI * t + _KIND] != 0 and wi[_NI * tl + _KIND] != 0
                and not _neighbours_apart(wi, t, npc)):
            rt = _find(parent, t)
            rl = _find(parent, tl)
            if rt != rl:
                parent[max(rt, rl)] = min(rt, rl)
                joined += 1
    return joined


@kernel(F64(I64_2D, I64, I64, I64_2D, I64, I64, _W1, _WF, I64))
def _raw_to_simp(rc, r0, n, sc, s0, m, wi, wf, npc):
    """Exact largest distance from a raw vertex to the simplified ring.

    Every run holds the largest bound of its raw vertices (their distance to the
    run's simplified edges, a subset of the ring's). The vertex with the largest
    bound is measured against all edges; if that does not settle it, runs whose
    bound exceeds the best exact distance are revisited, largest first, and their
    vertices whose bound exceeds it measured exactly.
    """
    top = 0
    for t in range(1, npc):
        if wf[_NF * t + _UB] > wf[_NF * top + _UB]:
            top = t
    bound = wf[_NF * top + _UB]
    if bound == 0.0:
        return 0.0
    k = wi[_NI * top + _KMAX]
    best = _to_ring_within(rc[r0 + k, 0], rc[r0 + k, 1], sc, s0, m, bound)
    if best == bound:
        return best
    keys = np.empty(npc, np.float64)
    for t in range(npc):
        keys[t] = -wf[_NF * t + _UB]
    order = np.argsort(keys)
    for i in range(npc):
        t = order[i]
        if wf[_NF * t + _UB] <= best:
            break
        b = _NI * t
        p = wi[b + _P]
        q = wi[b + _Q]
        for kk in range(wi[b + _AP], wi[b + _AQ] + 1):
            k = kk if kk < n else kk - n
            px = rc[r0 + k, 0]
            py = rc[r0 + k, 1]
            u = _near_edge_distance(px, py, sc, s0, m, p, (q - p) % m)
            if u > best:
                best = max(best, _to_ring_within(px, py, sc, s0, m, u))
    return best


@kernel(F64(I64_2D, I64, I64, I64_2D, I64, I64, _W1, I64, _WF))
def _simp_to_raw(rc, r0, n, sc, s0, m, wi, npc, ub):
    """Exact largest distance from a simplified vertex to the raw ring.

    Anchored vertices are raw vertices (distance 0). A moved vertex inside run
    p..q is bounded by the raw edges ap..aq; the largest bounds are then measured
    against all raw edges, largest first, until no bound exceeds the best.
    """
    top = -1
    for t in range(npc):
        b = _NI * t
        p = wi[b + _P]
        q = wi[b + _Q]
        ap = wi[b + _AP]
        aq = wi[b + _AQ]
        j = p + 1 if p + 1 < m else 0
        while j != q:
            # the nearest raw edge ap..aq-1, measured exactly: at least the
            # vertex's distance to the ring
            u = _near_edge_distance(sc[s0 + j, 0], sc[s0 + j, 1], rc, r0, n, ap,
                                    aq - ap)
            ub[j] = u
            if top < 0 or u > ub[top]:
                top = j
            j = j + 1 if j + 1 < m else 0
        ub[p] = 0.0
    if top < 0 or ub[top] == 0.0:
        return 0.0
    best = _to_ring_within(sc[s0 + top, 0], sc[s0 + top, 1], rc, r0, n, ub[top])
    if best == ub[top]:
        return best
    return settle_bounds(sc, s0, m, rc, r0, n, ub, best)


@kernel(types.Tuple((F64, F64, F64, B1))(I64_2D, I64, I64, I64_2D, I64, I64, _W1,
                                        _W1, _WF, _WF, _W2))
def _compare_one(rc, r0, n, sc, s0, m, anchor, wi, wf, ub, e):
    """(raw -> simp, simp -> raw, ∫|w_raw - w_simp|, linear) of one ring pair."""
    if m == 0:
        return np.nan, np.nan, _ring_area(rc, r0, n, sc, s0, m, e), False
    matched = _match(rc, r0, n, sc, s0, m, anchor)
    npc = 0
    first = -1
    if matched:
        for j in range(m):
            if anchor[j] >= 0:
                npc += 1
                if first < 0:
                    first = j
    if npc < 2:  # no usable correspondence: bounds from walks, and the sweep
        return (directed_distance(rc, r0, n, sc, s0, m, ub),
                directed_distance(sc, s0, m, rc, r0, n, ub),
                _ring_area(rc, r0, n, sc, s0, m, e), False)
    total = _runs_pass(rc, r0, n, sc, s0, m, anchor, first, wi, wf, e, npc)
    d1 = _raw_to_simp(rc, r0, n, sc, s0, m, wi, wf, npc)
    d2 = _simp_to_raw(rc, r0, n, sc, s0, m, wi, npc, ub)
    # runs that may overlap (neighbours no line separates, others too close)
    # form components, each measured by one sweep over its pieces together
    parent = anchor  # the anchors are not needed any more
    joined = _join_neighbours(wi, parent, npc)
    if joined == npc - 1 or not _others_conflicts(rc, r0, n, sc, s0, m, wi, wf,
                                                  parent, npc):
        return d1, d2, _ring_area(rc, r0, n, sc, s0, m, e), False
    lone = True
    for t in range(npc):
        if _find(parent, t) != t:
            lone = False
    if lone:
        return d1, d2, total, True
    # components in root order: count, then each root's runs' edges together
    start = np.zeros(npc + 1, np.int64)
    for t in range(npc):
        parent[t] = _find(parent, t)
        start[parent[t] + 1] += 1
    if start[1] == npc:
        return d1, d2, _ring_area(rc, r0, n, sc, s0, m, e), False
    for t in range(npc):
        start[t + 1] += start[t]
    runs = np.empty(npc, np.int64)  # the runs of each root, in order
    fill = start[:npc].copy()
    for t in range(npc):
        runs[fill[parent[t]]] = t
        fill[parent[t]] += 1
    for root in range(npc):
        if start[root + 1] - start[root] < 2:
            continue
        ne = 0
        for i in range(start[root], start[root + 1]):
            t = runs[i]
            total -= wf[_NF * t + _AREA]
            ne = _add_run_edges(rc, r0, n, sc, s0, m, wi, t, root, e, ne)
        total += winding_area(e, ne)
    return d1, d2, total, True


@kernel(
    types.void(I64_2D, I64_1D, I64_2D, I64_1D, I64_1D, I64, I64, _WF, _WF, _WF,
               _WB)
)
def compare_range(raw, raw_offsets, simp, simp_offsets, rings, i0, i1,
                  out_raw_to_simp, out_simp_to_raw, out_xor_area, out_linear):
    """:func:`compare_rings` of rings ``rings[i0:i1]``, into the ``out_*`` arrays.

    Ring ``rr = rings[i]`` is measured into ``out_*[rr]``; the other entries are
    left as they are. Serial: ``vecslice.metrics`` runs disjoint ranges on a few
    threads (the kernel releases the GIL; a serial kernel compiles much faster
    than a ``parallel=True`` one).
    """
    size = 1
    for i in range(i0, i1):
        rr = rings[i]
        size = max(size, raw_offsets[rr + 1] - raw_offsets[rr]
                   + simp_offsets[rr + 1] - simp_offsets[rr])
    anchor = np.empty(size + 1, np.int64)
    wi = np.empty(_NI * (size + 1), np.int64)
    wf = np.empty(_NF * (size + 1), np.float64)
    ub = np.empty(size + 1, np.float64)
    e = np.empty((size + 1, 4), np.int64)
    for i in range(i0, i1):
        rr = rings[i]
        a0 = raw_offsets[rr]
        b0 = simp_offsets[rr]
        d1, d2, a, lin = _compare_one(
            raw, a0, raw_offsets[rr + 1] - a0, simp, b0,
            simp_offsets[rr + 1] - b0, anchor, wi, wf, ub, e,
        )
        out_raw_to_simp[rr] = d1
        out_simp_to_raw[rr] = d2
        out_xor_area[rr] = a
        out_linear[rr] = lin


@kernel(
    types.Tuple((_F64_OUT, _F64_OUT, _F64_OUT, _B1_OUT))(I64_2D, I64_1D, I64_2D,
                                                         I64_1D)
)
def compare_rings(raw, raw_offsets, simp, simp_offsets):
    """Deviation both ways and XOR area of every (raw, simplified) ring pair.

    Returns ``(raw_to_simp, simp_to_raw, xor_area, linear)``, each of shape (R,):
    the largest distance (µm) from a raw vertex to the simplified ring and from a
    simplified vertex to the raw ring (NaN where the simplified ring is empty);
    ``∫ |w_raw - w_simp| dA`` in µm²; and whether the pass over the runs settled
    the area (False: the sweep over the whole ring pair did). Serial; see
    :func:`compare_range`.
    """
    n_rings = raw_offsets.shape[0] - 1
    out1 = np.empty(n_rings, np.float64)
    out2 = np.empty(n_rings, np.float64)
    area = np.empty(n_rings, np.float64)
    linear = np.zeros(n_rings, np.bool_)
    compare_range(raw, raw_offsets, simp, simp_offsets,
                  np.arange(n_rings, dtype=np.int64), 0, n_rings, out1, out2, area,
                  linear)
    return out1, out2, area, linear
