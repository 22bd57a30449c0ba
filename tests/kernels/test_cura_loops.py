"""CuraEngine's chaining of segments into loops (kernels/cura_loops.py)."""

import numba
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_cura as ref
from vecslice._kernels.cura_loops import basic_loops, emit_rings, hub_index
from vecslice._kernels.cura_segments import order_by_layer

needs_jit = pytest.mark.skipif(numba.config.DISABLE_JIT,
                               reason="NUMBA_DISABLE_JIT=1: too slow as plain Python")


def _arrays(n_layers, faces, slots, n_vertices):
    """Kernel inputs from per-face plane ranges and per-slot segments.

    ``faces[f]`` = (3 vertices, first plane); ``slots[f]`` = one entry per plane
    from the first: None (no segment) or (start, end, other face or -1, end
    vertex or -1). Returns the kernel arguments and, per plane, the reference's
    segment dicts (faces in order) and the faces around every vertex.
    """
    face_lo = np.array([lo for _, lo in faces], dtype=np.int64)
    slot_offsets = np.zeros(len(faces) + 1, dtype=np.int64)
    slot_offsets[1:] = np.cumsum([len(s) for s in slots])
    valid = np.array([x is not None for s in slots for x in s], dtype=np.bool_)
    layer_offsets, slot_seg = order_by_layer(valid, face_lo, slot_offsets, n_layers)

    def seg_of(f, k):
        i = k - face_lo[f]
        if f < 0 or i < 0 or i >= len(slots[f]):
            return -1
        return int(slot_seg[slot_offsets[f] + i])

    n_seg = int(layer_offsets[-1])
    points = np.zeros((n_seg, 4), dtype=np.int64)
    links = np.zeros((n_seg, 2), dtype=np.int64)
    per_plane = [[] for _ in range(n_layers)]
    for f, ((_, lo), s) in enumerate(zip(faces, slots, strict=True)):
        for i, x in enumerate(s):
            if x is None:
                continue
            start, end, other, vertex = x
            t = seg_of(f, lo + i)
            points[t] = (*start, *end)
            links[t] = (seg_of(other, lo + i), vertex)
            per_plane[lo + i].append({"start": start, "end": end, "face": f,
                                      "other": other,
                                      "vertex": None if vertex < 0 else vertex})
    vf = [[] for _ in range(n_vertices)]
    for f, (vs, _) in enumerate(faces):
        for v in vs:
            vf[v].append(f)
    vf_offsets = np.zeros(n_vertices + 1, dtype=np.int64)
    vf_offsets[1:] = np.cumsum([len(x) for x in vf])
    vf_faces = np.array([f for x in vf for f in x], dtype=np.int64)
    args = (points, links, layer_offsets, face_lo, slot_offsets, slot_seg, vf_offsets,
            vf_faces)
    return args, per_plane, vf


def _rings(coords, ring_offsets, layer_offsets):
    return [
        [[tuple(map(int, p)) for p in coords[ring_offsets[i] : ring_offsets[i + 1]]]
         for i in range(layer_offsets[k], layer_offsets[k + 1])]
        for k in range(len(layer_offsets) - 1)
    ]


def _run(args, run=None):
    points, layer_offsets = args[0], args[2]
    kw = {} if run is None else {"run": run}
    seg_order, ring_start, closed = basic_loops(*args, **kw)
    lc, lr, ll, cc, cr, cl = emit_rings(points, seg_order, ring_start, closed,
                                        layer_offsets)
    return seg_order, _rings(lc, lr, ll), _rings(cc, cr, cl)


# starts and ends near one another: on a 5 µm grid (distances of exactly 10 µm,
# the largest gap CuraEngine bridges, and just beyond), in a small cluster, or
# anywhere
POINT = st.one_of(
    st.tuples(st.integers(0, 3).map(lambda v: 5 * v), st.integers(0, 3).map(
        lambda v: 5 * v)),
    st.tuples(st.integers(-6, 6), st.integers(-6, 6)),
    st.tuples(st.integers(-1000, 1000), st.integers(-1000, 1000)),
)


@st.composite
def planes(draw, max_layers=3, max_vertices=6, max_faces=24, near=POINT):
    n_layers = draw(st.integers(1, max_layers))
    n_vertices = draw(st.integers(3, max_vertices))
    n_faces = draw(st.integers(1, max_faces))
    faces, slots = [], []
    for _ in range(n_faces):
        vs = draw(st.permutations(range(n_vertices)))[:3]
        lo = draw(st.integers(0, n_layers - 1))
        n = draw(st.integers(0, n_layers - lo))
        faces.append((tuple(vs), lo))
        slots.append([draw(st.none() | st.tuples(
            near, near, st.integers(-1, n_faces - 1),
            st.sampled_from([-1, -1, *vs]))) for _ in range(n)])
    return n_layers, faces, slots, n_vertices


@given(planes())
def test_basic_loops_match_reference(case):
    n_layers, faces, slots, n_vertices = case
    args, per_plane, vf = _arrays(n_layers, faces, slots, n_vertices)
    _, loops, chains = _run(args)
    for k in range(n_layers):
        polygons, polylines = ref.basic_loops(per_plane[k], vf)
        assert loops[k] == [list(p) for p in polygons]
        assert chains[k] == [list(p) for p in polylines]


@given(planes(max_layers=1, max_vertices=4, max_faces=40,
              near=st.tuples(st.integers(-7, 7), st.integers(-7, 7))))
def test_basic_loops_around_busy_vertices_match_reference(case):
    # few vertices, many faces, points close together: long searches around a
    # vertex, where used segments are skipped
    test_basic_loops_match_reference.hypothesis.inner_test(case)


@given(planes())
def test_basic_loops_in_chunks_of_planes_match(case):
    # planes are independent: any chunking (here one plane per chunk, in reverse)
    # gives the same result
    args, _, _ = _arrays(*case)
    want = _run(args)

    def backwards(fn, bounds):
        for c in reversed(range(len(bounds) - 1)):
            for k in range(int(bounds[c]), int(bounds[c + 1])):
                fn(k, k + 1)

    got = _run(args, run=backwards)
    assert np.array_equal(got[0], want[0]) and got[1:] == want[1:]


@given(planes())
def test_hub_index_keeps_every_candidate_within_reach(case):
    # every segment of a face around the hub whose start is within 10 µm of an
    # end on the hub is a candidate, in the order of the faces around the vertex
    args, _, _ = _arrays(*case)
    points, links, layer_offsets, face_lo, slot_offsets, slot_seg, vfo, vff = args
    seg_hub, hub_offsets, hub_cands = hub_index(*args)
    plane = np.repeat(np.arange(len(layer_offsets) - 1), np.diff(layer_offsets))
    for s in np.flatnonzero(links[:, 1] >= 0):
        v, k = links[s, 1], plane[s]
        cands = hub_cands[hub_offsets[seg_hub[s]]:hub_offsets[seg_hub[s] + 1]]
        near = []
        for f in vff[vfo[v]:vfo[v + 1]]:
            i = k - face_lo[f]
            if not 0 <= i < slot_offsets[f + 1] - slot_offsets[f]:
                continue
            t = slot_seg[slot_offsets[f] + i]
            d = points[s, 2:4] - points[t, 0:2]
            if t >= 0 and ref.shorter_than(int(d[0]), int(d[1]), 10):
                near.append(t)
        assert set(near) <= set(cands.tolist())
        assert (np.diff(cands) > 0).all()
    assert (seg_hub[links[:, 1] < 0] == -1).all()


def test_skipping_used_segments_never_hides_an_unused_one():
    # one vertex on the plane, and 8 faces around it, so all 8 segments are
    # tried when a chain ends on it; only p1..p4 start near the three ends on it
    # (A, B and C end at x = 0, 100, 200), so only they are candidates, in the
    # order p1, p2, p3, p4. The first chain takes p4 and p3 over edges and ends
    # on the vertex with A: p4, p3 are skipped, p2 is too far, p1 is taken. B
    # finds nothing (its search jumps over p4, p3 at once), and C must still
    # find p2 below those jumps.
    far = [(1000, 1000), (500, 500), (900, 900), (950, 950), (700, 700),
           (800, 800)]
    #         start      end         other face  end vertex
    segs = [(far[0], (150, 0), 7, -1),       # 0 W
            (far[1], (0, 0), -1, 0),         # 1 A
            (far[2], (100, 0), -1, 0),       # 2 B
            (far[3], (200, 0), -1, 0),       # 3 C
            ((0, 5), far[4], -1, -1),        # 4 p1, near A's end
            ((200, 5), far[5], -1, -1),      # 5 p2, near C's end
            ((50, 0), far[1], 1, -1),        # 6 p3
            ((150, 0), (50, 0), 6, -1)]      # 7 p4
    faces = [((0, 1 + 2 * f, 2 + 2 * f), 0) for f in range(8)]
    args, per_plane, vf = _arrays(1, faces, [[x] for x in segs], 17)
    seg_order, loops, chains = _run(args)
    polygons, polylines = ref.basic_loops(per_plane[0], vf)
    assert chains[0] == [list(p) for p in polylines] and loops == [[]]
    assert seg_order.tolist() == [0, 7, 6, 1, 4, 2, 3, 5]
    _, hub_offsets, hub_cands = hub_index(*args)
    assert hub_offsets.tolist() == [0, 4] and hub_cands.tolist() == [4, 5, 6, 7]


def _fan(n, hub=(0, 0)):
    """``n`` segments around one vertex on the plane, as a crown of triangles
    (rim vertices alternately above and below the plane) gives them: even ones
    come in from the rim and end on the vertex, odd ones start at the vertex
    (within 1 µm, from their face's own arithmetic) and end on a rim edge that
    has no other face."""
    faces = [((0, 1 + i, 1 + (i + 1) % n), 0) for i in range(n)]
    a = 2 * np.pi * np.arange(n) / n
    rim = np.stack([np.rint(4e5 * np.cos(a)), np.rint(4e5 * np.sin(a))], axis=1)
    rim = rim.astype(np.int64).tolist()
    slots = []
    for i in range(n):
        jitter = (hub[0] + (i % 3) - 1, hub[1] + (i % 2))
        if i % 2 == 0:
            slots.append([(tuple(rim[i]), jitter, i - 1 if i else n - 1, 0)])
        else:
            slots.append([(jitter, tuple(rim[i]), -1, -1)])
    return faces, slots


def _fan_expected(n):
    """The chains of :func:`_fan`: the search keeps the *last* unused segment
    around the vertex, so segment 2j continues with n - 1 - 2j while that is
    still unused (then with nothing); every other segment is a chain alone."""
    order, used = [], set()
    for s in range(n):
        if s in used:
            continue
        chain = [s]
        if s % 2 == 0 and n - 1 - s > s:
            chain.append(n - 1 - s)
        used.update(chain)
        order.append(chain)
    return order


@pytest.mark.parametrize("n", [8, 300])
def test_fan_matches_reference(n):
    faces, slots = _fan(n)
    args, per_plane, vf = _arrays(1, faces, slots, n + 1)
    seg_order, loops, chains = _run(args)
    polygons, polylines = ref.basic_loops(per_plane[0], vf)
    assert loops == [[]] and polygons == []
    assert chains[0] == [list(p) for p in polylines]
    assert seg_order.tolist() == [s for c in _fan_expected(n) for s in c]


@needs_jit
def test_fan_of_40000_faces_around_one_vertex():
    # audit D2: every segment ending on the vertex searched all 40,000 faces
    # around it (22.5 s); the result is checked here, not the time
    n = 40_000
    faces, slots = _fan(n, hub=(123_456, -7))
    args, _, _ = _arrays(1, faces, slots, n + 1)
    seg_order, loops, chains = _run(args)
    expected = _fan_expected(n)
    assert seg_order.tolist() == [s for c in expected for s in c]
    assert loops == [[]]
    points = args[0]
    assert chains[0] == [[tuple(points[c[0], :2])] + [tuple(points[s, 2:]) for s in c]
                         for c in expected]
    assert len(chains[0]) == 30_000
