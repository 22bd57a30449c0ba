"""Kernels matching chain ends greedily, smallest gap first, in O(n log n).

One stitching round (``kernels/stitch.py``) lists every candidate join of two free
chain ends closer than the gap, takes the candidates in increasing key order and
uses one only if both its ends are still free. Using a join frees no end and uses
exactly its two ends (a join makes them inner vertices, a closure uses the group's
only two ends). So the joins made are the *greedy matching* of a graph fixed when
the round starts: nodes are the free ends (*termini*), edges the candidates, each
with a distinct key. This module computes that matching without listing the
edges, which are O(n**2) when n ends crowd within one gap.

Keys. A terminus has a position, a role (0: its group's start, 1: its end) and a
group id ``gid``. Termini ``q != p`` are joinable when their squared distance
``d2 < gap2`` and their roles differ (in order), or, with ``allow_reverse``, are
equal. Seen from ``q``, the stitcher's key ``(d2, reversed, i, j, sub)`` orders
the edges of ``q`` exactly as ``(d2, role(p) == role(q), gid(p))`` does, and no
two partners of ``q`` share that triple (a group has one start and one end). So
every terminus has one best (smallest key) joinable partner.

Algorithm. With distinct keys, the greedy matching is also found by matching
mutual best partners in any order (the "locally dominant" edges of Preis, 1999):
such an edge is the smallest of both its ends among the free termini, so the
greedy order reaches it with both ends free. The *nearest-neighbour chain* finds
them: follow best partners from any free terminus, a -> b -> c ...; keys strictly
decrease along the chain, so it ends in a mutual pair, which is matched and popped,
and the walk goes on from the chain's new top. A terminus without a partner is
left alone for good (partners only disappear). Every terminus is pushed once, so
there are O(n) best-partner queries.

Queries. Termini are grouped by location (equal coordinates), each location
holding its termini per role sorted by gid, with the first free one tracked (a
"next free" union-find skips used ones): among coincident ends only the smallest
free gid of each role can be best. A k-d tree over the locations (leaves of 8,
median splits on the wider axis, built in O(m log m) from two presorted orders)
keeps in every node the count per role, bounding box and smallest gid per role of
its *free* termini, updated on every match. A query scans its own leaf, then the
siblings of its ancestors, nearer-bound child first, skipping a subtree whose
bound ``(box d2, reversed, smallest gid)`` is not below the best key so far.
It costs O(log m) for scattered, crowded or coincident ends; its one slow case is
many locations at exactly the same distance from the query (lattice points of one
circle: a few hundred at most within 10 mm). Memory is O(n); all sorts are merge
sorts (no quadratic worst case).
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
# A location's termini are the sorted rows F0:E1, role 0 in F0:E0 (F0 = start
# and F1 = E0 until some are used), role 1 in E0:E1.
_SX, _SY, _F, _E = 0, 1, 2, 4
# columns of the node table: its locations lo:hi; about its free termini, counts
# per role (_CNT + role), the box of their locations, smallest gid per role
_LO, _HI, _CNT, _X0, _X1, _Y0, _Y1, _MG = 0, 1, 2, 4, 5, 6, 7, 8
_N_NODE = 10
_I64_MAX = 9223372036854775807

_I64_1D_W = types.int64[::1]
_BUILT = types.Tuple(
    (types.int64[:, ::1], types.int64[:, ::1], _I64_1D_W, _I64_1D_W, _I64_1D_W,
     _I64_1D_W)
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
    """Smallest-gid free terminus of role ``r`` at location ``s``, or -1.

    Terminus ``skip`` (a sorted index) is passed over.
    """
    i = slots[s, _F + r]
    if i == skip:
        i = _find(nxt, i + 1)
    return i if i < slots[s, _E + r] else -1


@kernel(inline="always")
def _combine(node, k, slots, sg, role):
    """Recompute node ``k``'s box and role's smallest gid; True if they changed.

    A leaf reads its locations, an inner node its children. Counts are kept up
    to date by the caller.
    """
    x0 = _I64_MAX
    x1 = -_I64_MAX
    y0 = _I64_MAX
    y1 = -_I64_MAX
    mg = _I64_MAX
    lo, hi = node[k, _LO], node[k, _HI]
    if hi - lo <= _LEAF:
        for s in range(lo, hi):
            f0 = slots[s, _F] < slots[s, _E]
            if f0 or slots[s, _F + 1] < slots[s, _E + 1]:
                x0 = min(x0, slots[s, _SX])
                x1 = max(x1, slots[s, _SX])
                y0 = min(y0, slots[s, _SY])
                y1 = max(y1, slots[s, _SY])
                if slots[s, _F + role] < slots[s, _E + role]:
                    mg = min(mg, sg[slots[s, _F + role]])
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

    Returns ``(node, slots, leaf, order, sg, sloc)``: the node table; the location
    table in tree order; the leaf node of each location; ``order``, the termini
    sorted by (location in tree order, role, gid); ``sg`` and ``sloc``, the gid and
    location of each sorted terminus. The root covers all ``m`` locations; an
    inner node ``k`` covering ``lo:hi`` splits at ``(lo + hi) // 2`` into children
    ``2k + 1`` (the lower half along its wider axis) and ``2k + 2``. Built from
    the orders by x and by y, each split partitioning the other order stably;
    all sorts are merge sorts: O(n log n).
    """
    n = xy.shape[0]
    # termini by (x, y, role, gid): stable sorts, least significant key first
    key = np.empty(n, dtype=np.int64)
    for i in range(n):
        key[i] = ((1 if role[i] != 0 else 0) << 62) | gid[i]
    o = np.argsort(key, kind="mergesort")
    for i in range(n):
        key[i] = ((xy[o[i], 0] + _OFF) << 31) | (xy[o[i], 1] + _OFF)
    p = np.argsort(key, kind="mergesort")
    o = o[p]
    key = key[p]
    # distinct locations, by x then y
    first = np.empty(n + 1, dtype=np.int64)
    m = 0
    for i in range(n):
        if i == 0 or key[i] != key[i - 1]:
            first[m] = i
            m += 1
    first[m] = n
    lx = np.empty(m, dtype=np.int64)
    ly = np.empty(m, dtype=np.int64)
    for j in range(m):
        lx[j] = xy[o[first[j]], 0]
        ly[j] = xy[o[first[j]], 1]
    # the tree over locations
    n_nodes = 2 << _depth(m)
    node = np.full((n_nodes, _N_NODE), -1, dtype=np.int64)
    node[0, _LO] = 0
    node[0, _HI] = m
    px = np.arange(m)
    py = np.argsort(ly, kind="mergesort")
    upper = np.zeros(m, dtype=np.bool_)
    tmp = np.empty(m, dtype=np.int64)
    leaf = np.empty(m, dtype=np.int64)
    for k in range(n_nodes):
        lo, hi = node[k, _LO], node[k, _HI]
        if lo < 0:
            continue
        if hi - lo <= _LEAF:
            leaf[lo:hi] = k
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
        node[2 * k + 1, _LO] = lo
        node[2 * k + 1, _HI] = mid
        node[2 * k + 2, _LO] = mid
        node[2 * k + 2, _HI] = hi
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
    for k in range(n_nodes - 1, -1, -1):
        lo, hi = node[k, _LO], node[k, _HI]
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
            _combine(node, k, slots, sg, r)
    return node, slots, leaf, order, sg, sloc


@kernel(inline="always")
def _remove(node, slots, leaf, nxt, sg, i, s, r):
    """Mark sorted terminus ``i`` (role ``r``, at location ``s``) used.

    Updates the counts above it, then boxes and smallest gids while they change
    (not at all if its location keeps a free terminus and ``i`` was not its
    leaf's smallest gid).
    """
    nxt[i] = i + 1
    if slots[s, _F + r] == i:
        slots[s, _F + r] = _find(nxt, i + 1)
    k = leaf[s]
    while True:
        node[k, _CNT + r] -= 1
        if k == 0:
            break
        k = (k - 1) // 2
    k = leaf[s]
    if (
        slots[s, _F] < slots[s, _E] or slots[s, _F + 1] < slots[s, _E + 1]
    ) and sg[i] != node[k, _MG + r]:
        return
    while _combine(node, k, slots, sg, r) and k > 0:
        k = (k - 1) // 2


@kernel(inline="always")
def _bound(node, k, x, y, r, allow_reverse):
    """Lower bound ``(d2, reversed, gid)`` of node ``k``'s keys as partners.

    For a role ``r`` terminus at (x, y); the bound is above every key if the
    node has no partner for it.
    """
    if node[k, _CNT + 1 - r] > 0:
        rev = 0
    elif allow_reverse and node[k, _CNT + r] > 0:
        rev = 1
    else:
        return _I64_MAX, 2, 0
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
    return dx * dx + dy * dy, rev, node[k, _MG + (r if rev else 1 - r)]


@kernel(inline="always")
def _below(d2, rev, g, bd2, brev, bgid):
    """Whether key ``(d2, rev, g)`` is smaller than ``(bd2, brev, bgid)``."""
    if d2 != bd2:
        return d2 < bd2
    if rev != brev:
        return rev < brev
    return g < bgid


@kernel(inline="always")
def _scan(node, slots, nxt, sg, k, x, y, r, q, allow_reverse, bd2, brev, bgid, best):
    """The best key among leaf ``k``'s candidates and ``(bd2, brev, bgid, best)``.

    A location's candidates are its smallest-gid free terminus of each allowed
    role, other than ``q``.
    """
    for s in range(node[k, _LO], node[k, _HI]):
        dx = slots[s, _SX] - x
        dy = slots[s, _SY] - y
        d2 = dx * dx + dy * dy
        if d2 > bd2:
            continue
        for rev in range(2 if allow_reverse else 1):
            i = _first(nxt, slots, s, r if rev == 1 else 1 - r, q)
            if i >= 0 and _below(d2, rev, sg[i], bd2, brev, bgid):
                bd2, brev, bgid, best = d2, rev, sg[i], i
    return bd2, brev, bgid, best


@kernel(inline="always")
def _best_partner(node, slots, leaf, nxt, sg, stack, q, s, r, gap2, allow_reverse):
    """Best (smallest key) free partner of ``q``, or -1 (sorted indices).

    ``q`` has role ``r`` and location ``s``. Starts with the leaf of ``q``, then
    searches the sibling subtrees of its ancestors, each depth first, the child
    with the smaller lower bound ``(box d2, reversed, smallest gid)`` first; a
    subtree is skipped when its bound is not below the best key so far (at
    first ``(gap2, 0, -1)``, which every key with ``d2 < gap2`` is below).
    """
    x, y = slots[s, _SX], slots[s, _SY]
    k = leaf[s]
    bd2, brev, bgid, best = _scan(
        node, slots, nxt, sg, k, x, y, r, q, allow_reverse, gap2, 0, -1, -1
    )
    while k > 0:
        sib = k + 1 if k % 2 == 1 else k - 1
        k = (k - 1) // 2
        stack[0, 0] = sib
        stack[0, 1], stack[0, 2], stack[0, 3] = _bound(node, sib, x, y, r,
                                                       allow_reverse)
        sp = 1
        while sp > 0:
            sp -= 1
            if not _below(stack[sp, 1], stack[sp, 2], stack[sp, 3], bd2, brev, bgid):
                continue
            c = stack[sp, 0]
            if node[c, _HI] - node[c, _LO] <= _LEAF:
                bd2, brev, bgid, best = _scan(node, slots, nxt, sg, c, x, y, r, q,
                                              allow_reverse, bd2, brev, bgid, best)
                continue
            l2, lrev, lgid = _bound(node, 2 * c + 1, x, y, r, allow_reverse)
            r2, rrev, rgid = _bound(node, 2 * c + 2, x, y, r, allow_reverse)
            # push the child with the larger bound first: the other goes first
            left_first = _below(l2, lrev, lgid, r2, rrev, rgid)
            for j in range(2):
                left = left_first == (j == 1)
                stack[sp, 0] = 2 * c + 1 if left else 2 * c + 2
                stack[sp, 1] = l2 if left else r2
                stack[sp, 2] = lrev if left else rrev
                stack[sp, 3] = lgid if left else rgid
                sp += 1
    return best


@kernel(I64_2D_OUT(I64_2D, I64_1D, I64_1D, I64, B1))
def match_ends(xy, gid, role, gap2, allow_reverse):
    """Greedy matching of termini, smallest key first; pairs ``(n_pairs, 2)``.

    Terminus ``t`` is at ``xy[t]`` (|coords| < 2**30), has group id ``0 <=
    gid[t] < 2**62`` and role ``role[t]`` (0: its group's start, 1: its end; a
    group has at most one of each). ``q`` and ``p`` are joinable when
    ``d2 < gap2`` and their roles differ or (``allow_reverse``) are equal. Edges
    are taken in increasing ``(d2, reversed, i, j, sub)`` as in
    :func:`stitch_chains`, i.e. per terminus in increasing ``(d2, role(p) ==
    role(q), gid(p))``; an edge is used if both its termini are still free.
    Returns the used pairs (terminus indices), in the order found.
    """
    n = xy.shape[0]
    node, slots, leaf, order, sg, sloc = _build(xy, gid, role)
    nxt = np.arange(n + 1)  # sorted terminus i is free iff nxt[i] == i
    srole = np.empty(n, dtype=np.int64)
    for i in range(n):
        srole[i] = 1 if role[order[i]] != 0 else 0
    alone = np.zeros(n, dtype=np.bool_)
    stack = np.empty((_depth(slots.shape[0]) + 2, 4), dtype=np.int64)
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
            p = _best_partner(node, slots, leaf, nxt, sg, stack, c, sloc[c],
                              srole[c], gap2, allow_reverse)
            if p < 0:
                # no partner now, so never, and no terminus has it as its best
                # partner: it can stay in the tree. Only a chain's first is alone
                # (the one below would be a partner).
                if top > 1:
                    raise RuntimeError("match_ends: a best partner has no partner")
                alone[c] = True
                top -= 1
            elif top >= 2 and chain[top - 2] == p:  # mutual best: matched
                pairs[n_pairs, 0] = order[p]
                pairs[n_pairs, 1] = order[c]
                n_pairs += 1
                top -= 2
                _remove(node, slots, leaf, nxt, sg, p, sloc[p], srole[p])
                _remove(node, slots, leaf, nxt, sg, c, sloc[c], srole[c])
            else:
                chain[top] = p
                top += 1
    return pairs[:n_pairs].copy()
