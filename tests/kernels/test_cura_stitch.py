"""CuraEngine's chain joining (kernels/cura_stitch.py, kernels/cura_polylines.py)."""

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference_cura as ref
from vecslice._kernels.cura_polylines import stitch_open_polylines
from vecslice._kernels.cura_stitch import connect_open_polylines

# the large inputs take minutes when kernels run as plain Python (coverage runs)
needs_jit = pytest.mark.skipif(numba.config.DISABLE_JIT,
                               reason="NUMBA_DISABLE_JIT=1: too slow as plain Python")

ROUNDS = np.array([[20, 20, 0], [10_000, 10_000, 1]], dtype=np.int64)


def _pack(layers):
    pts, ro, lo = [], [0], [0]
    for chains in layers:
        for c in chains:
            pts.extend(c)
            ro.append(len(pts))
        lo.append(len(ro) - 1)
    coords = np.array(pts, dtype=np.int64).reshape(-1, 2)
    return coords, np.array(ro, dtype=np.int64), np.array(lo, dtype=np.int64)


def _unpack(coords, ring_offsets, layer_offsets):
    return [
        [[tuple(map(int, p)) for p in coords[ring_offsets[i] : ring_offsets[i + 1]]]
         for i in range(layer_offsets[k], layer_offsets[k + 1])]
        for k in range(len(layer_offsets) - 1)
    ]


def _check_offsets(*pairs):
    for offs, below in pairs:
        assert offs[0] == 0 and offs[-1] == below and (np.diff(offs) >= 0).all()


# chains whose ends fall on a coarse grid (many exact ties) or anywhere nearby
POINT = st.one_of(
    st.tuples(st.integers(0, 6).map(lambda v: 7 * v), st.integers(0, 6).map(
        lambda v: 7 * v)),
    st.tuples(st.integers(0, 5).map(lambda v: 350 * v), st.integers(0, 5).map(
        lambda v: 350 * v)),
    st.tuples(st.integers(-30_000, 30_000), st.integers(-30_000, 30_000)),
)
CHAIN = st.lists(POINT, min_size=1, max_size=5)
LAYERS = st.lists(st.lists(CHAIN, max_size=9), min_size=1, max_size=3)


@given(LAYERS)
def test_connect_open_polylines_matches_reference(layers):
    coords, ro, lo = _pack(layers)
    cc, cr, cl, oc, orr, ol, n = connect_open_polylines(coords, ro, lo, ROUNDS)
    _check_offsets((cr, len(cc)), (orr, len(oc)), (cl, len(cr) - 1),
                   (ol, len(orr) - 1))
    closed, still_open = _unpack(cc, cr, cl), _unpack(oc, orr, ol)
    for k, chains in enumerate(layers):
        polylines = [list(c) for c in chains]
        want = ref.connect_open_polylines(polylines, 20, False)
        want += ref.connect_open_polylines(polylines, 10_000, True)
        assert closed[k] == want
        assert still_open[k] == [p for p in polylines if p]
    assert (n >= 0).all()


def test_connect_keeps_both_joint_points_and_reverses_the_smaller():
    # round 1: 0's end meets 1's start 3 µm away (in order, both points kept);
    # round 2: ends of the joined chain and of chain 2 meet: 2 (smaller) reversed;
    # the joined chain's own end-to-start gap (about 2 mm) comes later and is gone
    layers = [[[(0, 0), (1000, 0)], [(1003, 0), (2000, 0), (2000, 500)],
               [(0, 50000), (2000, 505)]]]
    coords, ro, lo = _pack(layers)
    cc, cr, cl, oc, orr, ol, n = connect_open_polylines(coords, ro, lo, ROUNDS)
    assert _unpack(cc, cr, cl) == [[]]
    assert _unpack(oc, orr, ol) == [[[(0, 0), (1000, 0), (1003, 0), (2000, 0),
                                      (2000, 500), (2000, 505), (0, 50000)]]]
    assert n.tolist() == [2]


def test_connect_closes_a_chain_on_itself():
    square = [(0, 0), (1000, 0), (1000, 1000), (0, 1000), (0, 15)]
    coords, ro, lo = _pack([[square]])
    cc, cr, cl, oc, orr, ol, n = connect_open_polylines(coords, ro, lo, ROUNDS)
    # closed in round 1 (gap 15 < 20); no closing point is added
    assert _unpack(cc, cr, cl) == [[square]] and orr.tolist() == [0]
    assert n.tolist() == [1]


LINES = st.lists(st.lists(st.lists(POINT, min_size=1, max_size=5), max_size=8),
                 min_size=1, max_size=3)


@given(LINES, st.sampled_from([400, 10, 1000]))
def test_open_polyline_stitcher_matches_reference(layers, reach):
    coords, ro, lo = _pack(layers)
    cc, cr, cl, oc, orr, ol = stitch_open_polylines(coords, ro, lo, reach, 10)
    _check_offsets((cr, len(cc)), (orr, len(oc)), (cl, len(cr) - 1),
                   (ol, len(orr) - 1))
    closed, still_open = _unpack(cc, cr, cl), _unpack(oc, orr, ol)
    for k, lines in enumerate(layers):
        want_closed, want_open = ref.open_polyline_stitcher(lines, reach, 10)
        assert closed[k] == want_closed
        assert still_open[k] == want_open


def test_open_polyline_stitcher_closes_long_chains_only():
    # three sides of a 1 mm square and a gap of 5 µm back to the start: length
    # 3000 + 5 >= 3 * 400 and > 2 points: closed
    lines = [[(0, 0), (1000, 0), (1000, 1000)], [(1000, 1000), (0, 1000), (0, 5)]]
    coords, ro, lo = _pack([lines])
    cc, cr, cl, oc, orr, ol = stitch_open_polylines(coords, ro, lo, 400, 10)
    # the second line's first point is dropped (gap 0 < 10)
    assert _unpack(cc, cr, cl) == [[[(0, 0), (1000, 0), (1000, 1000), (0, 1000),
                                     (0, 5)]]]
    # a 100 µm square: 300 + 5 < 1200, never closed
    small = [[(0, 0), (100, 0), (100, 100)], [(100, 100), (0, 100), (0, 5)]]
    coords, ro, lo = _pack([small])
    cc, cr, cl, oc, orr, ol = stitch_open_polylines(coords, ro, lo, 400, 10)
    assert cr.tolist() == [0] and len(orr) == 2


@given(st.lists(st.lists(st.tuples(
    st.sampled_from([-(2**30) + 1, -(2**30) + 12, 2**30 - 1, 2**30 - 9]),
    st.sampled_from([-(2**30) + 1, -(2**30) + 5, 2**30 - 1, 2**30 - 400])),
    min_size=1, max_size=4), max_size=6))
def test_joining_near_the_coordinate_limit(chains):
    # grid keys stay in int64 for |coords| < 2**30 (cell size 20, 400, 10000)
    coords, ro, lo = _pack([chains])
    cc, cr, cl, oc, orr, ol, _ = connect_open_polylines(coords, ro, lo, ROUNDS)
    polylines = [list(c) for c in chains]
    want = ref.connect_open_polylines(polylines, 20, False)
    want += ref.connect_open_polylines(polylines, 10_000, True)
    assert _unpack(cc, cr, cl) == [want]
    assert _unpack(oc, orr, ol) == [[p for p in polylines if p]]
    cc, cr, cl, oc, orr, ol = stitch_open_polylines(coords, ro, lo, 400, 10)
    want_closed, want_open = ref.open_polyline_stitcher(chains, 400, 10)
    assert _unpack(cc, cr, cl) == [want_closed]
    assert _unpack(oc, orr, ol) == [want_open]


# ------------------------------------------- crowded ends (issue 8 A3)

def _same_as_quadratic(coords, ro, lo):
    """Kernel outputs, checked array by array against the pre-issue-8 kernel."""
    import reference_stitch_cura_quadratic as quadratic

    out = connect_open_polylines(coords, ro, lo, ROUNDS)
    want = quadratic.connect_open_polylines(coords, ro, lo, ROUNDS)
    for a, b in zip(out, want, strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    return out


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1, 3, 30, 3000]))
def test_crowded_ends_match_reference_and_quadratic_kernel(seed, span):
    # up to 60 chains with all ends within one gap, on small lattices (ties)
    rng = np.random.default_rng(seed)
    layers = []
    for _ in range(2):
        chains = []
        for _ in range(int(rng.integers(0, 60))):
            c = rng.integers(0, span + 1, (int(rng.integers(1, 5)), 2))
            chains.append([tuple(map(int, p)) for p in c])
        layers.append(chains)
    coords, ro, lo = _pack(layers)
    cc, cr, cl, oc, orr, ol, _ = _same_as_quadratic(coords, ro, lo)
    for k, chains in enumerate(layers):
        polylines = [list(c) for c in chains]
        want = ref.connect_open_polylines(polylines, 20, False)
        want += ref.connect_open_polylines(polylines, 10_000, True)
        assert _unpack(cc, cr, cl)[k] == want
        assert _unpack(oc, orr, ol)[k] == [p for p in polylines if p]


@needs_jit
def test_thousands_of_ends_within_one_gap_match_quadratic_kernel():
    # 1,200 random segments in a 5 mm square (2,400 ends, 2.9 M possible
    # stitches within 10 mm), and 600 on a 3 x 3 lattice
    rng = np.random.default_rng(3)
    layers = [
        [[tuple(map(int, p)) for p in rng.integers(0, 5_000, (2, 2))]
         for _ in range(1_200)],
        [[tuple(map(int, p)) for p in rng.integers(0, 3, (2, 2))]
         for _ in range(600)],
    ]
    *_, n = _same_as_quadratic(*_pack(layers))
    assert n.tolist()[0] > 1_000


@needs_jit
def test_coincident_ends_need_no_candidate_list():
    # 100,000 one-vertex chains at one point: 10**10 possible stitches, all of
    # which the old kernel listed (MemoryError). Smallest (gap², t0, t1) first:
    # each polyline's end meets its own start, in index order.
    n = 100_000
    coords = np.zeros((n, 2), dtype=np.int64)
    ro = np.arange(n + 1, dtype=np.int64)
    lo = np.array([0, n], dtype=np.int64)
    cc, cr, cl, oc, orr, ol, cnt = connect_open_polylines(coords, ro, lo, ROUNDS)
    assert (cc == 0).all() and cr.tolist() == list(range(n + 1))
    assert cl.tolist() == [0, n] and len(oc) == 0 and cnt.tolist() == [n]
    small = [[[(0, 0)] for _ in range(5)]]
    polylines = [list(c) for c in small[0]]
    assert _unpack(*connect_open_polylines(*_pack(small), ROUNDS)[:3]) == [
        ref.connect_open_polylines(polylines, 20, False)
    ]
