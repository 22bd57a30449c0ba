import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import reference_metrics as ref
from vecslice._kernels.planar import directed_distance


@st.composite
def rings(draw, max_n=120):
    """An integer ring: sorted or (wild) shuffled angles, random radii, offset."""
    n = draw(st.integers(1, max_n))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    ang = rng.uniform(0, 2 * np.pi, n)
    if draw(st.booleans()):
        ang = np.sort(ang)
    rad = draw(st.sampled_from([20, 1000, 40000])) * rng.uniform(0.2, 1.0, n)
    pts = np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)
    shift = draw(st.tuples(st.integers(-3000, 3000), st.integers(-3000, 3000)))
    return np.rint(pts).astype(np.int64) + np.array(shift, np.int64)


def _directed(a, b):
    # both rings in one coordinate array, as the metrics kernels hold them
    c = np.concatenate([a, b]).astype(np.int64)
    ub = np.full(len(a) + 1, np.nan)
    return directed_distance(c, 0, len(a), c, len(a), len(b), ub)


@settings(max_examples=150)
@given(rings(), rings())
def test_directed_distance_is_the_brute_force_maximum(a, b):
    # bit for bit the largest over all vertex-edge pairs, both ways, whatever
    # the rings (self-intersecting ones send the walks into local minima)
    assert _directed(a, b) == ref.max_vertex_distance(a, b)
    assert _directed(b, a) == ref.max_vertex_distance(b, a)


@settings(max_examples=40)
@given(rings(max_n=60), st.integers(0, 59))
def test_reversed_and_rotated_rings_are_zero(a, k):
    b = np.roll(a[::-1], k % len(a), axis=0)
    assert _directed(a, b) == 0.0 and _directed(b, a) == 0.0


def test_walks_longer_than_their_cap_are_still_exact():
    # a fine circle; a's vertices alternate between opposite sides, so every
    # walk from the previous vertex's edge stops at its cap far from the
    # nearest edge: the bounds are loose, the exact pass settles them
    n = 2000
    ang = 2 * np.pi * np.arange(n) / n
    b = np.rint(np.stack([1e5 * np.cos(ang), 1e5 * np.sin(ang)], 1)).astype(np.int64)
    a = np.array([(1000 + 37 * i, 0) if i % 2 else (-1000 - 41 * i, 5 * i)
                  for i in range(40)], np.int64)
    assert _directed(a, b) == ref.max_vertex_distance(a, b)
    assert _directed(b, a) == ref.max_vertex_distance(b, a)


def test_empty_rings():
    a = np.array([[0, 0], [10, 0], [0, 10]], np.int64)
    empty = np.zeros((0, 2), np.int64)
    assert _directed(empty, a) == 0.0
    assert _directed(a, empty) == np.inf  # no edge: as the all-pairs loop gives


def test_a_large_ring_against_its_reversal():
    # 20,000 vertices each way (4e8 pairs for the brute force): the walks bound
    # every vertex by 0, and no vertex is measured against all edges
    n = 20000
    ang = 2 * np.pi * np.arange(n) / n
    a = np.rint(np.stack([1e7 * np.cos(ang), 1e7 * np.sin(ang)], 1)).astype(np.int64)
    assert _directed(a, a[::-1].copy()) == 0.0
    assert _directed(a[::-1].copy(), a) == 0.0
