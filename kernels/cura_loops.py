"""Kernel chaining CuraEngine's segments into loops and open chains (compat mode).

``spec/CURA_COMPAT.md`` section 4, step 1 (``makeBasicPolygonLoops``). The result
is a relabelling of the segments: the order in which CuraEngine visits them, with
the ring boundaries; the caller turns it into points (the first segment's start,
then every segment's end).
"""

import numpy as np
from numba import prange, types

from ._jit import kernel
from ._types import B1_1D, B1_1D_OUT, I64_1D, I64_1D_OUT, I64_2D, I64_2D_OUT
from .cura_segments import segment_of

# CuraEngine's largest_neglected_gap_first_phase = MM2INT(0.01)
FIRST_PHASE_GAP = 10

_LOOPS_OUT = types.Tuple((I64_1D_OUT, B1_1D_OUT, B1_1D_OUT))


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
def _next_segment(points, links, added, cur, start, k, face_lo, slot_offsets,
                  slot_seg, vf_offsets, vf_faces):
    """CuraEngine's ``getNextSegmentIdx`` for segment ``cur`` of a chain."""
    v = links[cur, 1]
    if v < 0:
        return _try_segment(links[cur, 0], cur, start, points, added)
    result = -1
    for i in range(vf_offsets[v], vf_offsets[v + 1]):
        t = segment_of(vf_faces[i], k, face_lo, slot_offsets, slot_seg)
        r = _try_segment(t, cur, start, points, added)
        if r == start:
            return start
        if r >= 0:
            result = r
    return result


@kernel(
    _LOOPS_OUT(I64_2D, I64_2D, I64_1D, I64_1D, I64_1D, I64_1D, I64_1D, I64_1D),
    parallel=True,
)
def basic_loops(points, links, layer_offsets, face_lo, slot_offsets, slot_seg,
                vf_offsets, vf_faces):
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
    need one lookup each; only ends on a vertex search the faces around it.

    Returns ``(seg_order, ring_start, closed)`` of length S: segments in visiting
    order (a permutation of each plane's range), whether position ``i`` starts a
    ring, and (at ring starts) whether it closed on its first segment.

    Preconditions: as produced by ``cura_segments.order_by_layer``; faces of
    ``vf_faces`` index ``face_lo``.
    """
    n_seg = points.shape[0]
    n_layers = layer_offsets.shape[0] - 1
    added = np.zeros(n_seg, dtype=np.bool_)
    seg_order = np.empty(n_seg, dtype=np.int64)
    ring_start = np.zeros(n_seg, dtype=np.bool_)
    closed = np.zeros(n_seg, dtype=np.bool_)
    for k in prange(n_layers):
        pos = layer_offsets[k]
        for s in range(layer_offsets[k], layer_offsets[k + 1]):
            if added[s]:
                continue
            first = pos
            ring_start[first] = True
            cur = s
            while True:
                seg_order[pos] = cur
                pos += 1
                added[cur] = True
                nxt = _next_segment(points, links, added, cur, s, k, face_lo,
                                    slot_offsets, slot_seg, vf_offsets, vf_faces)
                if nxt == s:
                    closed[first] = True
                    break
                if nxt < 0:
                    break
                cur = nxt
    return seg_order, ring_start, closed


_EMIT_OUT = types.Tuple(
    (I64_2D_OUT, I64_1D_OUT, I64_1D_OUT, I64_2D_OUT, I64_1D_OUT, I64_1D_OUT)
)


@kernel(_EMIT_OUT(I64_2D, I64_1D, B1_1D, B1_1D, I64_1D), parallel=True)
def emit_rings(points, seg_order, ring_start, closed, layer_offsets):
    """The points of the loops and open chains :func:`basic_loops` found.

    A ring of segments ``s_0 .. s_m`` is the start of ``s_0`` followed by the end
    of every ``s_i`` (CuraEngine appends only segment ends): a closed loop's last
    point is its near-duplicate closing point. Returns ``(loop_coords,
    loop_ring_offsets, loop_layer_offsets, chain_coords, chain_ring_offsets,
    chain_layer_offsets)``, each kind in visiting order per plane (count, scan,
    fill; planes in parallel).
    """
    n_layers = layer_offsets.shape[0] - 1
    # per plane: loops, loop points, chains, chain points
    cnt = np.zeros((n_layers + 1, 4), dtype=np.int64)
    for k in prange(n_layers):
        c = 0
        for i in range(layer_offsets[k], layer_offsets[k + 1]):
            if ring_start[i]:
                c = 0 if closed[i] else 2
                cnt[k + 1, c] += 1
                cnt[k + 1, c + 1] += 1
            cnt[k + 1, c + 1] += 1
    for k in range(n_layers):
        for c in range(4):
            cnt[k + 1, c] += cnt[k, c]
    loop_xy = np.empty((cnt[n_layers, 1], 2), dtype=np.int64)
    chain_xy = np.empty((cnt[n_layers, 3], 2), dtype=np.int64)
    loop_rings = np.empty(cnt[n_layers, 0] + 1, dtype=np.int64)
    chain_rings = np.empty(cnt[n_layers, 2] + 1, dtype=np.int64)
    loop_rings[0] = 0
    chain_rings[0] = 0
    for k in prange(n_layers):
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
                    loop_xy[p_loop, 0] = points[s, 0]
                    loop_xy[p_loop, 1] = points[s, 1]
                    p_loop += 1
                else:
                    chain_xy[p_chain, 0] = points[s, 0]
                    chain_xy[p_chain, 1] = points[s, 1]
                    p_chain += 1
            if is_loop:
                loop_xy[p_loop, 0] = points[s, 2]
                loop_xy[p_loop, 1] = points[s, 3]
                p_loop += 1
            else:
                chain_xy[p_chain, 0] = points[s, 2]
                chain_xy[p_chain, 1] = points[s, 3]
                p_chain += 1
            last = i + 1 == layer_offsets[k + 1] or ring_start[i + 1]
            if last:
                if is_loop:
                    r_loop += 1
                    loop_rings[r_loop] = p_loop
                else:
                    r_chain += 1
                    chain_rings[r_chain] = p_chain
    loop_layers = cnt[:, 0].copy()
    chain_layers = cnt[:, 2].copy()
    return loop_xy, loop_rings, loop_layers, chain_xy, chain_rings, chain_layers
