import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import reference
from vecslice._kernels.rings import group_rings, ring_area2, take_rings

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
