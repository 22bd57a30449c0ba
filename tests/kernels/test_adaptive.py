import math
import re

import numba
import numpy as np
import pytest
import reference_adaptive as ref
from hypothesis import given
from hypothesis import strategies as st

from vecslice._kernels.adaptive import (
    TAU,
    adaptive_layers,
    face_slopes,
    face_slopes_range,
    zmin_order,
)


def _hex(values):
    return ["nan" if math.isnan(x) else float(x).hex() for x in values]


def _sloped(vertices, faces, dz):
    shifted = [[int(x), int(y), int(z) - dz] for x, y, z in vertices]
    return ref.face_data(shifted, faces.tolist())


# --- per-face data -----------------------------------------------------------------

big = st.integers(-(2**30) + 1, 2**30 - 1)
grid = st.integers(-4, 4).map(lambda k: 250 * k)  # ties, flat and vertical faces
small = st.integers(-3000, 3000)


@st.composite
def triangles(draw):
    coord = draw(st.sampled_from([big, grid, small]))
    n_v = draw(st.integers(3, 9))
    verts = np.array(draw(st.lists(st.tuples(coord, coord, coord), min_size=n_v,
                                   max_size=n_v)), dtype=np.int64)
    idx = st.integers(0, n_v - 1)
    faces = np.array(draw(st.lists(st.tuples(idx, idx, idx), min_size=1,
                                   max_size=12)), dtype=np.int64)
    lo = int(verts[:, 2].min())
    dz = draw(st.sampled_from([0, lo, lo - 1, 7]))
    return verts, faces, dz


@given(triangles())
def test_face_slopes_match_reference_bit_for_bit(case):
    verts, faces, dz = case
    face_z, slope = face_slopes(verts, faces, dz)
    zmin, zmax, want = _sloped(verts, faces, dz)
    assert face_z[:, 0].tolist() == zmin
    assert face_z[:, 1].tolist() == zmax
    assert _hex(slope) == _hex(want)


def test_face_slopes_at_the_spec_tie_points():
    verts = np.array([[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 1000],
                      [2000, 0, 0], [0, 0, 2000], [3000, 0, 0]], dtype=np.int64)
    faces = np.array([
        [0, 1, 2],  # horizontal: pi exactly
        [0, 1, 3],  # vertical: pi/2
        [0, 3, 1],  # vertical, reversed winding
        [0, 2, 5],  # vertical
        [0, 1, 4],  # collinear corners: zero area, NaN
        [0, 0, 3],  # two equal corners: NaN
        [1, 5, 6],  # all corners at y = 0: vertical
    ], dtype=np.int64)
    face_z, slope = face_slopes(verts, faces, 0)
    assert slope[0] == math.pi
    assert slope[1] == slope[2] == slope[3] == slope[6] == 1.5707963267948966
    assert math.isnan(slope[4]) and math.isnan(slope[5])
    assert face_z.tolist() == [[0, 0], [0, 1000], [0, 1000], [0, 2000], [0, 0],
                               [0, 1000], [0, 2000]]
    # a 45 degree face: acos gives 0x1.921fb54442d19p-1, the wrap rounds it down
    wedge = np.array([[0, 0, 0], [0, 1000, 0], [1000, 0, 1000]], dtype=np.int64)
    _, s45 = face_slopes(wedge, np.array([[0, 1, 2]], dtype=np.int64), 0)
    assert s45[0].hex() == "0x1.921fb54442d18p-1"
    assert math.acos(0.7071067811865475).hex() == "0x1.921fb54442d19p-1"


@given(st.one_of(
    st.floats(0.0, math.pi / 2),
    st.floats(0.0, 1.0).map(math.acos),
    st.sampled_from([0.0, 5e-324, 1.49e-8, math.pi / 4, math.pi / 2, 2.0**-50]),
))
def test_wrap_shortcut_is_cura_fmod(a):
    # face_slopes writes CuraEngine's fmod(fmod(a, TAU) + TAU, TAU) as
    # (a + TAU) - TAU, exact for a in [0, pi/2] (Sterbenz); both give the same bits
    assert ((a + TAU) - TAU).hex() == math.fmod(math.fmod(a, TAU) + TAU, TAU).hex()


@given(st.lists(st.integers(-2000, 2000), min_size=1, max_size=40),
       st.sampled_from([0, 10**6, -(2**40)]))
def test_zmin_order_is_a_stable_sort(values, spread):
    # a wide spread takes the merge sort, a narrow one the counting sort
    z = np.array([*values, spread][: len(values) + (spread != 0)], dtype=np.int64)
    assert zmin_order(z).tolist() == np.argsort(z, kind="stable").tolist()


def _fresh_asm(kernel):
    sig = kernel.declared_signature
    fresh = numba.njit(sig, nogil=True)(kernel.py_func)  # cached code has no asm
    return fresh.inspect_asm(sig.args)


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="no machine code without JIT")
@pytest.mark.parametrize("kernel", [face_slopes, adaptive_layers])
def test_no_fused_multiply_add_and_no_vector_math_library(kernel):
    # bit-exactness needs every a*b - c*d rounded twice (no FMA contraction) and
    # the scalar libm acos/tan (no SVML): check the machine code numba emits here
    asm = _fresh_asm(kernel)
    assert re.search(r"\bv?(mul|div)sd\b", asm)  # the scalar double code is there
    assert not re.search(r"\bv?f(n)?m(add|sub)\w*", asm)
    assert "svml" not in asm.lower()


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="no machine code without JIT")
def test_the_range_kernel_has_no_fused_multiply_add_either():
    # the library runs face_slopes_range on chunks of faces: the same check
    asm = _fresh_asm(face_slopes_range)
    assert re.search(r"\bv?(mul|div)sd\b", asm)
    assert not re.search(r"\bv?f(n)?m(add|sub)\w*", asm)
    assert "svml" not in asm.lower()


@given(triangles(), st.data())
def test_face_slopes_range_in_any_chunks_equals_face_slopes(case, data):
    verts, faces, dz = case
    n = len(faces)
    cuts = sorted(data.draw(st.lists(st.integers(0, n), max_size=4)))
    bounds = [0, *cuts, n]
    face_z = np.full((n, 2), -7, dtype=np.int64)
    slope = np.full(n, -7.0)
    for f0, f1 in reversed(list(zip(bounds[:-1], bounds[1:], strict=True))):
        face_slopes_range(verts, faces, dz, f0, f1, face_z, slope)
    want_z, want_slope = face_slopes(verts, faces, dz)
    assert face_z.tolist() == want_z.tolist()
    assert slope.tobytes() == want_slope.tobytes()  # bit for bit, NaNs included


# --- the layer loop ----------------------------------------------------------------

SLOPE_1IN2 = ref.face_slope((0, 0, 0), (0, 1000, 0), (2000, 0, 1000))  # tan == 0.5
SLOPES = [math.pi, math.nan, 1.5707963267948966, 0.7853981633974483, SLOPE_1IN2,
          math.atan(0.2), 1.49e-8, 0.3, 1.2]


@st.composite
def face_tables(draw):
    n = draw(st.integers(1, 12))
    # a 10 µm grid makes faces start and end exactly at layer boundaries
    z = draw(st.sampled_from([st.integers(-300, 1800),
                              st.integers(-30, 180).map(lambda k: 10 * k)]))
    pairs = draw(st.lists(st.tuples(z, z), min_size=n, max_size=n))
    face_z = np.sort(np.array(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    slope = np.array(draw(st.lists(
        st.one_of(st.sampled_from(SLOPES), st.floats(1e-9, math.pi / 2)),
        min_size=n, max_size=n)))
    base = draw(st.integers(1, 250))
    variation = draw(st.integers(0, 150))
    step = draw(st.integers(max(1, -(-2 * variation // 40)), 80))
    heights = ref.allowed_heights(base, variation, step)
    # exact ties: h / tan(SLOPE_1IN2) == 2 h
    tie = st.sampled_from(heights).map(lambda h: 2 * h)
    return dict(
        face_z=face_z, slope=slope, first=draw(st.integers(1, 400)),
        heights=heights, step=step,
        threshold=draw(st.one_of(st.integers(-100, 500), tie)),
        tolerance=draw(st.sampled_from(["middle", "inclusive", "exclusive"])),
    )


def _run_kernel(c):
    order = np.argsort(c["face_z"][:, 0], kind="stable")
    h = c["heights"]
    return adaptive_layers(
        np.ascontiguousarray(c["face_z"][order]), c["slope"][order], c["first"],
        h[0], h[-1], c["step"], c["threshold"], c["tolerance"] == "middle",
        c.get("max_layers", 10**9),
    )


def _run_reference(c):
    fz = c["face_z"]
    return ref.layer_loop(
        fz[:, 0].tolist(), fz[:, 1].tolist(), c["slope"].tolist(), int(fz[:, 1].max()),
        first=c["first"], heights=c["heights"], step=c["step"],
        threshold=c["threshold"], tolerance=c["tolerance"],
    )


@given(face_tables())
def test_layer_loop_matches_reference(c):
    thickness, top = _run_kernel(c)
    want = _run_reference(c)
    assert list(zip(thickness.tolist(), top.tolist(), strict=True)) == want


@given(face_tables(), st.permutations(range(12)))
def test_face_order_does_not_matter(c, perm):
    # only a NaN-ignoring minimum is taken, so ties in zmin may come in any order
    p = [i for i in perm if i < len(c["slope"])]
    shuffled = dict(c, face_z=c["face_z"][p], slope=c["slope"][p])
    a, b = _run_kernel(c), _run_kernel(shuffled)
    assert a[0].tolist() == b[0].tolist() and a[1].tolist() == b[1].tolist()


@given(face_tables())
def test_layer_loop_invariants(c):
    thickness, top = _run_kernel(c)
    h, step = c["heights"], c["step"]
    assert thickness[0] == top[0] == c["first"]
    assert len(top) >= 2
    assert (np.cumsum(thickness) == top).all()
    assert set(thickness[1:].tolist()) <= set(h)
    # at most one step thicker than the layer below, unless it is the thinnest
    up = np.diff(thickness)
    assert ((up <= step) | (thickness[1:] == h[-1])).all()
    # the last layer ends above the highest face; the one before does not
    assert top[-1] > c["face_z"][:, 1].max()
    assert len(top) == 2 or top[-2] <= c["face_z"][:, 1].max()


@given(face_tables(), st.integers(10**4, 10**9))
def test_a_face_far_below_the_bed_counts_like_any_other(c, depth):
    # a zmin spread beyond the counting sort's range takes the other sort
    c["face_z"] = np.vstack([c["face_z"], [[-depth, -depth + 5]]])
    c["slope"] = np.append(c["slope"], 0.1)
    thickness, top = _run_kernel(c)
    assert list(zip(thickness.tolist(), top.tolist(), strict=True)) == (
        _run_reference(c))


@given(face_tables(), st.integers(1, 30))
def test_layer_loop_stops_one_layer_past_max_layers(c, max_layers):
    full = _run_reference(c)
    thickness, top = _run_kernel(dict(c, max_layers=max_layers))
    got = list(zip(thickness.tolist(), top.tolist(), strict=True))
    assert got == full[: max_layers + 1]


def test_layer_buffer_grows_past_its_first_allocation():
    # a 5 mm vertical wall with threshold 0: 10 µm layers only (spec Q5)
    face_z = np.array([[0, 5000]], dtype=np.int64)
    thickness, top = adaptive_layers(face_z, np.array([math.pi / 2]), 300, 200, 10,
                                     10, 0, True, 10**6)
    # forced down from layer 0, then two steps thinner per layer, then 10 µm
    assert thickness[:11].tolist() == [300, *range(200, 19, -20)]
    assert top[10] == 1400 and (thickness[11:] == 10).all() and top[-1] == 5010
    assert len(top) == 11 + 361
