import pickle
from copy import deepcopy

import numba
import numpy as np
import pytest
import reference_stitch_quadratic
import trimesh
from hypothesis import given
from hypothesis import strategies as st

import reference_stitch
import vecslice as vs
from vecslice.errors import InputTypeError, SettingsError
from vecslice.paths import LayerPaths
from vecslice.stitch import Stitched, stitch

# the large inputs take minutes when kernels run as plain Python (coverage runs)
needs_jit = pytest.mark.skipif(numba.config.DISABLE_JIT,
                               reason="NUMBA_DISABLE_JIT=1: too slow as plain Python")


def _layer_paths(layers, open=None):
    pts, ro, lo = [], [0], [0]
    for rings in layers:
        for r in rings:
            pts.extend(r)
            ro.append(len(pts))
        lo.append(len(ro) - 1)
    return LayerPaths(np.array(pts, dtype=np.int64).reshape(-1, 2), ro, lo, open=open)


def _as_lists(lp):
    return [[[tuple(map(int, p)) for p in r] for r in lp.layer(k)]
            for k in range(lp.n_layers)]


def _check_valid(lp):
    # re-validating the arrays must succeed and give the same rings
    again = LayerPaths(lp.coords, lp.ring_offsets, lp.layer_offsets)
    assert _as_lists(again) == _as_lists(lp)
    assert not lp.coords.flags.writeable and not lp.ring_offsets.flags.writeable


ring = st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50)),
                min_size=0, max_size=5)


@st.composite
def layered(draw):
    n = draw(st.integers(1, 4))
    closed = [draw(st.lists(ring.filter(len), max_size=3)) for _ in range(n)]
    chains = [draw(st.lists(ring, max_size=8)) for _ in range(n)]
    return closed, chains


@given(layered(), st.sampled_from([(20, 10_000), (0, 30), (5, 0)]))
def test_new_loops_follow_the_input_loops_per_layer(case, gaps):
    closed, chains = case
    raw = _layer_paths(closed, open=_layer_paths(chains))
    loops, counts = stitch(raw, max_gap_in_order=gaps[0], max_gap=gaps[1])
    ref = [reference_stitch.stitch_layer(c, *gaps) for c in chains]
    assert _as_lists(loops) == [c + r[0] for c, r in zip(closed, ref, strict=True)]
    assert _as_lists(loops.open) == [r[1] for r in ref]
    assert counts.tolist() == [r[2] for r in ref]
    assert counts.dtype == np.int64
    _check_valid(loops)
    _check_valid(loops.open)
    assert loops.open.open is None


def test_result_is_a_named_tuple():
    chains = _layer_paths([[[(0, 0), (9, 0), (9, 9)], [(0, 9), (0, 1)]]])
    res = stitch(_layer_paths([[]], open=chains))
    assert isinstance(res, Stitched) and res.loops is res[0]
    assert res.gaps_stitched.tolist() == [2]
    # gap 1 (chain 1 to chain 0) is joined first, so chain 1 leads the loop
    assert _as_lists(res.loops) == [[[(0, 9), (0, 1), (0, 0), (9, 0), (9, 9)]]]


def test_no_open_chains_returns_the_loops():
    closed = [[[(0, 0), (10, 0), (0, 10)]], []]
    raw = _layer_paths(closed)  # .open is None
    loops, counts = stitch(raw)
    assert _as_lists(loops) == closed and counts.tolist() == [0, 0]
    assert loops.open is not None and loops.open.n_layers == 2
    assert loops.open.n_rings == 0


def test_open_box_side_is_closed():
    # a 9 mm box without its +x side: every layer is one open chain, gap 9 mm
    m = trimesh.creation.box((9, 9, 9))
    keep = ~np.isclose(m.face_normals[:, 0], 1)
    broken = vs.load_mesh(trimesh.Trimesh(m.vertices, m.faces[keep], process=False))
    whole = vs.load_mesh(m)
    z = [-4000, 0, 3000]
    raw = vs.slice_contours(broken, z, stitch=False)
    assert raw.open.rings_per_layer().tolist() == [1, 1, 1]
    # slice_contours stitches by default, with the same result
    stitched = vs.slice_contours(broken, z)
    assert stitched.open.n_rings == 0
    assert stitched.layer_area2().tolist() == stitch(raw).loops.layer_area2().tolist()
    loops, counts = stitch(raw)
    assert counts.tolist() == [1, 1, 1] and loops.open.n_rings == 0
    ref = vs.slice_contours(whole, z)
    assert loops.layer_area2().tolist() == ref.layer_area2().tolist()
    # with round 2 limited below the 9 mm gap, the chains stay open
    loops, counts = stitch(raw, max_gap=9_000)
    assert counts.tolist() == [0, 0, 0] and loops.open.n_rings == 3


def test_huge_gap_is_accepted():
    chains = _layer_paths([[[(-(2**29), 0), (0, 5)], [(2**29, 0), (0, -5)]]])
    loops, counts = stitch(_layer_paths([[]], open=chains), max_gap=10**30)
    assert counts.tolist() == [2] and loops.n_rings == 1


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"max_gap": -1}, SettingsError, "`max_gap` must be >= 0; got -1"),
        ({"max_gap_in_order": -20}, SettingsError, "`max_gap_in_order` must be >= 0"),
        ({"max_gap": 1.5}, InputTypeError, "`max_gap` must be an integer"),
        ({"max_gap_in_order": "20"}, InputTypeError, "`max_gap_in_order`"),
        ({"max_gap": True}, InputTypeError, "`max_gap`"),
        ({"max_gap": None}, InputTypeError, "`max_gap`"),
    ],
)
def test_bad_gaps(kwargs, error, match):
    raw = _layer_paths([[]], open=_layer_paths([[]]))
    with pytest.raises(error, match=match):
        stitch(raw, **kwargs)


def test_float_gap_with_integer_value_is_accepted():
    raw = _layer_paths([[]], open=_layer_paths([[[(0, 0), (5, 0)]]]))
    assert stitch(raw, max_gap=20.0, max_gap_in_order=0).gaps_stitched.tolist() == [1]


@pytest.mark.parametrize("bad", [None, [[0, 0]], "loops"])
def test_bad_loops(bad):
    with pytest.raises(InputTypeError, match=r"`loops` must be a vecslice\.LayerPaths"):
        stitch(bad)


# ---------------------------------------------------------------- triangle soups

def _soup(n, seed=0, size=10_000, edge=1_000):
    """``n`` random triangles (corners within ``edge`` µm) in a 10 mm cube."""
    rng = np.random.default_rng(seed)
    corner = rng.integers(0, size, (n, 1, 3))
    v = (corner + rng.integers(-edge // 2, edge // 2 + 1, (n, 3, 3))).reshape(-1, 3)
    return vs.Mesh.from_arrays(v, np.arange(3 * n).reshape(n, 3))


def _soup_raw(n):
    mesh = _soup(n)
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings())
    raw = vs.slice_contours(mesh, z, stitch=False)
    assert raw.n_rings == 0  # every triangle gives open chains only
    return raw


def _quadratic(chains):
    """Per layer (new loops, open chains, joins) by the pre-issue-8 kernel."""
    cc, cr, cl, oc, orr, ol, n = reference_stitch_quadratic.stitch_chains(
        chains.coords, chains.ring_offsets, chains.layer_offsets, 20, 10_000
    )
    loops, still_open = LayerPaths(cc, cr, cl), LayerPaths(oc, orr, ol)
    return [(loops.layer(k), still_open.layer(k), int(n[k]))
            for k in range(chains.n_layers)]


def _same_layer(got, want):
    assert got[2] == want[2]
    for a, b in zip(got[:2], want[:2], strict=True):
        assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


@needs_jit
def test_triangle_soup_matches_quadratic_kernel():
    raw = _soup_raw(2_000)
    assert raw.open.rings_per_layer().max() > 100
    loops, counts = stitch(raw)
    want = _quadratic(raw.open)
    for k in range(raw.n_layers):
        _same_layer((loops.layer(k), loops.open.layer(k), int(counts[k])), want[k])


@needs_jit
def test_20k_triangle_soup_is_stitched_as_the_quadratic_kernel_does():
    # issue 8 A3: this took minutes (thousands of chain ends within the 10 mm gap,
    # all pairs listed). Layers are stitched independently, so the quadratic
    # kernel checks the crowded layers alone (it takes seconds per layer).
    raw = _soup_raw(20_000)
    per_layer = raw.open.rings_per_layer()
    assert per_layer.sum() > 90_000 and per_layer.max() > 1_000
    loops, counts = stitch(raw)
    assert counts.sum() > 90_000 and (counts <= per_layer).all()
    crowded = sorted({int(np.argmax(per_layer)), len(per_layer) // 3})
    subset = _layer_paths([[list(map(tuple, r)) for r in raw.open.layer(k)]
                           for k in crowded])
    for k, want in zip(crowded, _quadratic(subset), strict=True):
        _same_layer((loops.layer(k), loops.open.layer(k), int(counts[k])), want)


@pytest.mark.parametrize("copy", [lambda r: pickle.loads(pickle.dumps(r)),
                                  deepcopy])
def test_copied_result_keeps_its_counts_read_only(copy):
    # audit s35: a pickled or deep-copied Stitched (a NamedTuple) came back with
    # a writeable gaps_stitched, while every container stays frozen
    chains = _layer_paths([[[(0, 0), (9, 0), (9, 9)], [(0, 9), (0, 1)]]])
    res = stitch(_layer_paths([[]], open=chains))
    back = copy(res)
    assert isinstance(back, Stitched)
    assert back.gaps_stitched.tolist() == res.gaps_stitched.tolist() == [2]
    assert not back.gaps_stitched.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        back.gaps_stitched[0] = 5
    assert back.loops.n_rings == res.loops.n_rings == 1
