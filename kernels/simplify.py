"""CuraEngine-exact simplification of rings and polylines, plus ring clean-up kernels.

One call processes a whole ragged array ``(coords, ring_offsets)``, or a range
of its rings (:func:`simplify_range`, which ``vecslice.simplify`` runs on a few
threads: a serial kernel compiles several times faster than a ``parallel=True``
one), writing the results back to back from the range's first input offset;
rings whose result is empty keep a zero-length range, so output ring ``r`` still
belongs to input ring ``r``. Helpers are plain kernels, not inlined: each is
compiled once, and LLVM still inlines them. The exception is :func:`_importance`,
inlined by numba into :func:`simplify_range` (LLVM left it a call; inlined, the
kernel is 2-4% faster for a few tenths of a second more on its first compile).

The algorithm is CuraEngine's ``Simplify::simplify`` (see ``spec/SIMPLIFY.md``):
a min-heap of ``(importance, index)`` with stale entries re-pushed, passes until
one removes nothing, size guards that use the ORIGINAL vertex count, and the
replacement of a short edge by the intersection of its neighbouring edges.
CuraEngine walks a ``to_delete`` array to find the nearest kept neighbours; here a
doubly linked list over the kept vertices gives the same neighbours in O(1).
The removals happen in exactly CuraEngine's order, with much less work: pops that
cannot change anything are skipped, a pass after the first looks only at the
vertices whose entry can change anything, importances are recomputed only where
their inputs changed (the first pass computes them in a vectorised loop), and
the queue is a bucket queue for the usual keys (see :func:`simplify_range`).

Preconditions (the caller checks them): |coords| < 2**30; ring_offsets starts at
0, never decreases and ends at len(coords); 0 <= thresholds < 2**31; widths, where
given, satisfy |w| < 2**30.
"""

import numpy as np
from numba import config, types
from numba.cpython.unsafe.numbers import trailing_zeros

from ._jit import kernel
from ._types import B1, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .geometry import (
    dist2_from_segment,
    line_line_intersection,
    tdiv,
    vsize,
    wadd,
    wmul,
    wsize2,
)

if config.DISABLE_JIT:  # numba's intrinsic has no plain-Python body
    def trailing_zeros(x):
        """Index of the lowest set bit of a non-zero int64."""
        u = int(x) & (2**64 - 1)
        return (u & -u).bit_length() - 1

# the index of simplify_range's work arrays: every index there is >= 0, and an
# unsigned one spares numba's wraparound of negative indices (on noisy circles
# and on Benchy loops the kernel takes 0.80-0.86 of its former time)
_U = np.uint64
INT64_MAX = np.iinfo(np.int64).max
INT64_MIN = np.iinfo(np.int64).min
MIN_RES2 = 25  # CuraEngine's min_resolution (5 µm), squared

_W1 = types.int64[::1]  # writable work arrays
_W2 = types.int64[:, ::1]
# keys d*d, 0 <= d < 2 * (max_deviation + 1), go to buckets (one bitmap over the
# ring's vertex indices each) instead of the heap when
# max_deviation < _MAX_BUCKETS
_MAX_BUCKETS = 65


@kernel(I64(I64, I64, I64, I64, I64, I64, I64, I64, I64))
def _area_deviation(bx, by, bw, vx, vy, vw, ax, ay, aw):
    """Extrusion-area deviation of removing vertex v between b and a."""
    ab = vsize(vx - bx, vy - by)
    bc = vsize(ax - vx, ay - vy)
    ac = vsize(ax - bx, ay - by)
    if ab == 0 or ac == 0 or bc == 0:
        return 0
    wd = max(abs(vw - bw), abs(aw - vw))
    if wd > 1:
        ab_w = tdiv(bw + vw, 2)
        bc_w = tdiv(vw + aw, 2)
        avg = tdiv(wadd(wmul(ab, ab_w), wmul(bc, bc_w)), ac)
        return wadd(wmul(abs(ab_w - avg), ab), wmul(abs(bc_w - avg), bc))
    if ab > bc:
        return wmul(wd, bc)
    return wmul(wd, ab)


@kernel(I64(I64, I64, I64, I64, I64, I64))
def _dist2_line(px, py, ax, ay, bx, by):
    """``dist2_from_line(p, a, b)``, bit for bit, with the length kept a double.

    ``rint(sqrt(s))`` is integer valued and below 2**32, so vsize's conversion
    to int64 and back to double changes nothing; a wrapped (negative) squared
    length gives vsize's INT64_MIN.
    """
    sx = bx - ax
    sy = by - ay
    s = wsize2(sx, sy)
    ab = np.rint(np.sqrt(np.float64(s))) if s >= 0 else np.float64(INT64_MIN)
    if ab == 0.0:
        d = vsize(px - ax, py - ay)
    else:
        area2 = wadd(wmul(px - bx, py - ay), wmul(ax - px, py - by))
        d = np.int64(np.float64(abs(area2)) / ab)
    return wmul(d, d)


@kernel(inline="always")
def _importance(has_w, bx, by, bw, vx, vy, vw, ax, ay, aw, max_res2, max_area):
    """CuraEngine's importance of vertex v between kept neighbours b and a.

    Inlined into its callers (see the module's docstring).

    (Open polyline end points, INT64_MAX, are the caller's business.)
    """
    if has_w and _area_deviation(bx, by, bw, vx, vy, vw, ax, ay, aw) > max_area:
        return INT64_MAX
    d2 = _dist2_line(vx, vy, bx, by, ax, ay)
    lb = wsize2(bx - vx, by - vy)
    la = wsize2(ax - vx, ay - vy)
    # unpredictable on noisy input: one select instead of branches
    long_edges = (d2 > MIN_RES2) & (lb > max_res2) & (la > max_res2)
    return INT64_MAX if long_edges else d2


@kernel(
    types.Tuple((B1, I64, I64))(I64, I64, I64, I64, I64, I64, I64, I64, I64),

)
def _collapse(p0x, p0y, p1x, p1y, p2x, p2y, p3x, p3y, max_dev2):
    """Replace the short edge p1-p2 by the intersection X of lines p0-p1, p2-p3.

    Returns ``(ok, X)``; ok only if X exists and lies within max_dev² of the
    segment p1-p2 (CuraEngine's ``dist2_from_segment(p1, X, p2)``).
    """
    ok, x, y = line_line_intersection(p0x, p0y, p1x, p1y, p2x, p2y, p3x, p3y)
    if ok and dist2_from_segment(p1x, p1y, x, y, p2x, p2y) > max_dev2:
        ok = False
    return ok, x, y


@kernel(types.void(_W1, _W1, I64, I64))
def _sift_down(hk, hi, pos, size):
    """Restore the heap below ``pos``; entries ordered by (key, index).

    Indices are cast to unsigned (all are >= 0): numba then skips the
    negative-index wrap-around code.
    """
    p = np.uint64(pos)
    end = np.uint64(size)
    k = hk[p]
    v = hi[p]
    while True:
        c = p + p + np.uint64(1)
        if c >= end:
            break
        r = c + np.uint64(1)
        kc = hk[c]
        if r < end:
            kr = hk[r]
            if kr < kc or (kr == kc and hi[r] < hi[c]):
                c = r
                kc = kr
        if kc < k or (kc == k and hi[c] < v):
            hk[p] = kc
            hi[p] = hi[c]
            p = c
        else:
            break
    hk[p] = k
    hi[p] = v


@kernel(types.void(_W1, _W1, I64, I64, I64))
def _push(hk, hi, size, key, idx):
    """Insert (key, idx) into a heap holding ``size`` entries."""
    p = np.uint64(size)
    while p > np.uint64(0):
        parent = (p - np.uint64(1)) >> np.uint64(1)
        kp = hk[parent]
        if kp < key or (kp == key and hi[parent] < idx):
            break
        hk[p] = kp
        hi[p] = hi[parent]
        p = parent
    hk[p] = key
    hi[p] = idx


@kernel(I64(I64, I64))
def _high_bucket(key, nb2):
    """Bucket of a queue key not in the look-up table: d if key == d*d < nb2.

    Else -1 (the heap). These are rare: stale keys above max_deviation². The
    double square root of a perfect square below 2**52 is exact.
    """
    if key < nb2:
        d = np.int64(np.sqrt(np.float64(key)))
        if d * d == key:
            return d
    return -1


@kernel(types.void(_W1, _W1, _W1, I64, I64))
def _importance_run(px, py, imp, n, max_res2):
    """``_importance`` (no widths) of vertices 1 .. n-2, for the first pass.

    Each vertex lies between its index neighbours; the body is branch-free so
    that the loop vectorises. Same values as ``_importance``: in the first pass
    |coords| < 2**30, so the squared sums cannot wrap (the square of the
    distance can: ``wmul``), and rint(sqrt) is an integer-valued double already.
    """
    for i in range(1, n - 1):
        bx = px[i - 1]
        by = py[i - 1]
        vx = px[i]
        vy = py[i]
        ax = px[i + 1]
        ay = py[i + 1]
        dx = ax - bx
        dy = ay - by
        ab = np.rint(np.sqrt(np.float64(dx * dx + dy * dy)))
        area2 = abs((vx - ax) * (vy - by) + (bx - vx) * (vy - ay))
        lb = (bx - vx) * (bx - vx) + (by - vy) * (by - vy)
        la = (ax - vx) * (ax - vx) + (ay - vy) * (ay - vy)
        d = np.int64(np.float64(area2) / max(ab, 1.0))
        d0 = np.int64(np.rint(np.sqrt(np.float64(lb))))  # line of length 0
        d = d0 if ab == 0.0 else d
        d2 = wmul(d, d)
        long_edges = (d2 > MIN_RES2) & (lb > max_res2) & (la > max_res2)
        imp[i] = INT64_MAX if long_edges else d2


# Vertex flags of simplify_range. A vertex has at most one queue entry per pass,
# keyed (imp[i], i), where imp[i] is its importance when the entry was made.
_DIRTY = 1  # the inputs of its importance (it, its neighbours) changed since
_FAILED = 2  # a removal attempt failed and its window (itself and two kept
#              neighbours on each side) is unchanged since: a retry fails too
_DELETED = 4
_INHEAP = 8  # its entry is in the heap
_CAND = 16  # listed as a candidate for the next pass
_EPOCH = 5  # fl >> _EPOCH: the last pass in which its entry was gone (popped,
#             or passed over); "popped" below means: in the current pass
# A kept vertex neither in the heap nor popped has a "side" entry: kept out of
# the heap because popping it would change nothing (see simplify_range).


@kernel(B1(I64, I64, I64, I64, I64, I64))
def _tiny(x0, y0, x1, y1, x2, y2):
    """CuraEngine's small-path test for a path of exactly the minimum size.

    True when the longest squared side among (p1 - p0, p2 - p0, p2 - p1) is below
    25 µm².
    """
    d1 = wsize2(x1 - x0, y1 - y0)
    d2 = wsize2(x2 - x0, y2 - y0)
    d3 = wsize2(x2 - x1, y2 - y1)
    return max(max(d1, d2), d3) < MIN_RES2


@kernel(
    types.void(I64_2D, I64_1D, I64_1D, B1, B1, I64, I64, I64, I64, I64, _W2, _W1,
               _W1)
)
def simplify_range(coords, widths, ring_offsets, has_w, closed, max_resolution,
                   max_deviation, max_area_deviation, r0, r1, out_coords,
                   out_widths, out_counts):
    """Simplify rings ``r0 .. r1-1``, writing the results back to back.

    The results go to ``out_coords`` (and ``out_widths`` when ``has_w``) from
    row ``ring_offsets[r0]`` on (a result is never longer than its input, so
    disjoint ring ranges write disjoint rows), and ring r's vertex count to
    ``out_counts[r]``. Serial: callers run disjoint ranges on several threads
    (the kernel releases the GIL). ``widths`` is ignored unless ``has_w``.

    Each ring is copied to px/py/pw, simplified there (kept vertices compacted
    to the front in their original order) with work arrays prv, nxt, fl, imp,
    hk, hi, cand (length >= the ring's size), tq (12), bits (nb * ceil(n / 64))
    and bq (2 * nb + nl * nl, its tail holding the bucket of every key below
    nl * nl: d where key == d * d, else -1) for ``nb`` buckets (0: the heap
    alone), nl <= nb.

    The priority queue pops (key, index) in increasing order. It is a bucket
    queue for the keys d*d with d < nb (importances are squared integer
    distances; nl = max_dev + 1 buckets hold every key <= max_dev², the others
    the stale keys just above, of entries whose window changed): bucket d is a
    bitmap over the vertex indices, scanned from its lowest possibly set word;
    other keys go to a binary heap (hk, hi), and the smaller of both heads
    pops first.

    CuraEngine pops every kept vertex in every pass, in (importance, index)
    order, re-pushing an entry whose importance changed. Most pops change
    nothing: an entry whose importance is unchanged and either above max_dev²
    (skipped) or known to fail removal again. Such entries stay out of the heap
    ("side" entries). The removals happen in exactly CuraEngine's order:

    * the heap pops in (key, index) order and each vertex has at most one
      entry, so the original heap has popped entry E exactly when the largest
      entry popped so far (the high-water mark ``hwk, hwi``) is >= E; popping a
      side entry changes nothing, and only pops of real entries change state;
    * when a removal changes a side entry's window and the mark has not passed
      it, the entry enters the heap with its old key, as the original still
      holds it; if the mark has passed it, the original popped it already;
    * importances are recomputed only where their inputs changed (``_DIRTY``),
      which gives the value CuraEngine recomputes at every pop;
    * a stale entry (k, i) whose importance dropped to cur < k would be
      re-pushed as the smallest entry and popped next: it is handled at once;
    * a pass whose queue starts empty removes nothing: the loop ends;
    * at the end of a pass the queue is empty, and a kept vertex can enter the
      next pass's queue only if it is ``_DIRTY`` or its ``_FAILED`` was cleared,
      that is if its window changed after its entry was popped (or passed
      over) in this pass: such vertices are listed (``cand``), and the next
      pass looks at them alone (the first pass at every vertex). "Popped in
      this pass" is the pass number kept in the flags' high bits (``_EPOCH``).
    (In this description "heap" means the whole priority queue.)
    """
    max_res2 = max_resolution * max_resolution
    max_dev2 = max_deviation * max_deviation
    max_area = max_area_deviation
    # lut buckets: every key <= max_dev²; more buckets for the stale keys above
    nl = max_deviation + 1 if max_deviation < _MAX_BUCKETS else 0
    nb = 2 * nl
    max_len = 0
    for rr in range(r0, r1):
        max_len = max(max_len, ring_offsets[rr + 1] - ring_offsets[rr])
    px = np.empty(max_len, np.int64)
    py = np.empty(max_len, np.int64)
    pw = np.zeros(max_len, np.int64)
    prv = np.empty(max_len, np.int64)
    nxt = np.empty(max_len, np.int64)
    fl = np.empty(max_len, np.int64)
    imp = np.empty(max_len, np.int64)
    hk = np.empty(max_len, np.int64)
    hi = np.empty(max_len, np.int64)
    tq = np.empty(12, np.int64)
    cand = np.empty(max_len, np.int64)
    bits = np.empty(nb * ((max_len + 63) >> 6), np.int64)
    bq = np.full(2 * nb + nl * nl, -1, np.int64)
    for d in range(nl):
        bq[_U(2 * nb + d * d)] = d
    min_size = 3 if closed else 2
    pos = ring_offsets[r0]
    for rr in range(r0, r1):
        start = ring_offsets[rr]
        n = ring_offsets[rr + 1] - start
        for t in range(n):
            px[_U(t)] = coords[start + t, 0]
            py[_U(t)] = coords[start + t, 1]
        if has_w:
            for t in range(n):
                pw[_U(t)] = widths[start + t]
        if n <= min_size:
            m = n
            if n < min_size or _tiny(px[0], py[0], px[1], py[1],
                                     px[_U(n - 1)], py[_U(n - 1)]):
                m = 0
        else:
            for i in range(n):
                prv[_U(i)] = i - 1
                nxt[_U(i)] = i + 1
            prv[0] = n - 1
            nxt[_U(n - 1)] = 0
            if has_w:
                for i in range(n):
                    fl[_U(i)] = _DIRTY
            else:
                _importance_run(px, py, imp, n, max_res2)
                for i in range(n):
                    fl[_U(i)] = 0
                fl[0] = _DIRTY
                fl[_U(n - 1)] = _DIRTY
            nw = (n + 63) >> 6
            lut = 2 * nb  # bq[lut + key]: d if key == d*d (d < nl), else -1
            nb2 = nb * nb
            nl2 = nl * nl
            for q in range(nb * nw):
                bits[_U(q)] = 0
            for d in range(nb):
                bq[_U(d)] = 0  # entries in bucket d
                bq[_U(nb + d)] = nw  # no set bit in bucket d below this word
            nc = n  # candidates of the first pass: every vertex
            for i in range(n):
                cand[_U(i)] = i
            removed = -1
            pas = 0
            # every pass that continues removes >= 1 vertex, so at most n passes
            while n - removed > min_size and removed != 0:
                removed = 0
                pas += 1
                popped = pas << _EPOCH
                size = 0  # heap entries
                nbk = 0  # bucket entries
                dmin = nb  # no entry in a bucket below dmin
                # only candidates can have an entry that changes anything: every other
                # kept vertex has an unchanged importance, and it is > max_dev² or a
                # removal is known to fail
                for c in range(nc):
                    i = cand[_U(c)]
                    f = fl[_U(i)] & ~_CAND
                    if f & _DELETED:
                        fl[_U(i)] = f
                        continue
                    if f & _DIRTY:
                        if not closed and (i == 0 or i == n - 1):
                            imp[_U(i)] = INT64_MAX
                        else:
                            b = prv[_U(i)]
                            a = nxt[_U(i)]
                            imp[_U(i)] = _importance(
                                has_w, px[_U(b)], py[_U(b)], pw[_U(b)],
                                px[_U(i)], py[_U(i)], pw[_U(i)],
                                px[_U(a)], py[_U(a)], pw[_U(a)], max_res2, max_area)
                        f ^= _DIRTY
                    k = imp[_U(i)]
                    if k <= max_dev2 and (f & _FAILED) == 0:
                        d = (bq[_U(lut + k)] if 0 <= k < nl2
                             else _high_bucket(k, nb2))
                        if d >= 0:
                            w = i >> 6
                            bits[_U(d * nw + w)] |= np.int64(1) << (i & 63)
                            bq[_U(d)] += 1
                            bq[_U(nb + d)] = min(bq[_U(nb + d)], w)
                            dmin = min(dmin, d)
                            nbk += 1
                        else:
                            hk[_U(size)] = k
                            hi[_U(size)] = i
                            size += 1
                        f |= _INHEAP
                    fl[_U(i)] = f
                nc = 0
                for h in range(size // 2 - 1, -1, -1):
                    _sift_down(hk, hi, h, size)
                hwk = INT64_MIN
                hwi = -1
                # an entry is re-pushed only when its importance changed, which needs a
                # removal in between, so this ends
                while size + nbk > 0 and n - removed > min_size:
                    from_bucket = False
                    if nbk > 0:
                        while bq[_U(dmin)] == 0:
                            dmin += 1
                        base = dmin * nw
                        w = bq[_U(nb + dmin)]
                        while bits[_U(base + w)] == 0:
                            w += 1
                        bq[_U(nb + dmin)] = w
                        k = dmin * dmin
                        i = (w << 6) + trailing_zeros(bits[_U(base + w)])
                        from_bucket = (size == 0 or k < hk[0]
                                       or (k == hk[0] and i < hi[0]))
                    if from_bucket:
                        bits[_U(base + w)] &= ~(np.int64(1) << (i & 63))
                        bq[_U(dmin)] -= 1
                        nbk -= 1
                    else:
                        k = hk[0]
                        i = hi[0]
                        size -= 1
                        if size > 0:
                            hk[0] = hk[_U(size)]
                            hi[0] = hi[_U(size)]
                            _sift_down(hk, hi, 0, size)
                    if k > hwk or (k == hwk and i > hwi):
                        hwk = k
                        hwi = i
                    f = fl[_U(i)]
                    b = prv[_U(i)]
                    a = nxt[_U(i)]
                    if f & _DIRTY:
                        if not closed and (i == 0 or i == n - 1):
                            cur = INT64_MAX
                        else:
                            cur = _importance(
                                has_w, px[_U(b)], py[_U(b)], pw[_U(b)],
                                px[_U(i)], py[_U(i)], pw[_U(i)],
                                px[_U(a)], py[_U(a)], pw[_U(a)], max_res2, max_area)
                        imp[_U(i)] = cur
                        f ^= _DIRTY
                        if cur > k:  # re-push; dirty implies not _FAILED
                            if cur <= max_dev2:
                                d = (bq[_U(lut + cur)] if 0 <= cur < nl2
                                     else _high_bucket(cur, nb2))
                                if d >= 0:
                                    w = i >> 6
                                    bits[_U(d * nw + w)] |= np.int64(1) << (i & 63)
                                    bq[_U(d)] += 1
                                    bq[_U(nb + d)] = min(bq[_U(nb + d)], w)
                                    dmin = min(dmin, d)
                                    nbk += 1
                                else:
                                    _push(hk, hi, size, cur, i)
                                    size += 1
                            else:  # would be skipped unless its inputs change again
                                f ^= _INHEAP
                            fl[_U(i)] = f
                            continue
                        # cur < k: the re-pushed entry (cur, i) would be the smallest
                        # (all others are > (k, i)), popped at once: go on with it
                        k = cur
                    f = ((f & ((1 << _EPOCH) - 1)) ^ _INHEAP) | popped
                    if k > max_dev2:
                        fl[_U(i)] = f
                        continue
                    # CuraEngine's remove(i): moved = -1 (nothing moves), b or a
                    moved = -2
                    if k <= MIN_RES2:
                        moved = -1
                    else:
                        vx = px[_U(i)]
                        vy = py[_U(i)]
                        lb = wsize2(vx - px[_U(b)], vy - py[_U(b)])
                        la = wsize2(vx - px[_U(a)], vy - py[_U(a)])
                        if lb <= max_res2 and la <= max_res2:
                            moved = -1
                        elif lb <= la:  # the edge before i is short (a tie too)
                            if closed or b != 0:
                                bb = prv[_U(b)]
                                ok, x, y = _collapse(
                                    px[_U(bb)], py[_U(bb)], px[_U(b)], py[_U(b)],
                                    vx, vy, px[_U(a)], py[_U(a)], max_dev2)
                                if ok:
                                    moved = b
                        elif closed or a != n - 1:
                            aa = nxt[_U(a)]
                            ok, x, y = _collapse(
                                px[_U(b)], py[_U(b)], vx, vy, px[_U(a)], py[_U(a)],
                                px[_U(aa)], py[_U(aa)], max_dev2)
                            if ok:
                                moved = a
                    if moved == -2:
                        fl[_U(i)] = f | _FAILED
                        continue
                    fl[_U(i)] = f | _DELETED
                    removed += 1
                    nxt[_U(b)] = a
                    prv[_U(a)] = b
                    # vertices whose window changed (tq[2q]) and whether their
                    # importance inputs did (tq[2q + 1])
                    tq[0] = b
                    tq[1] = _DIRTY
                    tq[2] = a
                    tq[3] = _DIRTY
                    tq[4] = prv[_U(b)]
                    tq[5] = 0
                    tq[6] = nxt[_U(a)]
                    tq[7] = 0
                    nt = 4
                    if moved >= 0:
                        if has_w:
                            pw[_U(moved)] = tdiv(pw[_U(b)] + pw[_U(a)], 2)
                        px[_U(moved)] = x
                        py[_U(moved)] = y
                        nt = 5
                        if moved == b:
                            tq[5] = _DIRTY
                            tq[8] = prv[tq[4]]
                        else:
                            tq[7] = _DIRTY
                            tq[8] = nxt[tq[6]]
                        tq[9] = 0
                    for q in range(nt):
                        j = tq[_U(2 * q)]
                        f = (fl[_U(j)] & ~_FAILED) | tq[_U(2 * q + 1)]
                        if (f & _INHEAP) == 0:
                            if (f >> _EPOCH) != pas:  # side entry
                                kj = imp[_U(j)]
                                # not passed over yet:
                                if kj > hwk or (kj == hwk and j > hwi):
                                    if (f & _DIRTY) != 0 or kj <= max_dev2:
                                        d = (bq[_U(lut + kj)] if 0 <= kj < nl2
                                             else _high_bucket(kj, nb2))
                                        if d >= 0:
                                            w = j >> 6
                                            bit = np.int64(1) << (j & 63)
                                            bits[_U(d * nw + w)] |= bit
                                            bq[_U(d)] += 1
                                            bq[_U(nb + d)] = min(bq[_U(nb + d)], w)
                                            dmin = min(dmin, d)
                                            nbk += 1
                                        else:
                                            _push(hk, hi, size, kj, j)
                                            size += 1
                                        f |= _INHEAP
                                else:
                                    f = (f & ((1 << _EPOCH) - 1)) | popped
                            if (f >> _EPOCH) == pas and (f & _CAND) == 0:
                                # popped: a candidate for the next pass
                                cand[_U(nc)] = j
                                nc += 1
                                f |= _CAND
                        fl[_U(j)] = f
            m = 0
            for i in range(n):
                if (fl[_U(i)] & _DELETED) == 0:
                    px[_U(m)] = px[_U(i)]
                    py[_U(m)] = py[_U(i)]
                    pw[_U(m)] = pw[_U(i)]
                    m += 1
            if m < min_size or (m == min_size and _tiny(
                    px[0], py[0], px[1], py[1], px[_U(m - 1)],
                    py[_U(m - 1)])):
                m = 0
        for t in range(m):
            out_coords[pos + t, 0] = px[_U(t)]
            out_coords[pos + t, 1] = py[_U(t)]
        if has_w:
            for t in range(m):
                out_widths[pos + t] = pw[_U(t)]
        pos += m
        out_counts[rr] = m


@kernel(I64_1D_OUT(I64_1D))
def _offsets_of(counts):
    """Ring offsets of rings with these vertex counts."""
    offsets = np.empty(counts.shape[0] + 1, np.int64)
    offsets[0] = 0
    for r in range(counts.shape[0]):
        offsets[r + 1] = offsets[r] + counts[r]
    return offsets


@kernel(
    types.Tuple((I64_2D_OUT, I64_1D_OUT))(I64_2D, I64_1D, B1, I64, I64, I64)
)
def simplify_rings(coords, ring_offsets, closed, max_resolution, max_deviation,
                   max_area_deviation):
    """Simplify every ring (``closed``) or polyline (not ``closed``) like CuraEngine.

    Returns ``(new_coords, new_ring_offsets)`` with one (possibly empty) output
    ring per input ring. ``max_area_deviation`` has no effect without widths.
    Serial: ``vecslice.simplify`` runs :func:`simplify_range` on threads.
    """
    n_rings = ring_offsets.shape[0] - 1
    buf = np.empty((coords.shape[0], 2), np.int64)
    counts = np.empty(n_rings, np.int64)
    simplify_range(coords, np.empty(0, np.int64), ring_offsets, False, closed,
                   max_resolution, max_deviation, max_area_deviation, 0, n_rings,
                   buf, np.empty(0, np.int64), counts)
    offsets = _offsets_of(counts)
    return buf[:offsets[n_rings]].copy(), offsets


@kernel(
    types.Tuple((I64_2D_OUT, I64_1D_OUT, I64_1D_OUT))(
        I64_2D, I64_1D, I64_1D, B1, I64, I64, I64
    )
)
def simplify_rings_w(coords, widths, ring_offsets, closed, max_resolution,
                     max_deviation, max_area_deviation):
    """Variable-width variant of :func:`simplify_rings` (CuraEngine ExtrusionLine).

    ``widths`` (N,) holds each vertex's line width. Returns ``(new_coords,
    new_widths, new_ring_offsets)``; an intersection vertex gets the truncated
    mean width of the removed vertex's two neighbours.
    """
    n_rings = ring_offsets.shape[0] - 1
    buf = np.empty((coords.shape[0], 2), np.int64)
    buf_w = np.empty(coords.shape[0], np.int64)
    counts = np.empty(n_rings, np.int64)
    simplify_range(coords, widths, ring_offsets, True, closed, max_resolution,
                   max_deviation, max_area_deviation, 0, n_rings, buf, buf_w,
                   counts)
    offsets = _offsets_of(counts)
    j = offsets[n_rings]
    return buf[:j].copy(), buf_w[:j].copy(), offsets


@kernel(I64_1D_OUT(I64_2D, I64_1D))
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


@kernel(B1(I64, I64, I64, I64, I64, I64))
def _reverses(lx, ly, cx, cy, nx, ny):
    """CuraEngine's isDegenerate: dot(now-last, next-now) == -|now-last|*|next-now|."""
    ax = cx - lx
    ay = cy - ly
    bx = nx - cx
    by = ny - cy
    return ax * bx + ay * by == -1 * vsize(ax, ay) * vsize(bx, by)


@kernel(types.Tuple((I64_2D_OUT, I64_1D_OUT))(I64_2D, I64_1D))
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
