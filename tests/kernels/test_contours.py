import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference
from strategies import closed_meshes, run_reversed
from vecslice._kernels._jit import run_serial
from vecslice._kernels.contours import round_div_by, trace_contours, vertex_layers
from vecslice._kernels.crossings import crossing_points, face_segments, range_offsets
from vecslice._kernels.loops import link_segments
from vecslice._kernels.rings import group_rings
from vecslice._kernels.topology import edge_topology, half_edge_twins
from vecslice._threads import run_chunks


def chained(v, f, z, out_layer):
    """The step kernels chained, as slice_contours did before trace_contours."""
    fe, ev, twin = edge_topology(f, len(v))
    vl = np.searchsorted(z, v[:, 2], side="left").astype(np.int64)
    eo = range_offsets(vl, ev)
    pts = crossing_points(v, ev, vl, eo, z)
    eb = eo[:-1] - np.minimum(vl[ev[:, 0]], vl[ev[:, 1]])
    fo = range_offsets(vl, f)
    sf, st_, sl, nxt, has_prev = face_segments(f, fe, vl, eb, fo, twin)
    cv, cr, cl, ov, orr, ol = link_segments(nxt, has_prev, sf, st_, sl)
    closed = group_rings(pts, cv, cr, out_layer[cl], len(z))
    chains = group_rings(pts, ov, orr, out_layer[ol], len(z))
    return closed + chains


RUNNERS = {"serial": run_serial, "reversed": run_reversed, "threads": run_chunks}


def traced(v, f, z, out_layer, n_chunks, run="serial", tell_closed=True):
    """trace_contours; ``tell_closed``: say whether every twin exists, as
    vecslice.Mesh does (else it is not said, and the plan reads the twins)."""
    vl = np.searchsorted(z, v[:, 2], side="left").astype(np.int64)
    twin = half_edge_twins(f, len(v))
    closed = tell_closed and bool((twin >= 0).all())
    return trace_contours(v, f, twin, vl, z, out_layer, n_chunks,
                          run=RUNNERS[run], closed=closed)


def break_mesh(f, rng):
    """Flip, delete and duplicate some faces (open, non-manifold, flipped edges)."""
    f = f.copy()
    flip = rng.random(len(f)) < 0.1
    f[flip] = f[flip][:, ::-1]
    keep = rng.random(len(f)) > 0.1
    dup = rng.random(len(f)) < 0.05
    return np.concatenate([f[keep], f[dup]])


@given(closed_meshes(), st.integers(0, 2**32 - 1), st.booleans(),
       st.integers(1, 9), st.sampled_from(sorted(RUNNERS)), st.booleans())
def test_trace_contours_equals_the_chained_kernels(case, seed, broken, n_chunks,
                                                   run, tell_closed):
    v, f, planes = case
    rng = np.random.default_rng(seed)
    if broken:
        f = break_mesh(f, rng)
        if len(f) == 0:
            return
    z = np.sort(np.asarray(planes, dtype=np.int64))
    out_layer = rng.permutation(len(z)).astype(np.int64)
    got = traced(v, f, z, out_layer, n_chunks, run, tell_closed)
    ref = chained(v, f, z, out_layer)
    for a, b in zip(got, ref, strict=True):
        assert a.tolist() == b.tolist()


@pytest.mark.parametrize(("name", "scale"), [
    ("3DBenchy.3mf", 1), ("stanford-bunny.obj", 1000), ("bun_zipper_res2.ply", 1000),
    ("hourglass.stl", 1000), ("openscad-nonmanifold-crash.obj", 1),
    ("plate_holes.STL", 1), ("teapot.stl", 1),
])
def test_trace_contours_equals_the_chained_kernels_on_real_meshes(meshes_dir, name,
                                                                  scale):
    # real meshes made elsewhere, broken ones included (open scans, duplicated and
    # non-manifold faces, flipped winding, open surfaces): the walk that enters
    # each face by its twin's edge, and the open ends, give what the step
    # kernels give, on threads in many chunks
    import vecslice as vs

    mesh = vs.load_mesh(meshes_dir / name, scale=scale)
    v, f = mesh.vertices, mesh.faces
    lo, hi = int(v[:, 2].min()), int(v[:, 2].max())
    z = np.arange(lo - 50, hi + 100, max(1, (hi - lo) // 97), dtype=np.int64)
    out_layer = np.arange(len(z), dtype=np.int64)
    got = traced(v, f, z, out_layer, 7, "threads")
    ref = chained(v, f, z, out_layer)
    assert len(got[0]) > 0
    for a, b in zip(got, ref, strict=True):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("seed", range(6))
def test_trace_contours_finds_starts_anywhere_in_a_block_of_marks(seed):
    # the trace skips a block of faces whose visited marks (one run of bytes when
    # the block lies within the chunk's planes; read 8 at a time) are all set.
    # Shuffled faces of spheres and cylinders put loop starts at every place of
    # such runs (before, on and after whole words); one chunk makes every block
    # lie within it, more chunks leave blocks across the chunks' bounds
    import trimesh

    rng = np.random.default_rng(seed)
    parts = [trimesh.creation.icosphere(subdivisions=3, radius=8.0),
             trimesh.creation.cylinder(radius=5.0, height=14.0, sections=37),
             trimesh.creation.icosphere(subdivisions=2, radius=3.0)]
    v, f = [], []
    for i, m in enumerate(parts):
        f.append(np.asarray(m.faces) + sum(len(x) for x in v))
        shift = np.array([20.0 * i, 0.0, 3.0 * i])
        v.append(np.rint((m.vertices + shift) * 1000))
    v = np.concatenate(v).astype(np.int64)
    f = np.concatenate(f).astype(np.int64)[rng.permutation(sum(len(x) for x in f))]
    z = np.unique(rng.integers(v[:, 2].min() - 5, v[:, 2].max() + 5, 90))
    out_layer = rng.permutation(len(z)).astype(np.int64)
    ref = chained(v, f, z, out_layer)
    assert len(ref[1]) > 100  # loops
    for n_chunks, run in ((1, "serial"), (3, "reversed"), (8, "threads")):
        got = traced(v, f, z, out_layer, n_chunks, run)
        for a, b in zip(got, ref, strict=True):
            assert np.array_equal(a, b)


@given(st.lists(st.integers(-(2**30) + 1, 2**30 - 1), min_size=1, max_size=50),
       st.lists(st.integers(-(2**30) + 1, 2**30 - 1), min_size=0, max_size=12))
def test_vertex_layers_is_searchsorted_left(vz, planes):
    v = np.zeros((len(vz), 3), dtype=np.int64)
    v[:, 2] = vz
    z = np.sort(np.array(planes, dtype=np.int64))
    # exact vertex heights among the planes too
    z = np.sort(np.concatenate([z, v[: len(vz) // 2, 2]]))
    expect = np.searchsorted(z, v[:, 2], side="left")
    assert vertex_layers(v, z).tolist() == expect.tolist()


@given(st.lists(st.integers(-(2**29), 2**29), min_size=0, max_size=6),
       st.integers(-(2**29), 2**29), st.integers(1, 2**20), st.integers(0, 40),
       st.lists(st.integers(-(2**30) + 1, 2**30 - 1), min_size=1, max_size=40),
       st.integers(0, 3))
def test_vertex_layers_of_evenly_spaced_planes_is_searchsorted_left(
        first, start, dz, n_even, vz, pick):
    # a schedule: a few planes of their own (as a first layer), then planes
    # evenly spaced, which vertex_layers counts by a division
    even = start + dz * np.arange(n_even, dtype=np.int64)
    z = np.sort(np.concatenate([np.array(first, dtype=np.int64), even]))
    v = np.zeros((len(vz), 3), dtype=np.int64)
    v[:, 2] = vz
    if len(z):  # vertices on, just above and just below planes too
        k = np.arange(len(vz)) % len(z)
        v[::2, 2] = np.clip(z[k[::2]] + (pick - 1), -(2**30) + 1, 2**30 - 1)
    expect = np.searchsorted(z, v[:, 2], side="left")
    assert vertex_layers(v, z).tolist() == expect.tolist()


@pytest.mark.parametrize(("z", "expect"), [
    ([], (0, 0)), ([7], (1, 0)), ([3, 5], (0, 2)), ([0, 200, 300, 400], (1, 100)),
    ([5, 5, 7, 9], (1, 2)), ([1, 2, 4, 4], (4, 0)), ([0, 10, 20, 25], (2, 5)),
])
def test_even_suffix_finds_the_evenly_spaced_planes(z, expect):
    from vecslice._kernels.contours import _even_suffix

    assert _even_suffix(np.array(z, dtype=np.int64)) == expect


@pytest.mark.parametrize("n_planes", [0, 1, 2, 3, 478, 1000])
def test_vertex_layers_in_chunks_on_threads(n_planes):
    rng = np.random.default_rng(n_planes)
    z = np.sort(rng.integers(-1000, 1000, n_planes)).astype(np.int64)
    v = np.zeros((200_003, 3), dtype=np.int64)
    v[:, 2] = rng.integers(-1100, 1100, v.shape[0])
    expect = np.searchsorted(z, v[:, 2], side="left")
    for run in (run_reversed, run_chunks):
        assert np.array_equal(vertex_layers(v, z, run=run), expect)


def test_plan_blocks_bound_the_planes_of_their_faces():
    # the block summaries let a chunk skip faces: each block's (low, high) must
    # cover the planes of every face in it that crosses any
    import trimesh

    from vecslice._kernels.contours import BLOCK, segment_plan

    m = trimesh.creation.icosphere(4, radius=10_000)
    v = np.rint(m.vertices).astype(np.int64)
    f = m.faces.astype(np.int64)
    z = np.arange(-9_000, 9_001, 700, dtype=np.int64)
    vl = np.searchsorted(z, v[:, 2], side="left").astype(np.int64)
    face_lo, face_offsets, _, _, _, blocks = segment_plan(
        f, half_edge_twins(f, len(v)), vl, len(z))
    n = np.diff(face_offsets)
    assert len(blocks) == -(-len(f) // BLOCK)
    for b in range(len(blocks)):
        sl = slice(b * BLOCK, (b + 1) * BLOCK)
        crossing = n[sl] > 0
        if crossing.any():
            assert blocks[b, 0] == face_lo[sl][crossing].min()
            assert blocks[b, 1] == (face_lo[sl] + n[sl])[crossing].max()
        else:
            assert blocks[b, 0] >= blocks[b, 1]
    # and tracing in many chunks (most blocks skipped by most) changes nothing
    out = np.arange(len(z), dtype=np.int64)
    one = trace_contours(v, f, half_edge_twins(f, len(v)), vl, z, out, 1)
    many = trace_contours(v, f, half_edge_twins(f, len(v)), vl, z, out, 13,
                          run=run_chunks)
    assert all(np.array_equal(a, b) for a, b in zip(one, many))
    assert all(np.array_equal(a, b) for a, b in zip(one, chained(v, f, z, out)))


@given(closed_meshes(), st.integers(0, 2**32 - 1), st.booleans(),
       st.integers(2, 40), st.sampled_from(["reversed", "threads"]))
def test_segment_plan_in_ranges_of_faces_equals_one_range(case, seed, broken,
                                                         n_chunks, run):
    # each range counts its offsets from 0, then moves them up by the ranges
    # before it; planes, blocks and open-end counts add up to the one-range plan
    from vecslice._kernels.contours import segment_plan

    v, f, planes = case
    if broken:
        f = break_mesh(f, np.random.default_rng(seed))
    z = np.sort(np.asarray(planes, dtype=np.int64))
    vl = np.searchsorted(z, v[:, 2], side="left").astype(np.int64)
    twin = half_edge_twins(f, len(v))
    one = segment_plan(f, twin, vl, len(z))
    many = segment_plan(f, twin, vl, len(z), n_chunks, run=RUNNERS[run])
    assert [np.asarray(a).tolist() for a in one] == [
        np.asarray(b).tolist() for b in many]


def test_segment_plan_takes_fewer_ranges_where_planes_are_many(monkeypatch):
    # each range keeps a row of plane counts: their total is capped
    import trimesh

    from vecslice._kernels import contours

    m = trimesh.creation.icosphere(4, radius=10_000)
    v = np.rint(m.vertices).astype(np.int64)
    f = m.faces.astype(np.int64)
    z = np.arange(-9_000, 9_001, 700, dtype=np.int64)
    vl = np.searchsorted(z, v[:, 2], side="left").astype(np.int64)
    twin = half_edge_twins(f, len(v))
    seen = []

    def spy(fn, bounds):
        seen.append(len(bounds) - 1)
        run_serial(fn, bounds)

    one = contours.segment_plan(f, twin, vl, len(z))
    monkeypatch.setattr(contours, "_PLAN_SCRATCH", 3 * (len(z) + 1))
    capped = contours.segment_plan(f, twin, vl, len(z), 16, run=spy)
    assert seen and max(seen) == 3
    assert [np.asarray(a).tolist() for a in one] == [
        np.asarray(b).tolist() for b in capped]


def _exact_round_div_by(d, t, dz):
    return reference.round_div(d * t, dz)


@st.composite
def _quotient_cases(draw):
    """(d, t, dz) in the crossing's range, often next to a tie or an integer."""
    dz = draw(st.one_of(st.integers(1, 2**31 - 1), st.integers(2**31 - 64, 2**31 - 1),
                        st.integers(1, 64)))
    t = draw(st.one_of(st.integers(0, dz - 1), st.just(dz - 1), st.just(0)))
    d = draw(st.integers(-(2**31) + 1, 2**31 - 1))
    if t and draw(st.booleans()):
        # d * t next to a multiple of dz, or of dz / 2: where a double's quotient
        # can floor one off, and the ties
        m = draw(st.integers(-(2**31) + 2, 2**31 - 2))
        half = draw(st.booleans())
        target = m * dz + (dz // 2 if half else 0) + draw(st.integers(-2, 2))
        d = max(-(2**31) + 1, min(2**31 - 1, target // t))
    return d, t, dz


@settings(max_examples=3000, deadline=None)
@given(_quotient_cases())
def test_round_div_by_is_the_exact_rounded_quotient(case):
    d, t, dz = case
    assert round_div_by(d, t, dz, 1.0 / dz) == _exact_round_div_by(d, t, dz)


def test_round_div_by_where_the_double_quotient_floors_one_off():
    # d * t one above or below a multiple of dz (d = ±t^-1 mod dz): the exact
    # quotient is 1/dz from an integer, closer than the double's error, so the
    # double's floor is one off, in both directions; the rounding by the exact
    # remainder must still give the exact result (see round_div_by)
    rng = np.random.default_rng(5)
    low, high = [], []
    while len(low) < 300 or len(high) < 300:
        dz = int(rng.integers(2**30, 2**31))
        t = int(rng.integers(1, dz))
        if math.gcd(t, dz) != 1:
            continue
        inv = pow(t, -1, dz)
        for d in (inv, dz - inv, -inv, inv - dz):
            if abs(d) >= 2**31:
                continue
            n = d * t
            floor_of_double = int(np.floor(float(n) * (1.0 / dz)))
            if floor_of_double < n // dz:
                low.append((d, t, dz))
            elif floor_of_double > n // dz:
                high.append((d, t, dz))
    for d, t, dz in low[:300] + high[:300]:
        assert round_div_by(d, t, dz, 1.0 / dz) == _exact_round_div_by(d, t, dz)


@pytest.mark.parametrize("run", sorted(RUNNERS))
def test_narrow_faces_is_faces_as_int32(run, monkeypatch):
    from vecslice._kernels import contours

    monkeypatch.setattr(contours, "_NARROW_CHUNK", 7)  # many chunks
    f = np.random.default_rng(5).integers(0, 2**31 - 1, size=(100, 3))
    f32 = contours.narrow_faces(f, run=RUNNERS[run])
    assert f32.dtype == np.int32 and f32.flags.c_contiguous
    assert f32.tolist() == f.tolist()
    assert contours.narrow_faces(f32, run=RUNNERS[run]) is f32
    assert contours.narrow_faces(f[:0], run=RUNNERS[run]).shape == (0, 3)
