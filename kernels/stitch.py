"""Kernels stitching open chains into longer chains and closed loops.

CuraEngine's ``Slicer::makePolygons`` in spirit: per layer, two rounds, always the
smallest gap first. Round 1 joins a chain's end to a chain's start (possibly its
own) across gaps ``< max_gap_in_order``; round 2 joins across gaps ``< max_gap_any``
and may also join end to end or start to start by reversing the shorter chain.

Data structure. Every input chain is a node of a doubly linked list (``next``,
``prev``, ``flip`` = traversed backwards); a *group* is a joined chain, found by
union-find, whose root holds its head chain, tail chain, vertex count, id (the
smallest input chain index in it) and whether it is closed. Joining links the tail
of one list to the head of the other in O(1); reversing a group walks its chains.
Only the shorter group is ever reversed, so each chain is reversed O(log V) times.

A round's rule (take the candidates by increasing key, use one if both its ends
are still free) is the greedy matching of the round's free chain ends, computed by
:func:`.chain_ends.match_ends` without listing the candidates: O(n log n) for
the ``n`` free ends of a layer, crowded or coincident ones included (a k-d tree
of their locations with deletions, and a nearest-neighbour chain), O(n) memory.
The matched pairs are then sorted by the same key and applied in that order, so
the result is the one of listing every candidate pair and sorting them (that
kernel is kept in the tests as the reference), ties included: the keys are
distinct. Measured (one core, CPU time, shared machine): a 20,000-triangle soup
in a 10 mm cube (100,000 two-vertex chains, up to 1,100 per layer) stitches in
about 0.5 s; the full candidate list took minutes.
"""

import numpy as np
from numba import types

from ._jit import kernel
from ._types import B1, I64, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .chain_ends import match_ends

# columns of the per-chain state table (group fields are valid on roots only)
_PARENT = 0  # union-find parent
_HEAD = 1  # root: first chain of the group
_TAIL = 2  # root: last chain of the group
_NV = 3  # root: vertices of the joined chain (identical joint vertices kept once)
_GID = 4  # root: smallest input chain index in the group
_CLOSED = 5  # root: 1 once the group closed into a loop
_NXT = 6  # next chain in the group, -1 at the tail
_PRV = 7  # previous chain in the group, -1 at the head
_FLIP = 8  # 1 if the chain is traversed from its last vertex to its first
_N_STATE = 9

# columns of the terminus table of one layer and round
_T_CHAIN, _T_SIDE, _T_X, _T_Y, _T_GID, _T_TAIL = 0, 1, 2, 3, 4, 5
# columns of the candidate table: sort key (gap², reversed, i, j, sub), termini
_C_D2, _C_REV, _C_I, _C_J, _C_SUB, _C_A, _C_B = 0, 1, 2, 3, 4, 5, 6

_I64_MAX = 9223372036854775807
_SQRT_I64_MAX = 3037000499  # largest g with g * g <= 2**63 - 1

_STATE = types.int64[:, ::1]
_OUT = types.Tuple(
    (I64_2D_OUT, I64_1D_OUT, I64_1D_OUT, I64_2D_OUT, I64_1D_OUT, I64_1D_OUT,
     I64_1D_OUT)
)


@kernel(I64(_STATE, I64))
def _find(st, c):
    """Root of chain ``c``'s group, compressing the path."""
    r = c
    while st[r, _PARENT] != r:
        r = st[r, _PARENT]
    while st[c, _PARENT] != r:
        n = st[c, _PARENT]
        st[c, _PARENT] = r
        c = n
    return r


@kernel(I64(I64_1D, I64, I64))
def _vertex(ring_offsets, c, side):
    """Row in ``coords`` of chain ``c``'s first (side 0) or last (side 1) vertex."""
    return ring_offsets[c] if side == 0 else ring_offsets[c + 1] - 1


@kernel(I64(_STATE, I64))
def _head_side(st, g):
    """Side of the head chain exposed at the start of group ``g``."""
    return st[st[g, _HEAD], _FLIP]


@kernel(I64(_STATE, I64))
def _tail_side(st, g):
    """Side of the tail chain exposed at the end of group ``g``."""
    return 1 - st[st[g, _TAIL], _FLIP]


@kernel(I64(I64_1D, _STATE, I64, I64))
def _terminus_role(ring_offsets, st, c, side):
    """Role of chain end (c, side): its group's start (0), end (1) or neither (-1).

    Neither: the end is inside a joined chain, the group is closed or the chain is
    empty.
    """
    if ring_offsets[c + 1] == ring_offsets[c]:
        return -1
    g = _find(st, c)
    if st[g, _CLOSED] != 0:
        return -1
    if st[g, _TAIL] == c and _tail_side(st, g) == side:
        return 1
    if st[g, _HEAD] == c and _head_side(st, g) == side:
        return 0
    return -1


@kernel(types.void(_STATE, I64))
def _reverse(st, g):
    """Reverse group ``g`` in place (walks its chains)."""
    c = st[g, _HEAD]
    while c >= 0:
        n = st[c, _NXT]
        st[c, _NXT] = st[c, _PRV]
        st[c, _PRV] = n
        st[c, _FLIP] = 1 - st[c, _FLIP]
        c = n
    h = st[g, _HEAD]
    st[g, _HEAD] = st[g, _TAIL]
    st[g, _TAIL] = h


@kernel(types.void(I64_2D, I64_1D, _STATE, I64, I64))
def _join(coords, ring_offsets, st, g1, g2):
    """Append group ``g2`` to group ``g1`` (distinct open roots)."""
    t1 = st[g1, _TAIL]
    h2 = st[g2, _HEAD]
    a = _vertex(ring_offsets, t1, _tail_side(st, g1))
    b = _vertex(ring_offsets, h2, _head_side(st, g2))
    same = coords[a, 0] == coords[b, 0] and coords[a, 1] == coords[b, 1]
    st[t1, _NXT] = h2
    st[h2, _PRV] = t1
    head = st[g1, _HEAD]
    tail = st[g2, _TAIL]
    nv = st[g1, _NV] + st[g2, _NV] - (1 if same else 0)
    gid = min(st[g1, _GID], st[g2, _GID])
    r, other = (g1, g2) if st[g1, _NV] >= st[g2, _NV] else (g2, g1)
    st[other, _PARENT] = r
    st[r, _HEAD] = head
    st[r, _TAIL] = tail
    st[r, _NV] = nv
    st[r, _GID] = gid


@kernel(I64(I64))
def _bit_length(v):
    """Bits needed for ``0 <= x <= v`` (v >= 0)."""
    b = 0
    while v > 0:
        v >>= 1
        b += 1
    return b


@kernel(I64_1D_OUT(I64_2D_OUT, I64, I64))
def _candidate_order(cand, gap2, id0):
    """Order of the candidates by (gap², reversed, i, j, sub), all ascending.

    Ids are ``>= id0``. The key is packed into one int64 when it fits (gap² < 2**27
    and 2**16 chains per layer, say), else sorted column by column (stable).
    """
    m = cand.shape[0]
    id_max = 0
    for k in range(m):
        id_max = max(id_max, cand[k, _C_I] - id0, cand[k, _C_J] - id0)
    b_id = _bit_length(id_max)
    if _bit_length(gap2 - 1) + 2 * b_id + 2 <= 62:
        key = np.empty(m, dtype=np.int64)
        for k in range(m):
            v = (cand[k, _C_D2] << 1) | cand[k, _C_REV]
            v = (v << b_id) | (cand[k, _C_I] - id0)
            v = (v << b_id) | (cand[k, _C_J] - id0)
            key[k] = (v << 1) | cand[k, _C_SUB]
        # keys are unique: any sort gives the same order; merge sort is O(m log m)
        return np.argsort(key, kind="mergesort")
    order = np.argsort(np.ascontiguousarray(cand[:, _C_SUB]), kind="mergesort")
    for col in (_C_J, _C_I, _C_REV, _C_D2):
        key = np.empty(m, dtype=np.int64)
        for k in range(m):
            key[k] = cand[order[k], col]
        order = order[np.argsort(key, kind="mergesort")]
    return order


@kernel(I64(I64_2D, I64_1D, _STATE, I64, I64, I64, B1))
def _stitch_round(coords, ring_offsets, st, c0, c1, max_gap, allow_reverse):
    """One round over chains ``c0:c1`` (one layer); returns the gaps stitched."""
    if max_gap <= 0:
        return 0
    n_term = 0
    for c in range(c0, c1):
        for side in range(2):
            if _terminus_role(ring_offsets, st, c, side) >= 0:
                n_term += 1
    if n_term == 0:
        return 0
    gap2 = max_gap * max_gap if max_gap <= _SQRT_I64_MAX else _I64_MAX
    term = np.empty((n_term, 6), dtype=np.int64)
    i = 0
    for c in range(c0, c1):
        for side in range(2):
            role = _terminus_role(ring_offsets, st, c, side)
            if role < 0:
                continue
            v = _vertex(ring_offsets, c, side)
            term[i, _T_CHAIN] = c
            term[i, _T_SIDE] = side
            term[i, _T_X] = coords[v, 0]
            term[i, _T_Y] = coords[v, 1]
            term[i, _T_GID] = st[_find(st, c), _GID]
            term[i, _T_TAIL] = role
            i += 1
    pairs = match_ends(
        np.ascontiguousarray(term[:, _T_X : _T_Y + 1]),
        np.ascontiguousarray(term[:, _T_GID]),
        np.ascontiguousarray(term[:, _T_TAIL]),
        gap2,
        allow_reverse,
    )
    m = pairs.shape[0]
    if m == 0:
        return 0
    cand = np.empty((m, 7), dtype=np.int64)
    for k in range(m):
        a, b = pairs[k, 0], pairs[k, 1]
        same_role = term[a, _T_TAIL] == term[b, _T_TAIL]
        # the row the full candidate list had: in order, the end first;
        # reversed, the lower id first
        if (not same_role and term[a, _T_TAIL] == 0) or (
            same_role and term[a, _T_GID] > term[b, _T_GID]
        ):
            a, b = b, a
        dx = term[b, _T_X] - term[a, _T_X]
        dy = term[b, _T_Y] - term[a, _T_Y]
        cand[k, _C_D2] = dx * dx + dy * dy
        cand[k, _C_REV] = 1 if same_role else 0
        cand[k, _C_I] = term[a, _T_GID]
        cand[k, _C_J] = term[b, _T_GID]
        cand[k, _C_SUB] = term[a, _T_TAIL] if same_role else 0
        cand[k, _C_A] = a
        cand[k, _C_B] = b
    stitched = 0
    for k in _candidate_order(cand, gap2, c0):
        a, b = cand[k, _C_A], cand[k, _C_B]
        ca, sa = term[a, _T_CHAIN], term[a, _T_SIDE]
        cb, sb = term[b, _T_CHAIN], term[b, _T_SIDE]
        role_a = _terminus_role(ring_offsets, st, ca, sa)
        role_b = _terminus_role(ring_offsets, st, cb, sb)
        if role_a < 0 or role_b < 0:  # cannot happen: a matching uses each end once
            raise RuntimeError("stitch_chains: a matched chain end is not free")
        ga, gb = _find(st, ca), _find(st, cb)
        stitched += 1
        if ga == gb:
            st[ga, _CLOSED] = 1
            continue
        if role_a == 1 and role_b == 0:
            _join(coords, ring_offsets, st, ga, gb)
        elif role_a == 0 and role_b == 1:
            _join(coords, ring_offsets, st, gb, ga)
        else:
            # two ends or two starts: reverse the shorter (tie: the higher id)
            rev_a = st[ga, _NV] < st[gb, _NV] or (
                st[ga, _NV] == st[gb, _NV] and st[ga, _GID] > st[gb, _GID]
            )
            if rev_a:
                _reverse(st, ga)
                if role_a == 1:  # end-end: b's chain, then a's reversed
                    _join(coords, ring_offsets, st, gb, ga)
                else:  # start-start: a's reversed, then b's chain
                    _join(coords, ring_offsets, st, ga, gb)
            else:
                _reverse(st, gb)
                if role_a == 1:
                    _join(coords, ring_offsets, st, ga, gb)
                else:
                    _join(coords, ring_offsets, st, gb, ga)
    return stitched


@kernel(I64(I64_2D, I64_1D, _STATE, I64, I64_2D_OUT, I64, I64))
def _emit(coords, ring_offsets, st, g, out, p, limit):
    """Write the first ``limit`` vertices of group ``g`` to ``out[p:]``.

    A chain's first vertex is skipped when it equals the vertex before it (the
    joint of two chains with identical ends keeps one). Returns vertices written.
    """
    w = 0
    c = st[g, _HEAD]
    while c >= 0 and w < limit:
        a, b = ring_offsets[c], ring_offsets[c + 1]
        flip = st[c, _FLIP] == 1
        for k in range(b - a):
            v = b - 1 - k if flip else a + k
            x, y = coords[v, 0], coords[v, 1]
            if k == 0 and w > 0 and out[p + w - 1, 0] == x and out[p + w - 1, 1] == y:
                continue
            if w == limit:
                break
            out[p + w, 0] = x
            out[p + w, 1] = y
            w += 1
        c = st[c, _NXT]
    return w


@kernel(I64(I64_2D, I64_1D, _STATE, I64))
def _out_length(coords, ring_offsets, st, g):
    """Vertices of group ``g`` as emitted (a loop drops a last vertex == first)."""
    nv = st[g, _NV]
    if st[g, _CLOSED] == 0 or nv < 2:
        return nv
    a = _vertex(ring_offsets, st[g, _HEAD], _head_side(st, g))
    b = _vertex(ring_offsets, st[g, _TAIL], _tail_side(st, g))
    same = coords[a, 0] == coords[b, 0] and coords[a, 1] == coords[b, 1]
    return nv - 1 if same else nv


@kernel(_OUT(I64_2D, I64_1D, I64_1D, I64, I64))
def stitch_chains(coords, ring_offsets, layer_offsets, max_gap_in_order, max_gap_any):
    """Join the open chains of each layer into longer chains and closed loops.

    Chain ``i`` is ``coords[ring_offsets[i]:ring_offsets[i + 1]]``; layer ``k``
    holds chains ``layer_offsets[k]:layer_offsets[k + 1]``. Per layer:

    1. Gaps ``< max_gap_in_order`` µm from a chain's last vertex to a chain's first
       (its own included: the chain closes), no reversal.
    2. Then gaps ``< max_gap_any`` µm, also last-to-last and first-to-first by
       reversing the shorter chain (fewer vertices; on a tie the one with the
       higher id); a group's own end to its own start closes it.

    In each round candidates are taken in increasing ``(gap², reversed, i, j,
    sub)``: gap² is exact; in-order (0) before reversed (1); ``i``, ``j`` are the
    ids of the chains (in order: the one whose end, then the one whose start;
    reversed: lower id first); ``sub`` puts first-to-first (0) before last-to-last
    (1). A chain's id is its index; a joined chain's id is the smallest index in
    it. Ids are taken when the round's candidates are listed. A candidate is used
    only if both its ends are still free ends of open chains. Appending keeps every
    vertex except that identical joint vertices are kept once; a loop whose last
    vertex equals its first drops the last (unless it has a single vertex).

    Returns ``(closed_coords, closed_ring_offsets, closed_layer_offsets,
    open_coords, open_ring_offsets, open_layer_offsets, stitched)``: per layer the
    new loops, then the chains left open, each ordered by id and starting at its
    head; ``stitched[k]`` counts the joins and closures of layer ``k``. Empty
    chains are dropped.

    Cost: O(V + n log n) time and O(V) memory for V vertices and n chains,
    however many chain ends crowd within one gap; the same result as listing and
    sorting every candidate pair (all keys are distinct, so ties are exact).

    Preconditions (the caller checks them): |coords| < 2**30; offsets start at 0,
    never decrease and end at the length of the level below; gaps >= 0.
    """
    n = ring_offsets.shape[0] - 1
    n_layers = layer_offsets.shape[0] - 1
    st = np.empty((n, _N_STATE), dtype=np.int64)
    for c in range(n):
        st[c, _PARENT] = c
        st[c, _HEAD] = c
        st[c, _TAIL] = c
        st[c, _NV] = ring_offsets[c + 1] - ring_offsets[c]
        st[c, _GID] = c
        st[c, _CLOSED] = 0
        st[c, _NXT] = -1
        st[c, _PRV] = -1
        st[c, _FLIP] = 0
    stitched = np.zeros(n_layers, dtype=np.int64)
    for k in range(n_layers):
        c0, c1 = layer_offsets[k], layer_offsets[k + 1]
        if c1 > c0:
            stitched[k] += _stitch_round(
                coords, ring_offsets, st, c0, c1, max_gap_in_order, False
            )
            stitched[k] += _stitch_round(
                coords, ring_offsets, st, c0, c1, max_gap_any, True
            )

    # count, scan, fill: one output ring per group, at its lowest chain index
    cl_layer = np.zeros(n_layers + 1, dtype=np.int64)
    op_layer = np.zeros(n_layers + 1, dtype=np.int64)
    n_cl_v = 0
    n_op_v = 0
    for k in range(n_layers):
        for c in range(layer_offsets[k], layer_offsets[k + 1]):
            if ring_offsets[c + 1] == ring_offsets[c]:
                continue
            g = _find(st, c)
            if st[g, _GID] != c:
                continue
            if st[g, _CLOSED] != 0:
                cl_layer[k + 1] += 1
                n_cl_v += _out_length(coords, ring_offsets, st, g)
            else:
                op_layer[k + 1] += 1
                n_op_v += st[g, _NV]
    cl_layer = np.cumsum(cl_layer)
    op_layer = np.cumsum(op_layer)
    cl_coords = np.empty((n_cl_v, 2), dtype=np.int64)
    op_coords = np.empty((n_op_v, 2), dtype=np.int64)
    cl_rings = np.zeros(cl_layer[n_layers] + 1, dtype=np.int64)
    op_rings = np.zeros(op_layer[n_layers] + 1, dtype=np.int64)
    ncl = 0
    nop = 0
    pcl = 0
    pop = 0
    for c in range(n):
        if ring_offsets[c + 1] == ring_offsets[c]:
            continue
        g = _find(st, c)
        if st[g, _GID] != c:
            continue
        if st[g, _CLOSED] != 0:
            length = _out_length(coords, ring_offsets, st, g)
            w = _emit(coords, ring_offsets, st, g, cl_coords, pcl, length)
            pcl += w
            ncl += 1
            cl_rings[ncl] = pcl
        else:
            length = st[g, _NV]
            w = _emit(coords, ring_offsets, st, g, op_coords, pop, length)
            pop += w
            nop += 1
            op_rings[nop] = pop
        if w != length:
            raise RuntimeError("stitch_chains: emitted vertex count mismatch")
    return cl_coords, cl_rings, cl_layer, op_coords, op_rings, op_layer, stitched
