"""Kernel chaining CuraEngine's segments into loops and open chains (compat mode).

``spec/CURA_COMPAT.md`` section 4, step 1 (``makeBasicPolygonLoops``). The result
is a relabelling of the segments: the order in which CuraEngine visits them, with
the ring boundaries; the caller turns it into points (the first segment's start,
then every segment's end).
"""

import numpy as np
from numba import types

from ._jit import cost_chunks, kernel, run_serial
from ._types import (
    B1_1D,
    B1_1D_W,
    I64,
    I64_1D,
    I64_1D_OUT,
    I64_1D_W,
    I64_2D,
    I64_2D_W,
)
from .cura_segments import segment_of
from .sorting import lower_bound

# CuraEngine's largest_neglected_gap_first_phase = MM2INT(0.01)
FIRST_PHASE_GAP = 10
_SEGMENT_CHUNK = 1 << 15  # segments (and planes) per chunk of planes


@kernel(inline="always")
def _shorter_than(dx, dy, length):
    """CuraEngine's ``shorterThen``: per-axis pre-check, then d.d <= length**2."""
    if dx > length or dx < -length or dy > length or dy < -length:
        return False
    return dx * dx + dy * dy <= length * length


@kernel(inline="always")
def _try_segment(t, cur, start, points, added):
    """CuraEngine's ``tryFaceNextSegmentIdx`` for the face whose segment is ``t``."""
    if t < 0:
        return -1
    if not _shorter_than(points[cur, 2] - points[t, 0], points[cur, 3] - points[t, 1],
                         FIRST_PHASE_GAP):
        return -1
    if t == start:
        return start
    if added[t]:
        return -1
    return t


@kernel(inline="always")
def _hub_candidate(points, f, k, box, face_lo, slot_offsets, slot_seg):
    """Face ``f``'s segment on plane ``k`` if it starts within 10 µm of ``box``."""
    t = segment_of(f, k, face_lo, slot_offsets, slot_seg)
    if t < 0:
        return -1
    x = points[t, 0]
    y = points[t, 1]
    gap = FIRST_PHASE_GAP
    if x < box[0] - gap or x > box[1] + gap or y < box[2] - gap or y > box[3] + gap:
        return -1
    return t


@kernel(
    types.Tuple((I64_1D_OUT, I64_1D_OUT, I64_1D_OUT))(
        I64_2D, I64_2D, I64_1D, I64_1D, I64_1D, I64_1D, I64_1D, I64_1D),
)
def hub_index(points, links, layer_offsets, face_lo, slot_offsets, slot_seg,
              vf_offsets, vf_faces):
    """The segments a chain may continue with at each hub: a vertex on a plane.

    A *hub* is a (vertex ``v``, plane ``k``) pair such that some segment of plane
    ``k`` ends on ``v`` (``links[s, 1] == v``). Its candidates are the segments
    of plane ``k`` made by the faces around ``v`` (``vf_faces[vf_offsets[v]:
    vf_offsets[v + 1]]``, in that order), keeping only those that start within
    10 µm per axis of the bounding box of the ends of the segments ending on the
    hub: any other one is farther than 10 µm from every end that looks for it,
    so ``tryFace`` would refuse it anyway.

    Returns ``(seg_hub, hub_offsets, hub_cands)``: the hub of segment ``s``
    (-1 if its end is on an edge); hub ``h``'s candidates are
    ``hub_cands[hub_offsets[h]:hub_offsets[h + 1]]``, in the order of
    ``vf_faces``, hence by increasing segment (faces around a vertex come in
    face order, and a plane numbers its segments in face order).

    One pass over the segments and two over the faces around each hub; a
    segment is a candidate of at most three hubs (its face's vertices).

    Preconditions: as :func:`basic_loops`.
    """
    n_seg = points.shape[0]
    n_layers = layer_offsets.shape[0] - 1
    n_vert = vf_offsets.shape[0] - 1
    n_hub_max = 0
    for s in range(n_seg):
        if links[s, 1] >= 0:
            n_hub_max += 1
    seg_hub = np.full(n_seg, -1, dtype=np.int64)
    vert_plane = np.full(n_vert, -1, dtype=np.int64)  # plane of v's latest hub
    vert_hub = np.empty(n_vert, dtype=np.int64)
    hub_vert = np.empty(n_hub_max, dtype=np.int64)
    hub_plane = np.empty(n_hub_max, dtype=np.int64)
    box = np.empty((n_hub_max, 4), dtype=np.int64)  # x lo, x hi, y lo, y hi
    n_hubs = 0
    for k in range(n_layers):
        for s in range(layer_offsets[k], layer_offsets[k + 1]):
            v = links[s, 1]
            if v < 0:
                continue
            ex = points[s, 2]
            ey = points[s, 3]
            if vert_plane[v] != k:
                vert_plane[v] = k
                vert_hub[v] = n_hubs
                hub_vert[n_hubs] = v
                hub_plane[n_hubs] = k
                box[n_hubs, 0] = ex
                box[n_hubs, 1] = ex
                box[n_hubs, 2] = ey
                box[n_hubs, 3] = ey
                n_hubs += 1
            else:
                h = vert_hub[v]
                box[h, 0] = min(box[h, 0], ex)
                box[h, 1] = max(box[h, 1], ex)
                box[h, 2] = min(box[h, 2], ey)
                box[h, 3] = max(box[h, 3], ey)
            seg_hub[s] = vert_hub[v]
    hub_offsets = np.zeros(n_hubs + 1, dtype=np.int64)
    for h in range(n_hubs):  # count, scan, fill
        n = 0
        for i in range(vf_offsets[hub_vert[h]], vf_offsets[hub_vert[h] + 1]):
            if _hub_candidate(points, vf_faces[i], hub_plane[h], box[h], face_lo,
                              slot_offsets, slot_seg) >= 0:
                n += 1
        hub_offsets[h + 1] = hub_offsets[h] + n
    hub_cands = np.empty(hub_offsets[n_hubs], dtype=np.int64)
    for h in range(n_hubs):
        pos = hub_offsets[h]
        for i in range(vf_offsets[hub_vert[h]], vf_offsets[hub_vert[h] + 1]):
            t = _hub_candidate(points, vf_faces[i], hub_plane[h], box[h], face_lo,
                               slot_offsets, slot_seg)
            if t >= 0:
                hub_cands[pos] = t
                pos += 1
    return seg_hub, hub_offsets, hub_cands


@kernel(inline="always")
def _alive_below(i, lo, hub_cands, added, io_skip):
    """The highest position ``<= i`` (and ``>= lo``) whose candidate is unused.

    ``lo - 1`` or below if there is none. ``io_skip[j] == j`` for a position not
    yet known to be used; otherwise every position in ``io_skip[j] + 1 .. j``
    holds a used segment. Segments are never unmarked, so the jumps only grow
    (halved as they are followed): used candidates cost a hub's searches about
    its candidate count in all.
    """
    while i >= lo:
        j = io_skip[i]
        if j != i:
            if j >= lo:
                io_skip[i] = io_skip[j]
            i = j
        elif added[hub_cands[i]]:
            io_skip[i] = i - 1
            i -= 1
        else:
            return i
    return i


@kernel(inline="always")
def _next_at_hub(points, added, cur, start, lo, hi, hub_cands, io_skip):
    """``getNextSegmentIdx`` for an end on a vertex: its hub's candidates lo:hi.

    CuraEngine tries every face around the vertex in order: the chain's first
    segment, if one of them and within 10 µm, returns at once; otherwise the
    last unused segment within 10 µm wins. Here the first segment is looked up
    by bisection (the candidates ascend), and the last unused one is found from
    the back, skipping used ones for good.
    """
    ex = points[cur, 2]
    ey = points[cur, 3]
    a = lower_bound(hub_cands, lo, hi, start)
    if a < hi and hub_cands[a] == start and _shorter_than(
            ex - points[start, 0], ey - points[start, 1], FIRST_PHASE_GAP):
        return start
    i = _alive_below(hi - 1, lo, hub_cands, added, io_skip)
    while i >= lo:
        t = hub_cands[i]
        if _shorter_than(ex - points[t, 0], ey - points[t, 1], FIRST_PHASE_GAP):
            return t
        i = _alive_below(i - 1, lo, hub_cands, added, io_skip)
    return -1


@kernel(
    types.void(I64_2D, I64_2D, I64_1D, I64_1D, I64_1D, I64_1D, I64, I64, B1_1D_W,
               I64_1D_W, I64_1D_W, B1_1D_W, B1_1D_W),
)
def _loops_range(points, links, layer_offsets, seg_hub, hub_offsets, hub_cands, k0,
                 k1, added, io_skip, out_seg_order, out_ring_start, out_closed):
    """:func:`basic_loops` of planes ``k0:k1``, into their segments' entries.

    ``added`` (S,) marks the segments used; False on entry for these planes'
    segments (a chain never leaves its plane, so disjoint plane ranges can run
    on several threads). ``io_skip`` is :func:`_alive_below`'s state over
    ``hub_cands`` (``io_skip[j] == j`` on entry). ``out_ring_start`` and
    ``out_closed`` are False on entry.
    """
    for k in range(k0, k1):
        pos = layer_offsets[k]
        for s in range(layer_offsets[k], layer_offsets[k + 1]):
            if added[s]:
                continue
            first = pos
            out_ring_start[first] = True
            cur = s
            while True:
                out_seg_order[pos] = cur
                pos += 1
                added[cur] = True
                h = seg_hub[cur]
                if h < 0:
                    nxt = _try_segment(links[cur, 0], cur, s, points, added)
                else:
                    nxt = _next_at_hub(points, added, cur, s, hub_offsets[h],
                                       hub_offsets[h + 1], hub_cands, io_skip)
                if nxt == s:
                    out_closed[first] = True
                    break
                if nxt < 0:
                    break
                cur = nxt


def basic_loops(points, links, layer_offsets, face_lo, slot_offsets, slot_seg,
                vf_offsets, vf_faces, run=run_serial):
    """CuraEngine's ``makeBasicPolygonLoops`` on every plane.

    Segment ``s`` (plane ``k`` holds ``layer_offsets[k]:layer_offsets[k + 1]``, in
    face order) runs from ``points[s, 0:2]`` to ``points[s, 2:4]``; ``links[s]`` is
    (the segment of ``endOtherFaceIdx`` on the plane or -1, ``endVertex`` or -1)
    as ``cura_segments.fill_segments`` makes them. ``vf_faces[vf_offsets[v]:
    vf_offsets[v + 1]]`` are the faces around vertex ``v`` in face order
    (``connected_faces_``); ``face_lo``, ``slot_offsets`` and ``slot_seg`` map
    (face, plane) to a segment (``face_idx_to_segment_idx``).

    Per plane, each segment not yet used starts a chain, lowest index first; the
    chain follows ``getNextSegmentIdx`` from its last segment ``cur``:

    * the end on an edge: ``tryFace(endOtherFaceIdx)``;
    * the end on a vertex: ``tryFace`` of every face around it, in order; the
      chain's first segment returns at once, otherwise the last hit wins;
    * ``tryFace(g)``: g's segment ``t`` on this plane if ``end(cur) - start(t)`` is
      within 10 µm (``shorterThen``), unless ``t`` is used (then -1; ``t`` equal to
      the chain's first segment closes the loop).

    Segments whose end lies on an edge (all of them on a plane through no vertex)
    need one lookup each. Ends on a vertex search the faces around it through
    :func:`hub_index`, which keeps only the segments starting near the vertex and
    skips used ones for good: a vertex on the plane with n faces around it costs
    about n in all, not n per segment ending there (a fan of 40,000 triangles
    around one vertex took 22 s with the plain search). Only unused candidates
    farther than 10 µm from the end searched from are passed again by each
    search; the box keeps out all but those near the other ends on the vertex,
    which CuraEngine's arithmetic puts within 1 µm of it.

    Returns ``(seg_order, ring_start, closed)`` of length S: segments in visiting
    order (a permutation of each plane's range), whether position ``i`` starts a
    ring, and (at ring starts) whether it closed on its first segment.

    Chunks of planes with about equal segment counts go to ``run``
    (``run(fn, bounds)`` calls ``fn(lo, hi)`` for every chunk of planes, in any
    order or at once: e.g. ``vecslice._threads.run_chunks``); by default one
    after another.

    Preconditions: as produced by ``cura_segments.order_by_layer`` (a plane's
    segments in face order); each vertex's faces in ``vf_faces`` in increasing
    order (as ``cura_mesh.vertex_faces`` makes them) and indexing ``face_lo``.
    """
    n_seg = points.shape[0]
    seg_hub, hub_offsets, hub_cands = hub_index(
        points, links, layer_offsets, face_lo, slot_offsets, slot_seg, vf_offsets,
        vf_faces)
    skip = np.arange(hub_cands.shape[0], dtype=np.int64)
    added = np.zeros(n_seg, dtype=np.bool_)
    seg_order = np.empty(n_seg, dtype=np.int64)
    ring_start = np.zeros(n_seg, dtype=np.bool_)
    closed = np.zeros(n_seg, dtype=np.bool_)
    run(lambda k0, k1: _loops_range(points, links, layer_offsets, seg_hub,
                                    hub_offsets, hub_cands, k0, k1, added, skip,
                                    seg_order, ring_start, closed),
        cost_chunks(layer_offsets, _SEGMENT_CHUNK))
    return seg_order, ring_start, closed


@kernel(types.void(B1_1D, B1_1D, I64_1D, I64, I64, I64_2D_W))
def _count_range(ring_start, closed, layer_offsets, k0, k1, out_cnt):
    """Count the rings of planes ``k0:k1``: the first pass of :func:`emit_rings`.

    ``out_cnt[k + 1]`` = (loops, loop points, chains, chain points) of plane
    ``k``; the row is zero on entry.
    """
    for k in range(k0, k1):
        c = 0
        for i in range(layer_offsets[k], layer_offsets[k + 1]):
            if ring_start[i]:
                c = 0 if closed[i] else 2
                out_cnt[k + 1, c] += 1
                out_cnt[k + 1, c + 1] += 1
            out_cnt[k + 1, c + 1] += 1


@kernel(
    types.void(I64_2D, I64_1D, B1_1D, B1_1D, I64_1D, I64_2D, I64, I64, I64_2D_W,
               I64_1D_W, I64_2D_W, I64_1D_W),
)
def _emit_range(points, seg_order, ring_start, closed, layer_offsets, cnt, k0, k1,
                out_loop_xy, out_loop_rings, out_chain_xy, out_chain_rings):
    """The rings of planes ``k0:k1``, from the counts ``cnt`` (scanned)."""
    for k in range(k0, k1):
        r_loop = cnt[k, 0]
        p_loop = cnt[k, 1]
        r_chain = cnt[k, 2]
        p_chain = cnt[k, 3]
        is_loop = False
        for i in range(layer_offsets[k], layer_offsets[k + 1]):
            s = seg_order[i]
            if ring_start[i]:
                is_loop = closed[i]
                if is_loop:
                    out_loop_xy[p_loop, 0] = points[s, 0]
                    out_loop_xy[p_loop, 1] = points[s, 1]
                    p_loop += 1
                else:
                    out_chain_xy[p_chain, 0] = points[s, 0]
                    out_chain_xy[p_chain, 1] = points[s, 1]
                    p_chain += 1
            if is_loop:
                out_loop_xy[p_loop, 0] = points[s, 2]
                out_loop_xy[p_loop, 1] = points[s, 3]
                p_loop += 1
            else:
                out_chain_xy[p_chain, 0] = points[s, 2]
                out_chain_xy[p_chain, 1] = points[s, 3]
                p_chain += 1
            last = i + 1 == layer_offsets[k + 1] or ring_start[i + 1]
            if last:
                if is_loop:
                    r_loop += 1
                    out_loop_rings[r_loop] = p_loop
                else:
                    r_chain += 1
                    out_chain_rings[r_chain] = p_chain


def emit_rings(points, seg_order, ring_start, closed, layer_offsets, run=run_serial):
    """The points of the loops and open chains :func:`basic_loops` found.

    A ring of segments ``s_0 .. s_m`` is the start of ``s_0`` followed by the end
    of every ``s_i`` (CuraEngine appends only segment ends): a closed loop's last
    point is its near-duplicate closing point. Returns ``(loop_coords,
    loop_ring_offsets, loop_layer_offsets, chain_coords, chain_ring_offsets,
    chain_layer_offsets)``, each kind in visiting order per plane (count, scan,
    fill; chunks of planes go to ``run`` as in :func:`basic_loops`).
    """
    n_layers = layer_offsets.shape[0] - 1
    bounds = cost_chunks(layer_offsets, _SEGMENT_CHUNK)
    # per plane: loops, loop points, chains, chain points
    cnt = np.zeros((n_layers + 1, 4), dtype=np.int64)
    run(lambda k0, k1: _count_range(ring_start, closed, layer_offsets, k0, k1, cnt),
        bounds)
    np.cumsum(cnt, axis=0, out=cnt)
    loop_xy = np.empty((cnt[n_layers, 1], 2), dtype=np.int64)
    chain_xy = np.empty((cnt[n_layers, 3], 2), dtype=np.int64)
    loop_rings = np.empty(cnt[n_layers, 0] + 1, dtype=np.int64)
    chain_rings = np.empty(cnt[n_layers, 2] + 1, dtype=np.int64)
    loop_rings[0] = 0
    chain_rings[0] = 0
    run(lambda k0, k1: _emit_range(points, seg_order, ring_start, closed,
                                   layer_offsets, cnt, k0, k1, loop_xy, loop_rings,
                                   chain_xy, chain_rings), bounds)
    loop_layers = cnt[:, 0].copy()
    chain_layers = cnt[:, 2].copy()
    return loop_xy, loop_rings, loop_layers, chain_xy, chain_rings, chain_layers
