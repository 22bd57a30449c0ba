"""Kernel chaining CuraEngine's segments into loops and open chains (compat mode).

``spec/CURA_COMPAT.md`` section 4, step 1 (``makeBasicPolygonLoops``). The result
is a relabelling of the segments: the order in which CuraEngine visits them, with
the ring boundaries; the caller turns it into points (the first segment's start,
then every segment's end).
"""

import numpy as np
from numba import prange, types

from ._jit import kernel
from ._types import B1_1D_OUT, I64_1D, I64_1D_OUT, I64_2D

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
def _segment_of(f, k, face_lo, slot_offsets, slot_seg):
    """Segment of face ``f`` on plane ``k`` (``face_idx_to_segment_idx``), or -1."""
    i = k - face_lo[f]
    if i < 0 or i >= slot_offsets[f + 1] - slot_offsets[f]:
        return -1
    return slot_seg[slot_offsets[f] + i]


@kernel(inline="always")
def _try_face(f, k, cur, start, points, added, face_lo, slot_offsets, slot_seg):
    """CuraEngine's ``tryFaceNextSegmentIdx``."""
    t = _segment_of(f, k, face_lo, slot_offsets, slot_seg)
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
        g = links[cur, 0]
        if g < 0:
            return -1
        return _try_face(g, k, cur, start, points, added, face_lo, slot_offsets,
                         slot_seg)
    result = -1
    for i in range(vf_offsets[v], vf_offsets[v + 1]):
        r = _try_face(vf_faces[i], k, cur, start, points, added, face_lo,
                      slot_offsets, slot_seg)
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
    (``endOtherFaceIdx``, ``endVertex``). ``vf_faces[vf_offsets[v]:vf_offsets[v +
    1]]`` are the faces around vertex ``v`` in face order (``connected_faces_``);
    the other arrays map (face, plane) to a segment (see ``cura_segments``).

    Per plane, each segment not yet used starts a chain, lowest index first; the
    chain follows ``getNextSegmentIdx`` from its last segment ``cur``:

    * the end on an edge: ``tryFace(endOtherFaceIdx)``;
    * the end on a vertex: ``tryFace`` of every face around it, in order; the
      chain's first segment returns at once, otherwise the last hit wins;
    * ``tryFace(g)``: g's segment ``t`` on this plane if ``end(cur) - start(t)`` is
      within 10 µm (``shorterThen``), unless ``t`` is used (then -1; ``t`` equal to
      the chain's first segment closes the loop).

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
