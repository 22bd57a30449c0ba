import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import reference_metrics as ref
from vecslice._kernels.metrics import compare_rings
from vecslice._kernels.planar import winding_area
from vecslice._kernels.simplify import remove_degenerate_vertices, simplify_rings


@st.composite
def star_rings(draw, min_n=3, max_n=40):
    """An integer ring around the origin: sorted angles, random radii (may be
    jagged; with `wild` radii it can also self-intersect)."""
    n = draw(st.integers(min_n, max_n))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    scale = draw(st.sampled_from([50, 1000, 30000]))
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    if draw(st.booleans()):
        ang = rng.permutation(ang)  # wild: self-intersecting
    rad = scale * rng.uniform(0.5, 1.0, n)
    if draw(st.booleans()):  # fine jitter, as crossing rounding gives
        rad += rng.integers(-2, 3, n)
    pts = np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=1)
    pts = np.rint(pts).astype(np.int64) + draw(st.integers(-10**6, 10**6))
    return pts


def _ragged(rings):
    offs = np.zeros(len(rings) + 1, np.int64)
    offs[1:] = np.cumsum([len(r) for r in rings])
    coords = (np.concatenate(rings) if rings else np.zeros((0, 2))).astype(np.int64)
    return coords.reshape(-1, 2), offs


def _check(raw_rings, simp_rings):
    rc, ro = _ragged(raw_rings)
    sc, so = _ragged(simp_rings)
    d1, d2, area, linear = compare_rings(rc, ro, sc, so)
    for r, (a, b) in enumerate(zip(raw_rings, simp_rings, strict=True)):
        if len(b) == 0:
            assert np.isnan(d1[r]) and np.isnan(d2[r])
            want = ref.winding_area([a])
        else:
            # bit-exact: the maximum over all vertex-segment pairs
            assert d1[r] == ref.max_vertex_distance(a, b)
            assert d2[r] == ref.max_vertex_distance(b, a)
            want = ref.winding_area([a, b[::-1]])
        assert area[r] == pytest.approx(float(want), rel=1e-9, abs=1e-6)
    return linear


@settings(max_examples=60)
@given(st.lists(star_rings(max_n=30), min_size=1, max_size=2),
       st.integers(0, 3000), st.integers(0, 400))
def test_simplified_rings_match_brute_force(rings, max_res, max_dev):
    rc, ro = _ragged(rings)
    sc, so = simplify_rings(rc, ro, True, max_res, max_dev, 50000)
    sc, so = remove_degenerate_vertices(sc, so)
    simp = [sc[so[i]:so[i + 1]] for i in range(len(rings))]
    _check(rings, simp)


@settings(max_examples=40)
@given(st.lists(st.tuples(star_rings(max_n=16), star_rings(max_n=16)), min_size=1,
                max_size=2))
def test_unrelated_rings_match_brute_force(pairs):
    # no order correspondence at all: the exact fallbacks must still be exact
    _check([a for a, _ in pairs], [b for _, b in pairs])


@given(star_rings(max_n=12), st.integers(0, 11), st.integers(-300, 300),
       st.integers(-300, 300))
def test_one_vertex_moved(ring, i, dx, dy):
    # a "simplified" ring that moved one vertex (like the intersection rule)
    moved = ring.copy()
    moved[i % len(ring)] += (dx, dy)
    _check([ring], [moved])


@settings(max_examples=40)
@given(st.lists(star_rings(max_n=15), min_size=1, max_size=3))
def test_winding_area_matches_exact_reference(rings):
    edges = []
    for r in rings:
        for i in range(len(r)):
            a, b = r[i], r[(i + 1) % len(r)]
            edges.append([a[0], a[1], b[0], b[1]])
    e = np.array(edges, np.int64)
    got = winding_area(e, len(e))
    assert got == pytest.approx(float(ref.winding_area(rings)), rel=1e-9, abs=1e-6)


def test_square_with_a_pushed_vertex_deviates_by_d():
    for d in (1, 7, 25, 1000):
        raw = np.array([[0, 0], [1000, 0], [1000 + d, 500], [1000, 1000], [0, 1000]])
        sq = np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000]])
        d1, d2, area, linear = compare_rings(raw, np.array([0, 5]), sq,
                                             np.array([0, 4]))
        assert (d1[0], d2[0], area[0], linear[0]) == (d, 0.0, 500.0 * d, True)


def test_dropped_ring_is_all_error_and_no_deviation():
    raw = np.array([[0, 0], [300, 0], [0, 400]])
    d1, d2, area, _ = compare_rings(raw, np.array([0, 3]), np.zeros((0, 2), np.int64),
                                    np.array([0, 0]))
    assert np.isnan(d1[0]) and np.isnan(d2[0]) and area[0] == 60000.0


def test_winding_number_two_counts_twice():
    sq = np.array([[0, 0], [10, 0], [10, 10], [0, 10]])
    e = np.array([[*sq[i], *sq[(i + 1) % 4]] for i in range(4)] * 2, np.int64)
    assert winding_area(e, len(e)) == 200.0


def test_real_layers_match_manifold3d(meshes_dir):
    # simple rings (w in {-1, 0, 1}): Positive + Negative fill is the XOR area
    import manifold3d as m3
    import shapely

    import vecslice as vs

    mesh = vs.load_mesh(meshes_dir / "Voron_Design_Cube_v7.stl")
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings(layer_height=500))
    raw = vs.slice_contours(mesh, z)
    sc, so = simplify_rings(raw.coords, raw.ring_offsets, True, 2000, 100, 50000)
    d1, d2, area, linear = compare_rings(raw.coords, raw.ring_offsets, sc, so)
    checked = 0
    for r in range(raw.n_rings):
        a = raw.coords[raw.ring_offsets[r]:raw.ring_offsets[r + 1]]
        b = sc[so[r]:so[r + 1]]
        if len(b) < 3 or not (shapely.Polygon(a).is_valid
                              and shapely.Polygon(b).is_valid):
            continue
        polys = [a.astype(float), b[::-1].astype(float)]
        want = (m3.CrossSection(polys, m3.FillRule.Positive).area()
                + m3.CrossSection(polys, m3.FillRule.Negative).area())
        assert area[r] == pytest.approx(want, rel=1e-7, abs=1e-3)
        checked += 1
    assert checked > 50 and linear.mean() > 0.9


@settings(max_examples=80)
@given(star_rings(max_n=40), st.integers(0, 39), st.integers(-40000, 40000),
       st.integers(-40000, 40000))
def test_to_ring_within_equals_to_ring(ring, i, dx, dy):
    # given one edge's distance as the bound, the windowed scan skips only
    # edges that cannot hold the minimum: the same float, bit for bit
    from vecslice._kernels.planar import _point_segment, _to_ring, _to_ring_within

    n = len(ring)
    i %= n
    a, b = ring[i], ring[(i + 1) % n]
    px, py = int(a[0]) + dx, int(a[1]) + dy
    bound = _point_segment(px, py, a[0], a[1], b[0], b[1])
    want = _to_ring(px, py, ring, 0, n)
    assert _to_ring_within(px, py, ring, 0, n, bound) == want
    assert _to_ring_within(px, py, ring, 0, n, np.inf) == want


def test_real_layers_deviation_matches_brute_force(meshes_dir):
    # the bounds (nearest edge chosen by squared distance, windowed ring scans)
    # only prune: every ring's deviation is the brute-force maximum, bit for bit
    import vecslice as vs

    mesh = vs.load_mesh(meshes_dir / "3DBenchy.3mf")
    raw = vs.slice_contours(mesh, np.array([2100, 9100, 25100]))
    for max_res, max_dev in ((500, 25), (2000, 100)):
        sc, so = simplify_rings(raw.coords, raw.ring_offsets, True, max_res,
                                max_dev, 50000)
        sc, so = remove_degenerate_vertices(sc, so)
        d1, d2, _, _ = compare_rings(raw.coords, raw.ring_offsets, sc, so)
        # some simplified vertices are moved (intersections), not raw vertices
        raw_set = {tuple(v) for v in raw.coords.tolist()}
        assert sum(tuple(v) not in raw_set for v in sc.tolist()) > 0
        for r in range(raw.n_rings):
            a = raw.coords[raw.ring_offsets[r]:raw.ring_offsets[r + 1]]
            b = sc[so[r]:so[r + 1]]
            if len(b) == 0:
                continue
            assert d1[r] == ref.max_vertex_distance(a, b)
            assert d2[r] == ref.max_vertex_distance(b, a)


def test_many_revisited_runs_match_brute_force():
    # a thin 1000 x 10 µm box whose top edge has 101 vertices; between every two
    # a vertex dips onto the bottom edge (distance 0 there, but 10 µm from its
    # own run's top edge), one of them only to y = 3. Every run's bound exceeds
    # the first exact distance, so all 100 runs are revisited, the one that
    # matters late. Raw -> simplified with the dips in the raw ring, simplified
    # -> raw with them as moved simplified vertices.
    top = [(1000 - 10 * i, 10) for i in range(101)]
    dips = [(995 - 10 * i, 3 if i == 90 else 0) for i in range(100)]
    with_dips = [(0, 0), (1000, 0)]
    for i in range(100):
        with_dips += [top[i], dips[i]]
    with_dips.append(top[100])
    plain = [(0, 0), (1000, 0), *top]
    a, b = np.array(with_dips), np.array(plain)
    _check([a], [b])
    _check([b], [a])
    rc, ro = _ragged([a])
    sc, so = _ragged([b])
    d1, d2, _, _ = compare_rings(rc, ro, sc, so)
    assert (d1[0], d2[0]) == (3.0, 0.0)
    d1, d2, _, _ = compare_rings(sc, so, rc, ro)
    assert (d1[0], d2[0]) == (0.0, 3.0)


def _run_records(raw, simp):
    """Each run's (UB, KMAX) from ``_runs_pass``, and the same measured at every
    raw vertex of the run (the first largest wins), for runs of several edges."""
    from vecslice._kernels import pieces as P
    from vecslice._kernels.metrics import _match, _runs_pass
    from vecslice._kernels.planar import _near_edge_distance

    n, m = len(raw), len(simp)
    anchor = np.empty(n + m + 1, np.int64)
    assert _match(raw, 0, n, simp, 0, m, anchor)
    first = int(np.flatnonzero(anchor[:m] >= 0)[0])
    npc = int((anchor[:m] >= 0).sum())
    wi = np.zeros(P._NI * (n + m + 1), np.int64)
    wf = np.zeros(P._NF * (n + m + 1), np.float64)
    e = np.zeros((n + m + 1, 4), np.int64)
    _runs_pass(raw, 0, n, simp, 0, m, anchor, first, wi, wf, e, npc)
    got, want = [], []
    for t in range(npc):
        b = P._NI * t
        p, q, ap, aq = (int(wi[b + k]) for k in (P._P, P._Q, P._AP, P._AQ))
        if (q - p) % m < 2:
            continue
        ub, kmax = 0.0, ap
        for kk in range(ap, aq + 1):
            k = kk % n
            d = _near_edge_distance(raw[k, 0], raw[k, 1], simp, 0, m, p, (q - p) % m)
            if d > ub:
                ub, kmax = d, k
        got.append((wf[P._NF * t + P._UB], int(wi[b + P._KMAX])))
        want.append((ub, kmax))
    return got, want


@settings(max_examples=60)
@given(star_rings(min_n=12, max_n=40), st.data())
def test_multi_edge_runs_bound_as_measuring_every_vertex(ring, data):
    # runs of several simplified edges (a moved vertex inside) measure only the
    # raw vertices whose squared distance may beat the largest so far: their
    # bound and its vertex are those of measuring every raw vertex, bit for bit
    n = len(ring)
    keep = sorted(data.draw(st.sets(st.integers(0, n - 1), min_size=3,
                                    max_size=n // 2)))
    simp = []
    for j, i in enumerate(keep):
        simp.append(ring[i])
        nxt = keep[(j + 1) % len(keep)]
        if (nxt - i) % n > 2 and data.draw(st.booleans()):  # a moved vertex
            mid = ring[(i + (nxt - i) % n // 2) % n]
            simp.append(mid + data.draw(st.tuples(st.integers(-30, 30),
                                                  st.integers(-30, 30))))
    got, want = _run_records(ring, np.array(simp, np.int64))
    assert got == want


def test_multi_edge_run_with_equal_distances_keeps_the_first():
    # raw vertices at exactly equal distance from the run's two edges: the first
    # of them holds the bound (later ones are equal, never larger)
    raw = np.array([(0, 0), (10, 5), (20, 5), (30, 5), (40, 0), (40, 40), (0, 40)])
    simp = np.array([(0, 0), (20, 1), (40, 0), (40, 40), (0, 40)])
    got, want = _run_records(raw, simp)
    assert got == want and len(got) == 1
    assert got[0][1] == 1


def _anchors(raw, simp):
    from vecslice._kernels.metrics import _match

    raw, simp = np.array(raw, np.int64), np.array(simp, np.int64)
    anchor = np.empty(len(simp), np.int64)
    ok = _match(raw, 0, len(raw), simp, 0, len(simp), anchor)
    return ok, anchor.tolist()


def test_match_anchors_in_order_and_skips_moved_vertices():
    raw = [(0, 0), (5, 1), (10, 0), (15, 1), (20, 0), (20, 20), (0, 20)]
    # a subsequence: each vertex anchored to the raw vertex it equals
    assert _anchors(raw, [(0, 0), (10, 0), (20, 0), (20, 20)]) == (True, [0, 2, 4, 5])
    # a moved vertex (equal to no raw vertex) is -1; the scan for it stops at
    # the next simplified vertex, which is still found
    assert _anchors(raw, [(0, 0), (12, 3), (20, 0), (0, 20)]) == (True, [0, -1, 4, 6])
    # ... or at the one after it (two moved in a row)
    assert _anchors(raw, [(0, 0), (12, 3), (13, 3), (20, 20)]) == (True,
                                                                     [0, -1, -1, 5])
    # the last simplified vertices, with nothing after them to stop at
    assert _anchors(raw, [(0, 0), (20, 20), (7, 7)]) == (True, [0, 5, -1])
    # out of (cyclic) order: the scan for (5, 1) stops at (20, 20), the next
    # simplified vertex, which is anchored instead
    assert _anchors(raw, [(10, 0), (20, 0), (5, 1), (20, 20)]) == (True,
                                                                    [2, 4, -1, 5])


def test_match_starts_where_the_simplified_ring_starts():
    raw = [(0, 0), (5, 1), (10, 0), (15, 1), (20, 0), (20, 20), (0, 20)]
    # a simplified ring starting at raw vertex 4: anchors increase cyclically
    assert _anchors(raw, [(20, 0), (0, 20), (0, 0), (10, 0)]) == (True, [4, 6, 0, 2])
    # its first vertex moved: the match starts at the second one's raw vertex
    assert _anchors(raw, [(21, 5), (20, 20), (0, 0), (10, 0)]) == (True,
                                                                    [-1, 5, 0, 2])


@settings(max_examples=40)
@given(st.lists(star_rings(min_n=6, max_n=30), min_size=1, max_size=2),
       st.integers(0, 3000), st.integers(0, 400), st.integers(1, 29))
def test_rotated_simplified_rings_match_brute_force_in_one_pass(rings, max_res,
                                                                 max_dev, shift):
    # rings from another simplifier may start anywhere in their raw ring: still
    # exact, and still measured by the linear pass (not all pairs)
    rc, ro = _ragged(rings)
    sc, so = simplify_rings(rc, ro, True, max_res, max_dev, 50000)
    sc, so = remove_degenerate_vertices(sc, so)
    simp = [np.roll(sc[so[i]:so[i + 1]], shift % max(1, so[i + 1] - so[i]), axis=0)
            for i in range(len(rings))]
    linear = _check(rings, simp)
    rotated = _check(rings, [sc[so[i]:so[i + 1]] for i in range(len(rings))])
    assert linear.tolist() == rotated.tolist()


def test_a_rotated_large_ring_is_measured_in_linear_time():
    # 20,000 vertices: all pairs would be 4e8 distances; a rotated copy of the
    # ring itself is matched in one pass, every deviation 0
    n = 20000
    ang = 2 * np.pi * np.arange(n) / n
    ring = np.rint(np.stack([1e6 * np.cos(ang), 1e6 * np.sin(ang)], 1)).astype(np.int64)
    rc, ro = _ragged([ring])
    sc, so = _ragged([np.roll(ring, 10, axis=0)])
    d1, d2, area, linear = compare_rings(rc, ro, sc, so)
    assert (d1[0], d2[0], area[0]) == (0.0, 0.0, 0.0) and linear[0]


def test_match_gives_up_beyond_its_linear_budget():
    # every simplified vertex is missing: each scans the rest of the raw ring
    raw = [(i, 0) for i in range(200)]
    simp = [(-1 - j, 5) for j in range(50)]
    ok, _ = _anchors(raw, simp)
    assert not ok
