"""Tests for vecslice.parts (make_parts, apply_slicing_tolerance), with to_shapely."""

from __future__ import annotations

import re

import numpy as np
import pytest
import shapely
import trimesh
from hypothesis import example, given
from hypothesis import strategies as st

import vecslice as vs
from vecslice import InputTypeError, LayerPaths, SettingsError
from vecslice._kernels.rings import ring_area2
from vecslice.interop import to_shapely
from vecslice.layerparts import LayerParts
from vecslice.parts import apply_slicing_tolerance, make_parts


def rect(x0, y0, x1, y1, *, cw=False):
    r = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    return r[::-1] if cw else r


def stack(*layers):
    """LayerPaths from a list of layers, each a list of rings."""
    rings = [
        np.asarray(r, dtype=np.int64).reshape(-1, 2) for lay in layers for r in lay
    ]
    lens = [len(r) for r in rings]
    coords = np.concatenate(rings) if rings else np.empty((0, 2), np.int64)
    return LayerPaths(
        coords,
        np.concatenate([[0], np.cumsum(lens)]).astype(np.int64),
        np.concatenate([[0], np.cumsum([len(x) for x in layers])]).astype(np.int64),
    )


def check_invariants(parts: LayerParts) -> np.ndarray:
    """Layout, orientation and no-repeat invariants; returns ring area2."""
    LayerParts(
        parts.coords, parts.ring_offsets, parts.part_offsets, parts.layer_offsets
    )
    assert (np.diff(parts.part_offsets) >= 1).all()
    assert (np.diff(parts.ring_offsets) >= 3).all()
    a2 = ring_area2(parts.coords, parts.ring_offsets)
    is_outline = np.zeros(len(a2), bool)
    is_outline[parts.part_offsets[:-1]] = True
    assert (a2[is_outline] > 0).all()
    assert (a2[~is_outline] < 0).all()
    ro = parts.ring_offsets
    for i in range(len(ro) - 1):  # no vertex equal to its cyclic predecessor
        r = parts.coords[ro[i] : ro[i + 1]]
        assert (r != np.roll(r, 1, axis=0)).any(axis=1).all()
    return a2


def layer_area2(parts: LayerParts) -> np.ndarray:
    a2 = ring_area2(parts.coords, parts.ring_offsets)
    ring_part = np.repeat(np.arange(parts.n_parts), np.diff(parts.part_offsets))
    part_layer = np.repeat(np.arange(parts.n_layers), np.diff(parts.layer_offsets))
    return np.bincount(part_layer[ring_part], weights=a2, minlength=parts.n_layers)


def test_nested_squares_island_in_hole_is_a_separate_part():
    loops = stack(
        [rect(0, 0, 100, 100), rect(10, 10, 90, 90, cw=True), rect(20, 20, 80, 80)]
    )
    parts = make_parts(loops)
    a2 = check_invariants(parts)
    assert parts.n_parts == 2
    assert np.diff(parts.part_offsets).tolist() == [2, 1]
    assert a2.tolist() == [20000, -12800, 7200]
    outline, holes = parts.part(0, 0)
    assert outline.tolist() == rect(0, 0, 100, 100)  # starts at min (x, y), CCW
    assert [h.tolist() for h in holes] == [[[10, 10], [10, 90], [90, 90], [90, 10]]]


def test_island_with_hole_inside_a_hole_and_a_second_body():
    # needs manifold3d's decompose: the inner hole has two candidate outlines
    loops = stack(
        [
            rect(0, 0, 100, 100),
            rect(10, 10, 90, 90, cw=True),
            rect(20, 20, 80, 80),
            rect(30, 30, 70, 70, cw=True),
            rect(200, 0, 300, 100),
            rect(210, 10, 220, 20, cw=True),
        ]
    )
    parts = make_parts(loops)
    a2 = check_invariants(parts)
    assert np.diff(parts.part_offsets).tolist() == [2, 2, 2]
    assert a2.tolist() == [20000, -12800, 7200, -3200, 20000, -200]
    assert parts.part(0, 1)[0].min(axis=0).tolist() == [20, 20]
    assert parts.part(0, 2)[0].min(axis=0).tolist() == [200, 0]


def test_two_overlapping_squares_nonzero_merge_evenodd_xor():
    loops = stack([rect(0, 0, 20, 20), rect(10, 10, 30, 30)])
    merged = make_parts(loops)
    check_invariants(merged)
    assert merged.n_parts == 1
    assert layer_area2(merged).tolist() == [2 * 700]
    xor = make_parts(loops, union_overlapping_volumes=False)
    check_invariants(xor)
    assert layer_area2(xor).tolist() == [2 * 600]


def test_same_orientation_overlap_nonzero_vs_evenodd():
    loops = stack([rect(0, 0, 30, 30), rect(10, 10, 20, 20)])  # both CCW
    assert layer_area2(make_parts(loops)).tolist() == [1800]
    xor = make_parts(loops, union_overlapping_volumes=False)
    check_invariants(xor)
    assert xor.n_parts == 1 and layer_area2(xor).tolist() == [1800 - 200]


def test_plate_with_five_holes_is_one_part_with_sorted_holes():
    holes = [
        rect(x, y, x + 10, y + 10, cw=True)
        for x, y in [(80, 10), (10, 10), (50, 30), (10, 40), (30, 10)]
    ]
    parts = make_parts(stack([rect(0, 0, 100, 60), *holes]))
    a2 = check_invariants(parts)
    assert parts.n_parts == 1 and parts.part_offsets.tolist() == [0, 6]
    assert a2.tolist() == [12000] + [-200] * 5
    starts = [h[0].tolist() for h in parts.part(0, 0)[1]]
    assert (
        starts == sorted(starts) == [[10, 10], [10, 40], [30, 10], [50, 30], [80, 10]]
    )


def test_integer_vertices_are_kept_exactly():
    rng = np.random.default_rng(7)
    big = 2**30 - 1
    rings = [rect(-big, -big, -big + 1000, -big + 3), rect(big - 5, big - 9, big, big)]
    for i in range(20):
        x, y = (int(v) for v in rng.integers(-(10**7), 10**7, 2))
        x += (i - 10) * 10**8
        rings.append(rect(x, y, x + 12345, y + 777))
    parts = make_parts(stack(rings))
    check_invariants(parts)
    assert parts.n_parts == len(rings)
    got = {tuple(v) for v in parts.coords.tolist()}
    assert got == {tuple(v) for r in rings for v in r}


def test_orientation_is_normalised_and_order_is_deterministic():
    rings = [
        rect(0, 0, 10, 10, cw=True),
        rect(50, 0, 60, 10),
        rect(20, 5, 30, 15, cw=True),
        rect(100, 0, 200, 100),
        rect(110, 10, 120, 20, cw=True),
    ]
    a = make_parts(stack(rings))
    check_invariants(a)
    assert [p[0][0].tolist() for p in (a.part(0, j) for j in range(a.n_parts))] == [
        [0, 0],
        [20, 5],
        [50, 0],
        [100, 0],
    ]
    rng = np.random.default_rng(3)
    for _ in range(3):
        perm = rng.permutation(len(rings))
        shuffled = [np.roll(rings[i], int(rng.integers(4)), axis=0) for i in perm]
        b = make_parts(stack(shuffled))
        for name in ("coords", "ring_offsets", "part_offsets", "layer_offsets"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_layers_empty_layers_and_degenerate_rings():
    collinear = [[0, 0], [5, 0], [10, 0]]
    loops = stack(
        [], [rect(0, 0, 10, 10)], [collinear], [rect(0, 0, 4, 4), rect(9, 9, 12, 12)]
    )
    parts = make_parts(loops)
    check_invariants(parts)
    assert parts.n_layers == 4
    assert parts.layer_offsets.tolist() == [0, 0, 1, 1, 3]
    assert layer_area2(parts).tolist() == [0, 200, 0, 32 + 18]
    assert make_parts(LayerPaths.empty(0)).n_layers == 0
    assert make_parts(LayerPaths.empty(3)).layer_offsets.tolist() == [0, 0, 0, 0]


def test_trimesh_cross_sections():
    # annulus and a disc sectioned by trimesh (loops of unknown orientation), in µm
    meshes = [
        trimesh.creation.annulus(r_min=4.0, r_max=9.0, height=2.0, sections=64),
        trimesh.creation.cylinder(radius=3.0, height=2.0, sections=48),
    ]
    meshes[1].apply_translation([30.0, 0.0, 0.0])
    rings = []
    for m in meshes:
        for loop in m.section(plane_origin=[0, 0, 0], plane_normal=[0, 0, 1]).discrete:
            rings.append(np.rint(loop[:-1, :2] * 1000).astype(np.int64))
    want = 0.0
    for r in rings:
        want = shapely.symmetric_difference(
            want or shapely.Polygon(), shapely.Polygon(r)
        )
    parts = make_parts(stack(rings), union_overlapping_volumes=False)
    check_invariants(parts)
    assert np.diff(parts.part_offsets).tolist() == [2, 1]  # ring + hole, then disc
    assert layer_area2(parts)[0] == 2 * want.area
    # the input's vertices, exactly, but for those on a line with their two
    # neighbours (the union removes collinear points: SLICING.md)
    kept = set()
    for r in rings:
        d0 = r - np.roll(r, 1, axis=0)
        d1 = np.roll(r, -1, axis=0) - r
        collinear = d0[:, 0] * d1[:, 1] == d0[:, 1] * d1[:, 0]
        kept |= {tuple(v) for v in r[~collinear].tolist()}
    assert {tuple(v) for v in parts.coords.tolist()} == kept


def test_union_removes_collinear_points():
    """Clipper2 keeps a point between two collinear edges; CuraEngine's union
    (and SLICING.md) remove it: in make_parts and in the 'inclusive'/'exclusive'
    tolerances (two layers' walls along one line left 472 on 3DBenchy)."""
    a = [[0, 0], [10, 0], [20, 0], [20, 10], [0, 10]]  # (10, 0) is collinear
    parts = make_parts(stack([np.array(a)]))
    assert parts.coords.tolist() == [[0, 0], [20, 0], [20, 10], [0, 10]]
    b = [[10, 0], [30, 0], [30, 10], [10, 10]]  # overlaps a: the walls y = 0, 10
    loops = LayerPaths(a + b, [0, 5, 9], [0, 1, 2])
    for mode in ("inclusive", "exclusive"):
        out = apply_slicing_tolerance(loops, mode)
        for ring in out.layer(0):
            d0 = ring - np.roll(ring, 1, axis=0)
            d1 = np.roll(ring, -1, axis=0) - ring
            cross = d0[:, 0] * d1[:, 1] - d0[:, 1] * d1[:, 0]
            assert (cross != 0).all(), (mode, ring.tolist())
        assert [len(r) for r in out.layer(0)] == [4]  # 30 x 10, or 10 x 10


def test_rounded_union_output_loses_its_spikes():
    """A sliver in the union's float output can round to a zero-width spike
    (out and back along one line); its tip is a collinear point, removed like
    CuraEngine's union removes every vertex whose neighbours' slopes are equal,
    and then its base vertices repeat and go too."""
    from vecslice.parts import _dedupe, _vertex_keys

    square = [[0, 0], [10, 0], [10, 10], [0, 10]]
    spiked = [[0, 0], [10, 0], [10, 10], [5, 10], [5, 25], [5, 10], [0, 10]]
    # a spike whose way back stops short of its base, and one along an edge
    short = [[0, 0], [10, 0], [10, 10], [5, 10], [5, 25], [5, 12], [4, 10], [0, 10]]
    along = [[0, 0], [10, 0], [10, 10], [20, 10], [10, 10], [0, 10]]
    rings = [np.array(r, dtype=np.int64) for r in (spiked, short, along, square)]
    coords = np.concatenate(rings)
    lens = np.array([len(r) for r in rings], dtype=np.int64)
    out, key, out_lens = _dedupe(coords, _vertex_keys(coords), lens)
    assert np.array_equal(key, _vertex_keys(out))
    got = np.split(out, np.cumsum(out_lens)[:-1])
    assert got[0].tolist() == square
    assert got[1].tolist() == [[0, 0], [10, 0], [10, 10], [5, 10], [5, 12], [4, 10],
                               [0, 10]]  # (5, 25) goes; (5, 12) turns a corner
    assert got[2].tolist() == square
    assert got[3].tolist() == square


def test_no_collinear_vertex_survives_on_a_broken_mesh(meshes_dir):
    # the shared mesh where manifold3d's output has slivers that round to
    # spikes 1.5 mm long (16 outlines in the default mode before the fix)
    mesh = vs.load_mesh(meshes_dir / "openscad-nonmanifold-crash.obj")
    for tol in ("middle", "inclusive", "exclusive"):
        model = vs.slice_mesh(mesh, vs.SliceSettings(slicing_tolerance=tol))
        for r in range(model.ring_offsets.shape[0] - 1):
            ring = model.coords[model.ring_offsets[r]:model.ring_offsets[r + 1]]
            d0 = ring - np.roll(ring, 1, axis=0)
            d1 = np.roll(ring, -1, axis=0) - ring
            cross = d0[:, 0] * d1[:, 1] - d0[:, 1] * d1[:, 0]
            assert (cross != 0).all(), (tol, r, ring[cross == 0].tolist())


@st.composite
def rectangle_layers(draw):
    n = draw(st.integers(0, 12))
    coord = st.integers(-1000, 1000)
    rings, cw = [], draw(st.booleans())
    for _ in range(n):
        x0, x1 = sorted(draw(st.lists(coord, min_size=2, max_size=2, unique=True)))
        y0, y1 = sorted(draw(st.lists(coord, min_size=2, max_size=2, unique=True)))
        rings.append(rect(x0, y0, x1, y1, cw=cw))
    return rings


def clipper_valid(got):
    """``got`` (a layer's MultiPolygon) made OGC-valid, after checking that it is
    a valid Clipper polygon: valid already, or invalid only where a ring touches
    itself or another ring at a vertex that both pass through (documented in
    ``vecslice.interop.to_shapely``: the union's rings may do that, as
    CuraEngine's do), never where edges cross."""
    reason = shapely.is_valid_reason(got)
    if reason == "Valid Geometry":
        return got
    m = re.fullmatch(r"(?:Ring )?Self-intersection\[(\S+) (\S+)\]", reason)
    assert m, reason
    point = (float(m.group(1)), float(m.group(2)))
    rings = [r for poly in got.geoms for r in (poly.exterior, *poly.interiors)]
    passes = sum(list(map(tuple, r.coords[:-1])).count(point) for r in rings)
    assert passes >= 2, reason  # a vertex passed twice, not a crossing
    return shapely.make_valid(got)


@given(rectangle_layers())
def test_area_equals_independent_union(rings):
    parts = make_parts(stack(rings, rings[::2]))
    check_invariants(parts)
    for k, lay in enumerate((rings, rings[::2])):
        want = shapely.unary_union([shapely.box(*r[0], *r[2]) for r in lay]).area
        assert layer_area2(parts)[k] == 2 * want
        got = to_shapely(parts, k, scale=1.0)
        assert len(got.geoms) == np.diff(parts.layer_offsets)[k]
        assert clipper_valid(got).area == got.area == want


def test_to_shapely_in_mm():
    parts = make_parts(
        stack(
            [],
            [
                rect(0, 0, 2000, 1000),
                rect(500, 250, 1500, 750, cw=True),
                rect(3000, 0, 4000, 1000),
            ],
        )
    )
    empty = to_shapely(parts, 0)
    assert isinstance(empty, shapely.MultiPolygon) and empty.is_empty
    mp = to_shapely(parts, -1)
    assert mp.area == pytest.approx(2.0 - 0.5 + 1.0)
    assert [len(p.interiors) for p in mp.geoms] == [1, 0]
    assert mp.bounds == (0.0, 0.0, 4.0, 1.0)
    msg = r"`k` must be a layer index in \[-2, 2\); got 2"
    with pytest.raises(ValueError, match=msg):
        to_shapely(parts, 2)


def stack3():
    return stack([rect(0, 0, 10, 10)], [rect(5, 0, 15, 10)], [rect(0, 0, 4, 4)])


def test_inclusive_unions_each_layer_with_the_raw_next():
    out = apply_slicing_tolerance(stack3(), "inclusive")
    assert out.layer_area2().tolist() == [2 * 150, 2 * (100 + 16), 32]
    assert (out.area2() > 0).all()


def test_exclusive_intersects_with_the_next_and_clears_the_top():
    out = apply_slicing_tolerance(stack3(), "exclusive")
    assert out.layer_area2().tolist() == [2 * 50, 2 * 0, 0]
    assert out.rings_per_layer().tolist() == [1, 0, 0]
    assert out.layer(0)[0].tolist() == [[10, 10], [5, 10], [5, 0], [10, 0]] or sorted(
        out.layer(0)[0].tolist()
    ) == [[5, 0], [5, 10], [10, 0], [10, 10]]


def test_exclusive_uses_evenodd_and_inclusive_keeps_holes():
    hollow = [
        rect(0, 0, 30, 30),
        rect(10, 10, 20, 20),
    ]  # both CCW: EvenOdd makes a hole
    out = apply_slicing_tolerance(stack(hollow, hollow), "exclusive")
    assert out.layer_area2().tolist() == [2 * 800, 0]
    inc = apply_slicing_tolerance(
        stack(
            [rect(0, 0, 30, 30), rect(10, 10, 20, 20, cw=True)],
            [rect(0, 0, 30, 30), rect(12, 12, 18, 18, cw=True)],
        ),
        "inclusive",
    )
    assert inc.layer_area2().tolist() == [2 * (900 - 36), 2 * (900 - 36)]


def test_middle_returns_input_and_open_is_passed_through():
    raw = stack3()
    opened = LayerPaths([[0, 0], [5, 5]], [0, 2], [0, 1, 1, 1])
    loops = LayerPaths(raw.coords, raw.ring_offsets, raw.layer_offsets, open=opened)
    assert apply_slicing_tolerance(loops, "middle") is loops
    assert apply_slicing_tolerance(loops, "inclusive").open is opened
    assert apply_slicing_tolerance(LayerPaths.empty(0), "exclusive").n_layers == 0


@pytest.mark.parametrize(
    ("call", "exc", "fragment"),
    [
        (
            lambda: make_parts([[0, 0]]),
            InputTypeError,
            "`loops` must be a vecslice.LayerPaths",
        ),
        (
            lambda: apply_slicing_tolerance(stack3(), "outer"),
            SettingsError,
            "`mode` must be one of 'middle', 'inclusive', 'exclusive'; got 'outer'",
        ),
        (
            lambda: apply_slicing_tolerance(None, "middle"),
            InputTypeError,
            "got NoneType",
        ),
        (
            lambda: LayerParts([[0, 0]], [0, 1], [0, 2], [0, 1]),
            ValueError,
            "`part_offsets` must end at 1",
        ),
    ],
)
def test_errors(call, exc, fragment):
    with pytest.raises(exc, match=fragment.replace("(", r"\(")):
        call()


@given(st.integers(0, 2**32 - 1), st.integers(1, 8))
@example(185716, 3)  # two hulls' union passes through one vertex twice
def test_random_convex_polygons_union_area(seed, n):
    rng = np.random.default_rng(seed)
    polys = []
    for _ in range(n):
        pts = rng.integers(-5000, 5000, (8, 2)) + rng.integers(-20000, 20000, 2)
        hull = shapely.convex_hull(shapely.MultiPoint(pts))
        if hull.geom_type == "Polygon" and hull.area > 0:
            polys.append(shapely.geometry.polygon.orient(hull, 1.0))
    rings = [np.asarray(p.exterior.coords, dtype=np.int64)[:-1] for p in polys]
    parts = make_parts(stack(rings))
    check_invariants(parts)
    union = shapely.unary_union(polys) if polys else shapely.Polygon()
    got = clipper_valid(to_shapely(parts, 0, scale=1.0))
    assert (
        abs(got.area - union.area) <= union.length + 1
    )  # intersections rounded to 1 µm
    assert shapely.symmetric_difference(got, union).area <= union.length + 1


def test_part_views_and_index_errors():
    parts = make_parts(stack([rect(0, 0, 10, 10)], []))
    assert parts.part(-2, 0)[0].tolist() == rect(0, 0, 10, 10)
    assert "LayerParts(2 layers, 1 parts, 1 rings, 4 vertices)" == repr(parts)
    with pytest.raises(ValueError, match=r"`k` must be a layer index in \[-2, 2\)"):
        parts.part(2, 0)
    with pytest.raises(
        ValueError, match=r"`j` must be a part index of layer 1 in \[0, 0\)"
    ):
        parts.part(1, 0)


@st.composite
def frames(draw):
    """Rectangular frames (outline CCW + hole CW); often one in the previous hole."""
    out, box = [], (0, 0, 400, 400)
    for _ in range(draw(st.integers(1, 6))):
        if out and draw(st.booleans()) and min(box[2] - box[0], box[3] - box[1]) > 8:
            lo = (box[0] + 1, box[1] + 1, box[2] - 1, box[3] - 1)  # island in hole
        else:
            lo = (0, 0, 400, 400)
        xs = sorted(
            draw(
                st.lists(st.integers(lo[0], lo[2]), min_size=4, max_size=4, unique=True)
            )
        )
        ys = sorted(
            draw(
                st.lists(st.integers(lo[1], lo[3]), min_size=4, max_size=4, unique=True)
            )
        )
        out.append(
            (
                rect(xs[0], ys[0], xs[3], ys[3]),
                rect(xs[1], ys[1], xs[2], ys[2], cw=True),
            )
        )
        box = (xs[1], ys[1], xs[2], ys[2])
    return out


@given(frames())
def test_nested_frames_match_shapely_union(fr):
    parts = make_parts(stack([r for f in fr for r in f]))
    check_invariants(parts)
    want = shapely.unary_union([shapely.Polygon(o, [h]) for o, h in fr])
    got = to_shapely(parts, 0, scale=1.0)
    assert got.is_valid  # holes inside their outline, parts disjoint
    assert got.area == want.area == layer_area2(parts)[0] / 2
    assert shapely.symmetric_difference(got, want).area == 0


def test_manifold3d_is_imported_inside_the_functions_that_use_it():
    import ast
    import pathlib

    import vecslice

    for path in pathlib.Path(vecslice.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in tree.body:  # module level only (TYPE_CHECKING blocks are ok)
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            assert not any(n.split(".")[0] == "manifold3d" for n in names), path.name


def test_moved_names_are_still_importable_from_parts():
    from vecslice import interop, layerparts, parts

    assert parts.LayerParts is layerparts.LayerParts
    assert parts.to_shapely is interop.to_shapely


@pytest.mark.parametrize("value", ["no", 0, 1, None, np.array([True])])
def test_fill_rule_option_must_be_a_bool(value):
    """Issue 8 D8: union_overlapping_volumes='no' was taken as True."""
    with pytest.raises(InputTypeError, match="`union_overlapping_volumes` must be "
                       "True or False; got"):
        make_parts(stack3(), union_overlapping_volumes=value)
    assert make_parts(stack3(), union_overlapping_volumes=np.False_).n_layers == 3


def many_layers(n):
    """n layers: a frame with an island in its hole, and a lone square, shifted."""
    layers = []
    for k in range(n):
        d = k % 7
        rings = [rect(0, 0, 100 + d, 100), rect(20, 20, 80, 80, cw=True),
                 rect(40, 40, 60 + d, 60), rect(200, 0, 210, 10 + d)]
        layers.append(rings[: 1 + k % 4])
    return stack(*layers)


@pytest.mark.parametrize("batch", [1, 2, 5])
def test_batches_of_layers_give_the_same_parts(batch, monkeypatch):
    """Issue 8 A5: manifold3d objects exist for one batch of layers at a time."""
    from vecslice import parts as parts_module

    loops = many_layers(23)
    want = make_parts(loops)
    want_inc = apply_slicing_tolerance(loops, "inclusive")
    want_exc = apply_slicing_tolerance(loops, "exclusive")
    seen = []
    real = parts_module._cross_sections

    def spy(lp, rule, k0=0, k1=None):
        seen.append((k1 if k1 is not None else lp.n_layers) - k0)
        return real(lp, rule, k0, k1)

    monkeypatch.setattr(parts_module, "_BATCH_LAYERS", batch)
    monkeypatch.setattr(parts_module, "_cross_sections", spy)
    got = make_parts(loops)
    for name in ("coords", "ring_offsets", "part_offsets", "layer_offsets"):
        assert np.array_equal(getattr(got, name), getattr(want, name)), name
    assert max(seen) == batch
    seen.clear()
    for mode, ref in (("inclusive", want_inc), ("exclusive", want_exc)):
        out = apply_slicing_tolerance(loops, mode)
        for name in ("coords", "ring_offsets", "layer_offsets"):
            assert np.array_equal(getattr(out, name), getattr(ref, name)), (mode, name)
    assert max(seen) == batch + 1  # each batch also needs the next raw layer


def test_hole_outline_pairs_are_listed_a_chunk_at_a_time():
    """Audit s25 hang D4: a batch's (hole, outline) box tests were listed at once,
    up to 10**7 pairs (a plate of 100 washers over 1,000 layers: 657 MB for 14 MB
    in and 12 MB out). Here 3 * 10**6 pairs: 185 MB before, about 29 MB now."""
    import tracemalloc

    n, layers = 100, 300
    grid = np.stack(np.meshgrid(np.arange(10), np.arange(10)), -1).reshape(-1, 2) * 3000
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]])
    outline = grid[:, None, :] + square[None] * 2400  # CCW
    hole = grid[:, None, :] + 600 + square[None, ::-1] * 1200  # CW
    rings = np.stack([outline, hole], 1).reshape(-1, 2)
    count = 2 * n * layers
    loops = vs.LayerPaths(np.tile(rings, (layers, 1)), np.arange(0, 4 * count + 1, 4),
                          np.arange(0, count + 1, 2 * n))
    vs.make_parts(vs.LayerPaths(rings, np.arange(0, 4 * 2 * n + 1, 4), [0, 2 * n]))
    tracemalloc.start()
    try:
        parts = vs.make_parts(loops)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert parts.n_parts == n * layers
    assert all(len(holes) == 1 for _, holes in parts.layer(layers - 1))
    assert peak < 60 * 2**20, peak / 2**20


@pytest.mark.parametrize(("which", "index", "value", "fragment"), [
    (0, (5, 0), -100, r"ring 1 \(a hole of part 0, layer 0\) must be clockwise"),
    (1, 1, 2, r"ring 0 \(the outline of part 0, layer 0\) has 2"),
    (2, 1, 10**12, r"`part_offsets` must end at 2"),
    (3, 1, -5, r"`layer_offsets` must end at 1"),
])  # fmt: skip
def test_layer_parts_checks_the_copies_it_keeps(write_when_copied, which, index,
                                                value, fragment):
    """Audit s26 state D2: LayerParts checked the caller's arrays, then copied them;
    a write by another thread in between was kept unchecked. Here the write lands
    just before the copy."""
    hole = [[2, 8], [8, 8], [8, 2], [2, 2]]
    arrays = [np.array([[0, 0], [10, 0], [10, 10], [0, 10], *hole]),
              np.array([0, 4, 8]), np.array([0, 2]), np.array([0, 1])]
    LayerParts(*arrays)  # valid as given
    writes = write_when_copied(arrays[which], index, value)
    with pytest.raises(ValueError, match=fragment):
        LayerParts(*arrays)
    assert writes == [index]
