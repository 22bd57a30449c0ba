"""``planar._to_ring_from`` (pruned, early-stopping ring distance) against ``_to_ring``."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vecslice._kernels.planar import _point_segment, _to_ring, _to_ring_from


@st.composite
def point_and_ring(draw):
    n = draw(st.integers(1, 30))
    scale = draw(st.sampled_from([3, 100, 10**5, 2**29]))
    coord = st.integers(-scale, scale)
    ring = np.array([[draw(coord), draw(coord)] for _ in range(n)], np.int64)
    if draw(st.booleans()):  # near-collinear runs, points on edges, ties
        ring[:, 1] = ring[:, 0] // draw(st.integers(1, 7))
    p = ring[draw(st.integers(0, n - 1))].copy() if draw(st.booleans()) else np.array(
        [draw(coord), draw(coord)], np.int64)
    p += np.array([draw(st.integers(-2, 2)), draw(st.integers(-2, 2))], np.int64)
    return p, ring


@settings(max_examples=300)
@given(point_and_ring(), st.data())
def test_to_ring_from_is_bitwise_to_ring(pr, data):
    p, ring = pr
    n = len(ring)
    want = _to_ring(p[0], p[1], ring, 0, n)
    assert _to_ring_from(p[0], p[1], ring, 0, n, np.inf, -1.0) == want
    # started from the distance to some of its edges, as the metrics do
    edges = data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n))
    best = min(_point_segment(p[0], p[1], *ring[i], *ring[(i + 1) % n]) for i in edges)
    assert _to_ring_from(p[0], p[1], ring, 0, n, best, -1.0) == want
    # stopping early: at most stop once the distance is; else the exact distance
    stop = data.draw(st.sampled_from([0.0, want, want * 0.5, want * 2.0, 1.0]))
    got = _to_ring_from(p[0], p[1], ring, 0, n, best, stop)
    assert got <= stop if want <= stop else got == want


def test_ring_offset_and_far_edges_skipped_exactly():
    # a ring far away except one edge: the pruning must keep the one that counts
    ring = np.array([[0, 0], [10**6, 0], [10**6, 10**6], [0, 10**6],
                     [5, 7], [9, 7]], np.int64)
    stack = np.concatenate([np.zeros((3, 2), np.int64), ring])
    for px, py in ((7, 9), (7, 7), (7, 3), (0, 5), (10**6 + 3, 10**6 + 4)):
        want = _to_ring(px, py, ring, 0, len(ring))
        assert _to_ring_from(px, py, stack, 3, len(ring), np.inf, -1.0) == want
