"""Repair keeps cavities (issue 8 B1): closed shells face by nesting depth,
decided by exact ray parity (vecslice.nesting)."""

import numpy as np
import pytest
import trimesh
from hypothesis import given
from hypothesis import strategies as st

import vecslice as vs
from vecslice.nesting import ON_SURFACE, nesting_depth, points_in_shell

SETTINGS = vs.SliceSettings()


def sphere(r, centre=(0, 0, 0), inward=False, sub=3):
    s = trimesh.creation.icosphere(subdivisions=sub, radius=r)
    s.apply_translation(centre)
    return s.vertices, (s.faces[:, ::-1] if inward else s.faces)


def shells(*parts):
    v, f, base = [], [], 0
    for pv, pf in parts:
        v.append(pv)
        f.append(pf + base)
        base += len(pv)
    return trimesh.Trimesh(np.vstack(v), np.vstack(f), process=False)


def sliced_volume_mm3(mesh):
    model = vs.slice_mesh(mesh, SETTINGS)
    return round((model.layer_areas() * model.thickness).sum() * 1e-9)


def test_hollow_ball_keeps_its_void():
    # r 20 mm ball with a r 10 mm void, as a CAD program writes it (void inward)
    hollow = shells(sphere(20, sub=4), sphere(10, inward=True, sub=4))
    kept = vs.load_mesh(hollow, repair=False)
    fixed = vs.load_mesh(hollow)
    # 29,259 mm³ (4/3 pi (20³ - 10³) = 29,322 for true spheres); the old repair
    # turned the void outward and the ball sliced solid (33,437 mm³)
    assert sliced_volume_mm3(kept) == sliced_volume_mm3(fixed) == 29_259
    assert np.array_equal(fixed.faces, kept.faces)
    li = fixed.load_info
    assert (li.faces_flipped, li.shells_reversed, li.cavities_kept) == (0, 0, 1)
    text = str(fixed.report())
    assert "shells reversed     0" in text and "cavities kept       1" in text


@pytest.mark.parametrize(("label", "outer_in", "inner_in", "flipped", "reversed_"), [
    ("as written", False, True, 0, 0),
    ("inside out", True, False, 2 * 1280, 2),
])
def test_a_void_wound_opposite_its_ball_stays_a_void(label, outer_in, inner_in,
                                                      flipped, reversed_):
    m = vs.load_mesh(shells(sphere(20, inward=outer_in), sphere(10, inward=inner_in)))
    li = m.load_info
    assert (li.faces_flipped, li.shells_reversed, li.cavities_kept) == (
        flipped, reversed_, 1)
    assert sliced_volume_mm3(m) == 29_069  # icosphere level 3
    outer = m.faces[:1280]
    assert vs.Mesh.from_arrays(m.vertices, outer).volume > 0
    assert vs.Mesh.from_arrays(m.vertices, m.faces[1280:]).volume < 0


@pytest.mark.parametrize(("label", "both_in", "flipped", "reversed_"), [
    ("both outward", False, 0, 0),
    ("both inward", True, 2 * 1280, 2),
])
def test_a_body_inside_another_wound_the_same_way_stays_a_body(label, both_in,
                                                               flipped, reversed_):
    # a closed shell inside another is a cavity only when wound opposite to it: a
    # body wound like the one around it overlaps it, and the NonZero union merges
    # them (an inside-out pair is turned over as a whole)
    m = vs.load_mesh(shells(sphere(20, inward=both_in), sphere(10, inward=both_in)))
    li = m.load_info
    assert (li.faces_flipped, li.shells_reversed, li.cavities_kept) == (
        flipped, reversed_, 0)
    assert vs.Mesh.from_arrays(m.vertices, m.faces[:1280]).volume > 0
    assert vs.Mesh.from_arrays(m.vertices, m.faces[1280:]).volume > 0
    solid = sliced_volume_mm3(vs.load_mesh(shells(sphere(20))))
    assert sliced_volume_mm3(m) == solid
    assert vs.slice_mesh(m, SETTINGS.replace(union_overlapping_volumes=False)
                         ).layer_areas().sum() < vs.slice_mesh(m, SETTINGS
                                                               ).layer_areas().sum()


@pytest.mark.parametrize("inside_out", [False, True])
def test_ball_inside_the_void_is_solid(inside_out):
    # a ball in the void of a hollow ball, each shell wound opposite to the one
    # around it (outward, inward, outward); inside out, all three are turned
    m = vs.load_mesh(shells(sphere(20, inward=inside_out),
                            sphere(10, inward=not inside_out),
                            sphere(5, inward=inside_out)))
    li = m.load_info
    assert (li.cavities_kept, li.shells_reversed) == (1, 3 if inside_out else 0)
    assert vs.Mesh.from_arrays(m.vertices, m.faces[2560:]).volume > 0  # depth 2
    ball = sliced_volume_mm3(vs.load_mesh(shells(sphere(5))))
    assert abs(sliced_volume_mm3(m) - (29_069 + ball)) <= 1  # each rounded


@pytest.mark.parametrize("centre", [(8, 0, 0), (15, 0, 0)])
def test_crossing_shells_are_not_nested(centre):
    # two overlapping balls (the second one's box inside the first's for 15 mm):
    # both stay outward and are merged by the union
    big = 20 if centre[0] == 15 else 10
    m = vs.load_mesh(shells(sphere(big), sphere(10, centre=centre)))
    assert m.load_info.cavities_kept == 0 and m.load_info.faces_flipped == 0


def test_open_shells_keep_the_majority_winding():
    # an open hemisphere-like cap inside a ball: not a container, not contained
    cap = trimesh.creation.icosphere(subdivisions=2, radius=5)
    keep = cap.vertices[cap.faces].mean(axis=1)[:, 2] > 0
    cap_f = cap.faces[keep][:, ::-1]  # inward, all of it
    m = vs.load_mesh(shells(sphere(20), (cap.vertices, cap_f)))
    assert m.load_info.faces_flipped == 0 and m.load_info.cavities_kept == 0


# ---------------------------------------------------------------------------
# points_in_shell against exact references
# ---------------------------------------------------------------------------

BOX = trimesh.creation.box((4, 6, 8))


def box_tri(lo=(0, 0, 0)):
    v = np.rint(BOX.vertices + 2 + np.array([0, 1, 2]) + lo).astype(np.int64)
    return v[BOX.faces]  # corners 0..4, 0..6, 0..8 (+lo)


def test_points_on_a_grid_around_a_box():
    # every point of the grid: many rays pass exactly through vertices and
    # along edges of the triangulated faces, and many points lie on faces
    tri = box_tri()
    g = np.stack(np.meshgrid(*[np.arange(-1, 10)] * 3, indexing="ij"), -1)
    pts = g.reshape(-1, 3).astype(np.int64)
    got = points_in_shell(pts, tri)
    x, y, z = pts.T
    strictly = (x > 0) & (x < 4) & (y > 0) & (y < 6) & (z > 0) & (z < 8)
    closed = (x >= 0) & (x <= 4) & (y >= 0) & (y <= 6) & (z >= 0) & (z <= 8)
    want = np.where(strictly, 1, np.where(closed, ON_SURFACE, 0))
    assert np.array_equal(got, want)
    assert np.array_equal(points_in_shell(pts, tri[:, ::-1]), want)  # any winding


def orient3d(a, b, c, d):
    m = np.array([b - a, c - a, d - a], dtype=object)
    return (m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
            - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
            + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]))


coord = st.integers(-4, 4)
point = st.tuples(coord, coord, coord)


@given(st.lists(point, min_size=4, max_size=4, unique=True),
       st.lists(point, min_size=1, max_size=40), st.integers(0, 2**40))
def test_points_in_random_tetrahedra(corners, points, shift):
    # a convex reference: inside iff on the inner side of all four face planes
    c = np.array(corners, dtype=np.int64) * 1000
    if orient3d(*c) == 0:
        return
    faces = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    if orient3d(*c) < 0:
        faces = faces[:, ::-1]
    off = np.array([shift % 997, shift % 991, -(shift % 983)]) * 1000
    tri = c[faces] + off
    p = np.array(points, dtype=np.int64) * 500 + off
    got = points_in_shell(p, tri)
    for q, g in zip(p, got):
        side = [orient3d(*t, q) for t in tri]  # < 0 inside for outward faces
        if all(s < 0 for s in side):
            assert g == 1
        elif any(s > 0 for s in side):
            assert g == 0
        else:
            assert g in (ON_SURFACE, 0)
            # on a face plane and inside the closed tetrahedron: on the surface
            assert g == ON_SURFACE


def test_nesting_depth_of_boxes_in_boxes():
    parts = [trimesh.creation.box((s, s, s)) for s in (40, 30, 20, 10)]
    far = trimesh.creation.box((5, 5, 5))
    far.apply_translation((100, 0, 0))
    m = vs.load_mesh(trimesh.util.concatenate([*parts, far]), repair=False)
    shell = np.repeat(np.arange(5), 12)
    depth = nesting_depth(m.vertices, m.faces, shell, np.ones(5, dtype=bool))
    assert depth.tolist() == [0, 1, 2, 3, 0]
    closed = np.array([True, False, True, True, True])  # an open shell: skipped
    assert nesting_depth(m.vertices, m.faces, shell, closed).tolist() == [0, 0, 1, 2, 0]


def test_many_separate_closed_shells():
    # a voxel-like plate: 40 x 40 separate cubes, none inside another
    cubes = []
    for i in range(40):
        for j in range(40):
            c = trimesh.creation.box((1, 1, 1))
            c.apply_translation((2 * i, 2 * j, 0))
            cubes.append(c)
    m = vs.load_mesh(trimesh.util.concatenate(cubes))
    assert m.n_bodies == 1600 and m.load_info.cavities_kept == 0


# ---------------------------------------------------------------------------
# many shells (audit s25 hang D1: 400 concentric frames took 46 s to repair,
# 1,000 cubes inside a fine sphere 83 s)
# ---------------------------------------------------------------------------


def test_box_pairs_are_those_of_all_against_all():
    from vecslice.nesting import _Boxes

    rng = np.random.default_rng(7)
    for trial in range(20):
        n = int(rng.integers(65, 400))
        lo = rng.integers(-1000, 1000, (n, 3))
        size = rng.integers(0, 60, (n, 3))
        if trial % 4 == 0:  # a fan: large boxes from the centre (the grid coarsens)
            size[: n // 2] = rng.integers(500, 2000, (n // 2, 3))
        hi = lo + size
        p = np.concatenate([rng.integers(-1100, 1100, (300, 3)), lo[:20], hi[:20]])
        for dims in (2, 3):
            pi, bi = _Boxes(lo, hi).pairs(p, dims)
            assert _Boxes(lo, hi).grid
            near = ((p[:, None, :dims] >= lo[None, :, :dims])
                    & (p[:, None, :dims] <= hi[None, :, :dims])).all(axis=2)
            assert sorted(zip(pi.tolist(), bi.tolist())) == sorted(
                zip(*(x.tolist() for x in np.nonzero(near))))


def test_points_in_a_fine_sphere():
    v, f = sphere(10_000, sub=3)  # 1,280 faces: found through the grid
    tri = np.round(v).astype(np.int64)[f]
    rng = np.random.default_rng(3)
    p = rng.integers(-12_000, 12_000, (2000, 3))
    r = np.linalg.norm(p, axis=1)
    got = points_in_shell(p, tri)
    assert (got[r < 9_000] == 1).all() and (got[r > 10_001] == 0).all()
    corners = np.unique(tri.reshape(-1, 3), axis=0)[:50]
    assert (points_in_shell(corners, tri) == ON_SURFACE).all()


def _frames(n):
    parts = []
    for k in range(1, n + 1):
        m = trimesh.creation.annulus(r_min=k, r_max=k + 0.5, height=1, sections=4)
        parts.append(m)
    return trimesh.util.concatenate(parts)


def test_concentric_frames_take_one_sample_per_pair(monkeypatch):
    """Every frame's box holds the smaller frames', none holds another: each
    candidate pair fails on its first sample, tested with its container's other
    pairs in one call."""
    from vecslice import nesting

    seen = []
    real = nesting.points_in_shell
    monkeypatch.setattr(nesting, "points_in_shell",
                        lambda p, t: seen.append(len(p)) or real(p, t))
    n = 60
    m = vs.load_mesh(_frames(n))
    assert m.n_bodies == n and m.load_info.cavities_kept == 0
    assert len(seen) == n - 1  # one call per container
    assert sum(seen) == n * (n - 1) // 2  # one sample per candidate pair


def test_cubes_inside_a_fine_sphere():
    v, f = sphere(50_000, sub=4)
    cubes = []
    rng = np.random.default_rng(0)
    for c in rng.uniform(-25_000, 25_000, (200, 3)):
        b = trimesh.creation.box((500, 500, 500))
        b.apply_translation(c)
        cubes.append((b.vertices, b.faces))
    mesh = shells((v, f), *cubes)
    shell = np.repeat(np.arange(201), [len(f)] + [12] * 200)
    depth = nesting_depth(np.round(mesh.vertices).astype(np.int64),
                          np.asarray(mesh.faces), shell, np.ones(201, dtype=bool))
    assert depth.tolist() == [0] + [1] * 200


# ---------------------------------------------------------------------------
# deep nesting (audit D04: 8,000 nested tetrahedra took 218 s and 3.6 GB when
# every pair of nested boxes was listed and tested)
# ---------------------------------------------------------------------------

TET = np.array([[-1, -1, -1], [3, -1, -1], [-1, 3, -1], [-1, -1, 3]], np.int64)
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
BOX_FACES = np.asarray(trimesh.creation.box().faces)
BOX_CORNERS = np.asarray(trimesh.creation.box().vertices > 0, dtype=np.int64)


def _scene(parts):
    """vertices, faces, shell labels of (vertices, faces) parts, one shell each."""
    v, f, base = [], [], 0
    for pv, pf in parts:
        v.append(pv)
        f.append(pf + base)
        base += len(pv)
    shell = np.repeat(np.arange(len(parts)), [len(pf) for _, pf in parts])
    return np.concatenate(v).astype(np.int64), np.concatenate(f), shell


def test_nested_shells_take_one_test_each(monkeypatch):
    from vecslice import nesting

    n = 3000
    v, f, shell = _scene([(TET * 10 * k, TET_FACES) for k in range(1, n + 1)])
    seen = []
    real = nesting.points_in_shell
    monkeypatch.setattr(nesting, "points_in_shell",
                        lambda p, t: seen.append(len(p)) or real(p, t))
    depth = nesting_depth(v, f, shell, np.ones(n, dtype=bool))
    assert depth.tolist() == list(range(n - 1, -1, -1))
    # each tetrahedron but the outermost: its first sample, then its other 4,
    # against the next one out only (not against all the n - k around it)
    assert seen == [1, 4] * (n - 1)


@st.composite
def scenes(draw):
    """Closed boxes and tetrahedra on a coarse grid, often inside another's box
    (ties, touching faces, equal boxes, crossing shells), some of them open."""
    parts, region = [], []
    for _ in range(draw(st.integers(2, 14))):
        if region and draw(st.integers(0, 3)):  # within an earlier part's box
            lo, hi = region[draw(st.integers(0, len(region) - 1))]
        else:
            lo, hi = np.zeros(3, np.int64), np.full(3, 24)
        pick = st.tuples(*[st.integers(0, 24)] * 3)
        if draw(st.booleans()):  # lo + 0..24 (mostly less), to hi - 0..24
            a = lo + np.array(draw(pick)) // draw(st.sampled_from([1, 3, 6]))
            b = hi - np.array(draw(pick)) // draw(st.sampled_from([1, 3, 6]))
            if (a >= b).any():
                continue
            parts.append((np.where(BOX_CORNERS == 1, b, a), BOX_FACES))
        else:
            c = lo + np.array(draw(st.lists(pick, min_size=4, max_size=4))) % (
                hi - lo + 1)
            if orient3d(*c) == 0:
                continue
            parts.append((c, TET_FACES))
        region.append((parts[-1][0].min(axis=0), parts[-1][0].max(axis=0)))
        if draw(st.integers(0, 5)) == 0:  # a copy: the same shell again
            parts.append(parts[draw(st.integers(0, len(parts) - 1))])
    if len(parts) < 2:
        parts.append((TET * 1000, TET_FACES))
    closed = np.array(draw(st.lists(st.booleans(), min_size=len(parts),
                                    max_size=len(parts))))
    closed[: len(parts) * 3 // 4] = True
    v, f, shell = _scene(parts)
    return v * 10, f, shell, closed


@given(scenes())
def test_parents_equal_the_quadratic_reference(scene):
    import reference_nesting_quadratic

    from vecslice.nesting import _parents

    v, f, shell, closed = scene
    want = reference_nesting_quadratic._parents(v, f, shell, closed)
    assert _parents(v, f, shell, closed).tolist() == want.tolist()


def test_parents_equal_the_quadratic_reference_on_many_shells():
    # enough shells for a tree of several levels, nested a few deep
    import reference_nesting_quadratic

    from vecslice.nesting import _parents

    rng = np.random.default_rng(11)
    parts = []
    for _ in range(300):
        lo = rng.integers(0, 200, 3)
        hi = lo + rng.integers(1, 60, 3)
        parts.append((np.where(BOX_CORNERS == 1, hi, lo), BOX_FACES))
        if rng.random() < 0.3:
            c = lo + rng.integers(0, 1 + (hi - lo) // 2, (4, 3))
            if orient3d(*c) != 0:
                parts.append((c, TET_FACES))
    v, f, shell = _scene(parts)
    closed = rng.random(len(parts)) < 0.9
    want = reference_nesting_quadratic._parents(v, f, shell, closed)
    got = _parents(v, f, shell, closed)
    assert got.tolist() == want.tolist()
    assert (got >= 0).sum() > 50  # many nested, not only separate shells
