import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import reference
from vecslice._kernels.rings import (
    AREA2_BEYOND_INT64,
    group_rings,
    ring_area2,
    ring_keys,
    rings_equal,
    take_rings,
)

coord = st.integers(-(2**30) + 1, 2**30 - 1)


@st.composite
def ragged_rings(draw):
    lens = draw(st.lists(st.integers(0, 7), max_size=10))
    pts = draw(st.lists(st.tuples(coord, coord), min_size=sum(lens),
                        max_size=sum(lens)))
    coords = np.array(pts, dtype=np.int64).reshape(-1, 2)
    offsets = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
    return coords, offsets


@given(ragged_rings())
def test_ring_area2_matches_reference(case):
    coords, offsets = case
    assert ring_area2(coords, offsets).tolist() == reference.ring_area2(coords, offsets)


@given(ragged_rings())
def test_reversing_a_ring_negates_its_area(case):
    coords, offsets = case
    rev = np.concatenate(
        [coords[offsets[i]:offsets[i + 1]][::-1] for i in range(len(offsets) - 1)]
        or [np.empty((0, 2), np.int64)]
    ).astype(np.int64)
    assert (ring_area2(rev, offsets) == -ring_area2(coords, offsets)).all()


@given(ragged_rings(), st.integers(1, 4), st.randoms())
def test_group_rings_is_a_stable_grouping(case, n_keys, rnd):
    coords, offsets = case
    n = len(offsets) - 1
    keys = np.array([rnd.randrange(n_keys) for _ in range(n)], dtype=np.int64)
    ids = np.arange(len(coords), dtype=np.int64)[::-1].copy()
    out, ro, ko = group_rings(coords, ids, offsets, keys, n_keys)
    expect = []
    for k in range(n_keys):
        for r in range(n):
            if keys[r] == k:
                expect.append(coords[ids[offsets[r]:offsets[r + 1]]].tolist())
    got = [out[ro[i]:ro[i + 1]].tolist() for i in range(n)]
    assert got == expect
    assert np.diff(ko).tolist() == np.bincount(keys, minlength=n_keys).tolist()


@given(st.lists(st.integers(0, 5), min_size=0, max_size=30), st.randoms())
def test_take_rings_keeps_the_chosen_rings_in_order(lengths, rnd):
    offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    coords = np.arange(2 * offsets[-1], dtype=np.int64).reshape(-1, 2)
    keep = np.array([rnd.random() < 0.5 for _ in lengths], dtype=np.bool_)
    got_c, got_o = take_rings(coords, offsets, keep)
    rings = [coords[offsets[i]:offsets[i + 1]] for i in range(len(lengths)) if keep[i]]
    assert got_o.tolist() == [0, *np.cumsum([len(r) for r in rings]).tolist()]
    assert got_c.tolist() == (np.concatenate(rings).tolist() if rings else [])


@given(ragged_rings(), ragged_rings(), st.data())
def test_rings_equal_matches_numpy(a, b, data):
    ca, oa = a
    cb, ob = b
    na, nb = len(oa) - 1, len(ob) - 1
    if na == 0 or nb == 0:
        return
    k = data.draw(st.integers(1, 8))
    ia = np.array(data.draw(st.lists(st.integers(0, na - 1), min_size=k, max_size=k)))
    ib = np.array(data.draw(st.lists(st.integers(0, nb - 1), min_size=k, max_size=k)))
    want = [np.array_equal(ca[oa[i]:oa[i + 1]], cb[ob[j]:ob[j + 1]])
            for i, j in zip(ia, ib, strict=True)]
    assert rings_equal(ca, oa, ia, cb, ob, ib).tolist() == want


def test_rings_equal_itself_and_a_copy_with_one_vertex_moved():
    coords = np.array([[0, 0], [5, 0], [5, 5], [1, 1], [2, 2], [3, 3]], np.int64)
    offsets = np.array([0, 3, 6], np.int64)
    other = coords.copy()
    other[4, 1] += 1
    both = np.array([0, 1])
    assert rings_equal(coords, offsets, both, coords, offsets, both).tolist() == [
        True, True]
    assert rings_equal(coords, offsets, both, other, offsets, both).tolist() == [
        True, False]
    # rings of different lengths differ even where one starts like the other
    assert not rings_equal(coords, np.array([0, 2, 6]), np.array([0]), coords,
                           offsets, np.array([0]))[0]


@given(ragged_rings())
def test_ring_keys_depend_on_the_ring_and_its_index(case):
    coords, offsets = case
    keys = ring_keys(coords, offsets)
    assert keys.shape == (len(offsets) - 1,)
    # the same rings in a fresh array: the same keys
    assert np.array_equal(ring_keys(coords.copy(), offsets.copy()), keys)
    # an empty ring in front moves every ring to the next index: the same ring
    # under another index has another key
    shifted = ring_keys(coords, np.concatenate([[0], offsets]))
    assert not (shifted[1:] == keys).any()


def test_ring_keys_see_every_coordinate_and_the_vertex_count():
    base = np.array([[10, 20], [30, 40], [50, 60]], np.int64)
    key = ring_keys(base, np.array([0, 3]))[0]
    for i in range(3):
        for c in range(2):
            moved = base.copy()
            moved[i, c] += 1
            assert ring_keys(moved, np.array([0, 3]))[0] != key
    assert ring_keys(base[:2], np.array([0, 2]))[0] != key
    assert ring_keys(base[[1, 2, 0]], np.array([0, 3]))[0] != key  # rotated


near_limit = st.integers(2**30 - 2**20, 2**30 - 1)


@st.composite
def wound_rings(draw):
    """Rings near the coordinate limit, traversed 1 to 4 times, either way."""
    corners = draw(st.lists(st.tuples(near_limit, near_limit), min_size=3,
                            max_size=6))
    signs = draw(st.lists(st.tuples(st.sampled_from([-1, 1]),
                                    st.sampled_from([-1, 1])),
                          min_size=len(corners), max_size=len(corners)))
    ring = [(sx * x, sy * y) for (x, y), (sx, sy) in zip(corners, signs, strict=True)]
    ring = ring * draw(st.integers(1, 4))
    if draw(st.booleans()):
        ring = ring[::-1]
    return np.array(ring, dtype=np.int64), np.array([0, len(ring)], dtype=np.int64)


@given(wound_rings())
def test_ring_area2_is_exact_or_beyond_int64_near_the_limit(case):
    # audit s24 D6: the int64 sum wrapped, so a clockwise ring wound twice
    # came out with a positive area
    coords, offsets = case
    assert ring_area2(coords, offsets).tolist() == reference.ring_area2(coords, offsets)


def test_ring_area2_of_a_square_wound_twice():
    lim = 2**30 - 1
    square = [[-lim, -lim], [lim, -lim], [lim, lim], [-lim, lim]]
    for ring, expect in [(square, (2 * lim) ** 2 * 2),
                         (square * 2, AREA2_BEYOND_INT64),
                         (square[::-1] * 2, AREA2_BEYOND_INT64)]:
        got = ring_area2(np.array(ring, np.int64), np.array([0, len(ring)], np.int64))
        assert got.tolist() == [expect]
