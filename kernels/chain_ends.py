"""Kernels matching chain ends greedily, smallest gap first, in O(n log n).

One stitching round (``kernels/stitch.py``) lists every candidate join of two free
chain ends closer than the gap, takes the candidates in increasing key order and
uses one only if both its ends are still free. Using a join frees no end and uses
exactly its two ends (a join makes them inner vertices, a closure uses the group's
only two ends). So the joins made are the *greedy matching* of a graph fixed when
the round starts: nodes are the free ends (*termini*), edges the candidates, each
with a unique key. This module computes that matching without listing the edges,
which may be O(n**2) when many ends crowd within one gap.

Keys. A terminus has a position, a role (0: its group's start, 1: its end) and the
group id ``gid``. Termini ``q != p`` are joinable when their squared distance
``d2 < gap2`` and their roles differ (in order), or, with ``allow_reverse``, are
equal (the two termini of one group have different roles). Seen from ``q``, the
stitcher's key ``(d2, reversed, i, j, sub)`` orders the edges of ``q`` exactly as
``(d2, role(p) == role(q), gid(p))`` does, and no two termini of ``q``'s edges share
that triple. So every terminus has one best (smallest key) joinable partner.

Algorithm. The greedy matching of a graph with unique edge keys is also found by
matching mutual best partners in any order (Preis 1999, "locally dominant" edges):
such a pair is the best edge of both its ends among the free ones, so no smaller
edge can take either end first. The *nearest-neighbour chain* finds them: follow
best partners from any free terminus, a -> b -> c ...; keys strictly decrease along
the chain, so it ends in a mutual pair, which is matched and popped, and the walk
goes on from the chain's new top (whose best partner is then recomputed). Every
terminus is pushed once, so there are O(n) best-partner queries.

Queries use two k-d trees (one per role; bucket leaves, median splits on the wider
axis, built in O(n log n) from two presorted orders) that delete matched termini:
every node keeps the count, bounding box and smallest gid of its *free* termini,
and a subtree is skipped when its ``(box distance², reversed, smallest gid)``
cannot beat the best so far. A query costs O(log n) for scattered or crowded ends;
coincident ends are resolved by the smallest-gid bound. Its only slow case is many
ends at exactly the same distance from the query (lattice points of one circle,
a few hundred at most within 10 mm), which costs their number. Memory is O(n).
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, I64, I64_1D, I64_2D, I64_2D_OUT

__all__ = ["match_ends"]

_LEAF = 8  # a node with at most this many locations is a leaf
_OFF = 2**30  # coordinate + offset in [1, 2**31) for |coords| < 2**30
# columns of the location table (in tree order): position; per role, the first
# free sorted terminus (_F + role) and the end of the role's termini (_E + role).
# A location's termini are sorted rows _F:_E + 1 at first, role 0 then role 1.
_SX, _SY, _F, _E = 0, 1, 2, 4
# columns of the node table, all about free termini: counts per role, the box of
# their locations, smallest gid per role
_CNT, _X0, _X1, _Y0, _Y1, _MG = 0, 2, 3, 4, 5, 6  # _CNT + role, _MG + role
_N_NODE = 8
_I64_MAX = 9223372036854775807

_I64_1D_W = types.int64[::1]
_BUILT = types.Tuple(
    (types.int64[:, ::1], types.int64[:, ::1], _I64_1D_W, _I64_1D_W, _I64_1D_W)
)


@kernel(I64(I64))
def _depth(n):
    """Depth of the deepest leaf of a tree over ``n`` locations."""
    d = 0
    s = n
    while s > _LEAF:
        s = (s + 1) // 2
        d += 1
    return d


@kernel(inline="always")
def _find(nxt, i):
    """First free sorted terminus at or after ``i`` (``n`` if none); path halving."""
    while nxt[i] != i:
        nxt[i] = nxt[nxt[i]]
        i = nxt[i]
    return i


@kernel(inline="always")
def _first(nxt, slots, s, r, skip):
    """Smallest-gid free terminus of role ``r`` at location ``s`` other than
    ``skip`` (a sorted index), or -1.
    """
    i = slots[s, _F + r]
    if i == skip:
        i = _find(nxt, i + 1)
    return i if i < slots[s, _E + r] else -1


@kernel(inline="always")
def _combine(node, k, lo, hi, slots, nxt, sg, role):
    """Recompute node ``k``'s box and role's smallest gid; True if they changed.

    A leaf reads its locations ``lo:hi``, an inner node its children. Counts are
    kept up to date by the caller.
    """
    x0 = _I64_MAX
    x1 = -_I64_MAX
    y0 = _I64_MAX
    y1 = -_I64_MAX
    mg = _I64_MAX
    if hi - lo <= _LEAF:
        for s in range(lo, hi):
            i0 = _first(nxt, slots, s, 0, -1)
            i1 = _first(nxt, slots, s, 1, -1)
            if i0 >= 0 or i1 >= 0:
                x0 = min(x0, slots[s, _SX])
                x1 = max(x1, slots[s, _SX])
                y0 = min(y0, slots[s, _SY])
                y1 = max(y1, slots[s, _SY])
                i = i0 if role == 0 else i1
                if i >= 0:
                    mg = min(mg, sg[i])
    else:
        for c in range(2 * k + 1, 2 * k + 3):
            if node[c, _CNT] + node[c, _CNT + 1] > 0:
                x0 = min(x0, node[c, _X0])
                x1 = max(x1, node[c, _X1])
                y0 = min(y0, node[c, _Y0])
                y1 = max(y1, node[c, _Y1])
                mg = min(mg, node[c, _MG + role])
    changed = (
        x0 != node[k, _X0]
        or x1 != node[k, _X1]
        or y0 != node[k, _Y0]
        or y1 != node[k, _Y1]
        or mg != node[k, _MG + role]
    )
    node[k, _X0] = x0
    node[k, _X1] = x1
    node[k, _Y0] = y0
    node[k, _Y1] = y1
    node[k, _MG + role] = mg
    return changed


@kernel(_BUILT(I64_2D, I64_1D, I64_1D))
def _build(xy, gid, role):
    """Sorted termini and a k-d tree over their distinct locations.

    Returns ``(node, slots, order, sg, sloc)``: the node table; the location table
    in tree order; ``order``, the termini sorted by (location in tree order, role,
    gid); ``sg`` and ``sloc``, the gid and location of each sorted terminus. Node
    ``k`` covers locations ``lo:hi`` (the root ``0:m``); an inner node splits at
    ``mid = (lo + hi) // 2`` into children ``2k + 1`` (the lower half along its
    wider axis) and ``2k + 2``. Built from the orders by x and by y, each split
    partitioning the other order stably; all sorts are merge sorts: O(n log n).
    """
    n = xy.shape[0]
    # termini by (x, y, role, gid): stable sorts, least significant key first
    o = np.argsort(gid, kind="mergesort")
    o = o[np.argsort(role[o], kind="mergesort")]
    key = np.empty(n, dtype=np.int64)
    for i in range(n):
        key[i] = ((xy[o[i], 0] + _OFF) << 31) | (xy[o[i], 1] + _OFF)
    p = np.argsort(key, kind="mergesort")
    o = o[p]
    key = key[p]
    # distinct locations, by x then y
    m = 0
    for i in range(n):
        if i == 0 or key[i] != key[i - 1]:
            m += 1
    first = np.empty(m + 1, dtype=np.int64)
    j = 0
    for i in range(n):
        if i == 0 or key[i] != key[i - 1]:
            first[j] = i
            j += 1
    first[m] = n
    lx = np.empty(m, dtype=np.int64)
    ly = np.empty(m, dtype=np.int64)
    for j in range(m):
        lx[j] = xy[o[first[j]], 0]
        ly[j] = xy[o[first[j]], 1]
    # the tree over locations
    n_nodes = 2 << _depth(m)
    lo_ = np.full(n_nodes, -1, dtype=np.int64)
    hi_ = np.full(n_nodes, -1, dtype=np.int64)
    lo_[0] = 0
    hi_[0] = m
    px = np.arange(m)
    py = np.argsort(ly, kind="mergesort")
    upper = np.zeros(m, dtype=np.bool_)
    tmp = np.empty(m, dtype=np.int64)
    for k in range(n_nodes):
        lo, hi = lo_[k], hi_[k]
        if lo < 0 or hi - lo <= _LEAF:
            continue
        mid = (lo + hi) // 2
        wide_x = lx[px[hi - 1]] - lx[px[lo]] >= ly[py[hi - 1]] - ly[py[lo]]
        a, b = (px, py) if wide_x else (py, px)
        for i in range(lo, hi):
            upper[a[i]] = i >= mid
        w = lo  # stable partition of the other order: both halves stay sorted
        for half in (False, True):
            for i in range(lo, hi):
                if upper[b[i]] == half:
                    tmp[w] = b[i]
                    w += 1
        b[lo:hi] = tmp[lo:hi]
        lo_[2 * k + 1] = lo
        hi_[2 * k + 1] = mid
        lo_[2 * k + 2] = mid
        hi_[2 * k + 2] = hi
    # locations in tree order, their termini contiguous
    order = np.empty(n, dtype=np.int64)
    sg = np.empty(n, dtype=np.int64)
    sloc = np.empty(n, dtype=np.int64)
    slots = np.empty((m, 6), dtype=np.int64)
    w = 0
    for s in range(m):
        j = px[s]
        slots[s, _SX] = lx[j]
        slots[s, _SY] = ly[j]
        slots[s, _F] = w
        slots[s, _E] = w
        for i in range(first[j], first[j + 1]):
            t = o[i]
            order[w] = t
            sg[w] = gid[t]
            sloc[w] = s
            if role[t] == 0:
                slots[s, _E] = w + 1
            w += 1
        slots[s, _F + 1] = slots[s, _E]
        slots[s, _E + 1] = w
    nxt = np.arange(n + 1)
    node = np.full((n_nodes, _N_NODE), -1, dtype=np.int64)
    for k in range(n_nodes - 1, -1, -1):
        lo, hi = lo_[k], hi_[k]
        if lo < 0:
            continue
        for r in range(2):
            if hi - lo <= _LEAF:
                c = 0
                for s in range(lo, hi):
                    c += slots[s, _E + r] - slots[s, _F + r]
            else:
                c = node[2 * k + 1, _CNT + r] + node[2 * k + 2, _CNT + r]
            node[k, _CNT + r] = c
            _combine(node, k, lo, hi, slots, nxt, sg, r)
    return node, slots, order, sg, sloc


@kernel(inline="always")
def _remove(node, slots, nxt, sg, path, i, s, r):
    """Mark sorted terminus ``i`` (role ``r``, location ``s``) used; update the
    counts on its path and the boxes and smallest gids while they change.
    """
    nxt[i] = i + 1
    if slots[s, _F + r] == i:
        slots[s, _F + r] = _find(nxt, i + 1)
    k, lo, hi = 0, 0, slots.shape[0]
    d = 0
    while True:
        node[k, _CNT + r] -= 1
        path[d] = k
        d += 1
        if hi - lo <= _LEAF:
            break
        mid = (lo + hi) // 2
        if s < mid:
            k, hi = 2 * k + 1, mid
        else:
            k, lo = 2 * k + 2, mid
    if _combine(node, k, lo, hi, slots, nxt, sg, r):
        for j in range(d - 2, -1, -1):
            if not _combine(node, path[j], 0, slots.shape[0], slots, nxt, sg, r):
                break


@kernel(inline="always")
def _box_d2(node, k, x, y):
    """Squared distance from (x, y) to node ``k``'s box of free termini."""
    dx = 0
    if x < node[k, _X0]:
        dx = node[k, _X0] - x
    elif x > node[k, _X1]:
        dx = x - node[k, _X1]
    dy = 0
    if y < node[k, _Y0]:
        dy = node[k, _Y0] - y
    elif y > node[k, _Y1]:
        dy = y - node[k, _Y1]
    return dx * dx + dy * dy


@kernel(inline="always")
def _below(d2, rev, g, bd2, brev, bgid):
    """Whether key ``(d2, rev, g)`` is smaller than ``(bd2, brev, bgid)``."""
    if d2 != bd2:
        return d2 < bd2
    if rev != brev:
        return rev < brev
    return g < bgid


@kernel(inline="always")
def _bound(node, k, x, y, r, allow_reverse):
    """Lower bound ``(d2, reversed, gid)`` of the keys of node ``k``'s termini as
    partners of a role ``r`` terminus at (x, y); above every key if it has none.
    """
    if node[k, _CNT + 1 - r] > 0:
        return _box_d2(node, k, x, y), 0, node[k, _MG + 1 - r]
    if allow_reverse and node[k, _CNT + r] > 0:
        return _box_d2(node, k, x, y), 1, node[k, _MG + r]
    return _I64_MAX, 2, 0


@kernel(inline="always")
def _best_partner(node, slots, nxt, sg, stack, x, y, r, q, gap2, allow_reverse):
    """Sorted index of the best free partner of sorted terminus ``q`` (role ``r``
    at (x, y)): the smallest key; -1 if none.

    Depth first, the child with the smaller lower bound ``(box d2, reversed,
    smallest gid)`` first; a subtree is skipped when its bound is not below the
    best key so far (at first ``(gap2, 0, -1)``, which every key with
    ``d2 < gap2`` is below). At a location, the candidates are its smallest-gid
    free terminus of each role (other than ``q``).
    """
    bd2, brev, bgid, best = gap2, 0, -1, -1
    stack[0, 0] = 0
    stack[0, 1] = 0
    stack[0, 2] = slots.shape[0]
    stack[0, 3], stack[0, 4], stack[0, 5] = _bound(node, 0, x, y, r, allow_reverse)
    sp = 1
    while sp > 0:
        sp -= 1
        if not _below(stack[sp, 3], stack[sp, 4], stack[sp, 5], bd2, brev, bgid):
            continue
        k, lo, hi = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        if hi - lo <= _LEAF:
            for s in range(lo, hi):
                dx = slots[s, _SX] - x
                dy = slots[s, _SY] - y
                d2 = dx * dx + dy * dy
                if d2 > bd2:
                    continue
                for rev in range(2 if allow_reverse else 1):
                    i = _first(nxt, slots, s, r if rev == 1 else 1 - r, q)
                    if i >= 0 and _below(d2, rev, sg[i], bd2, brev, bgid):
                        bd2, brev, bgid, best = d2, rev, sg[i], i
            continue
        mid = (lo + hi) // 2
        l2, lrev, lgid = _bound(node, 2 * k + 1, x, y, r, allow_reverse)
        r2, rrev, rgid = _bound(node, 2 * k + 2, x, y, r, allow_reverse)
        # push the child with the larger bound first: the other is searched first
        left_first = _below(l2, lrev, lgid, r2, rrev, rgid)
        for j in range(2):
            left = left_first == (j == 1)
            stack[sp, 0] = 2 * k + 1 if left else 2 * k + 2
            stack[sp, 1] = lo if left else mid
            stack[sp, 2] = mid if left else hi
            stack[sp, 3] = l2 if left else r2
            stack[sp, 4] = lrev if left else rrev
            stack[sp, 5] = lgid if left else rgid
            sp += 1
    return best


@kernel(I64_2D_OUT(I64_2D, I64_1D, I64_1D, I64, B1))
def match_ends(xy, gid, role, gap2, allow_reverse):
    """Greedy matching of termini, smallest key first; pairs ``(n_pairs, 2)``.

    Terminus ``t`` is at ``xy[t]`` (|coords| < 2**30), has group id ``gid[t] >=
    0`` and role ``role[t]`` (0: its group's start, 1: its end; a group has at most
    one of each). ``q`` and ``p`` are joinable when ``d2 < gap2`` and their roles
    differ or (``allow_reverse``) are equal. Edges are taken in increasing
    ``(d2, reversed, i, j, sub)`` as in :func:`stitch_chains`, i.e. per terminus in
    increasing ``(d2, role(p) == role(q), gid(p))``; an edge is used if both its
    termini are still free. Returns the used pairs, in the order found.
    """
    n = xy.shape[0]
    node, slots, order, sg, sloc = _build(xy, gid, role)
    nxt = np.arange(n + 1)  # sorted terminus i is free iff nxt[i] == i
    srole = np.empty(n, dtype=np.int64)
    for i in range(n):
        srole[i] = 1 if role[order[i]] != 0 else 0
    alone = np.zeros(n, dtype=np.bool_)
    depth = _depth(slots.shape[0])
    stack = np.empty((depth + 2, 6), dtype=np.int64)
    path = np.empty(depth + 1, dtype=np.int64)
    chain = np.empty(n, dtype=np.int64)
    pairs = np.empty((n // 2, 2), dtype=np.int64)
    n_pairs = 0
    for first in range(n):
        if nxt[first] != first or alone[first]:
            continue
        chain[0] = first
        top = 1
        while top > 0:
            c = chain[top - 1]
            s = sloc[c]
            p = _best_partner(node, slots, nxt, sg, stack, slots[s, _SX],
                              slots[s, _SY], srole[c], c, gap2, allow_reverse)
            if p < 0:
                # no partner now, so never, and no terminus has it as its best
                # partner: it can stay in the tree. Only a chain's first is alone.
                alone[c] = True
                top -= 1
            elif top >= 2 and chain[top - 2] == p:  # mutual best: matched
                pairs[n_pairs, 0] = order[p]
                pairs[n_pairs, 1] = order[c]
                n_pairs += 1
                top -= 2
                _remove(node, slots, nxt, sg, path, p, sloc[p], srole[p])
                _remove(node, slots, nxt, sg, path, c, sloc[c], srole[c])
            else:
                chain[top] = p
                top += 1
    return pairs[:n_pairs].copy()
