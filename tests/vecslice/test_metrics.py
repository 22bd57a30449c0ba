import numpy as np
import pytest
import trimesh

import vecslice as vs
from vecslice.metrics import model_loops, resolution_stats


@pytest.fixture(scope="module")
def cylinder():
    return vs.load_mesh(trimesh.creation.cylinder(radius=10, height=3, sections=720))


def test_coarser_resolution_fewer_vertices_more_error(cylinder):
    raw = None
    stats = []
    for res in (100, 500, 2000):
        model = vs.slice_mesh(cylinder, vs.SliceSettings(max_resolution=res,
                                                          max_deviation=50))
        raw = raw or vs.slice_contours(cylinder, model.slice_z)
        stats.append(resolution_stats(model, raw, speed_mm_s=60))
    verts = [s.vertices for s in stats]
    err = [s.relative_error for s in stats]
    assert verts[0] >= verts[1] >= verts[2]
    assert err[0] <= err[1] <= err[2]
    for s in stats:  # moves/s = speed / mean edge
        assert s.moves_per_s == pytest.approx(60_000 / s.mean_edge_um)
        assert s.mean_edge_um == pytest.approx(s.perimeter_um / s.vertices)


def test_model_loops_and_identity(cylinder):
    model = vs.slice_mesh(cylinder)
    loops = model_loops(model)
    assert loops.n_layers == model.n_layers
    assert np.allclose(loops.layer_area2() / 2, model.layer_areas())
    assert resolution_stats(model, model).error_um2 == 0.0


def test_bad_arguments(cylinder):
    model = vs.slice_mesh(cylinder)
    with pytest.raises(vs.SettingsError, match=r"`speed_mm_s` must be finite and > 0 "
                       r"\(mm/s\); got 0\.0"):
        resolution_stats(model, model, speed_mm_s=0)
    # a speed in mm/s need not be whole, as in move_stats and sweep
    ref = vs.slice_contours(cylinder, model.slice_z)
    half = resolution_stats(model, ref, speed_mm_s=60.5)
    assert half.moves_per_s == pytest.approx(
        resolution_stats(model, ref, speed_mm_s=60).moves_per_s * 60.5 / 60)
    with pytest.raises(vs.InputTypeError, match="`reference` must be"):
        resolution_stats(model, [1, 2])
    with pytest.raises(vs.InputTypeError, match="`model` must be"):
        model_loops("model")


def test_relative_error_of_layers_near_the_coordinate_limit():
    """Audit s35 api D1: the area total was summed in int64 and wrapped for
    layers near the coordinate limit (three 2 km squares), giving a negative
    relative error (-9.0 instead of 0.6)."""
    s = 2**30 - 1
    big = [[-s, -s], [s, -s], [s, s], [-s, s]]
    small = [[x // 2, y // 2] for x, y in big]
    n = 3
    model = vs.SlicedModel(np.arange(n) * 100 + 50, np.arange(n) * 100 + 100,
                           [100] * n, np.arange(n + 1), np.arange(n + 1),
                           np.arange(n + 1) * 4, big * n)
    ref = vs.LayerPaths(small * n, np.arange(n + 1) * 4, np.arange(n + 1))
    a, b = (2 * s) ** 2, (2 * (s // 2) + 1) ** 2  # exact areas, µm² per layer
    stats = resolution_stats(model, ref)
    assert stats.error_um2 == pytest.approx(n * (a - b), rel=1e-12)
    assert stats.relative_error == pytest.approx((a - b) / (a + b), rel=1e-12)


def test_reference_with_other_layers_is_named_in_the_error():
    """Audit s35 api D3: resolution_stats passed a reference of another layer
    count on to layer_xor_areas, whose message named arguments `a` and `b`
    that resolution_stats does not have."""
    model = vs.SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 3],
                           [[0, 0], [10, 0], [0, 10]])
    ref = vs.LayerPaths([[0, 0], [10, 0], [0, 10]], [0, 3], [0, 1, 1])
    with pytest.raises(vs.InputValueError,
                       match=r"^`reference` must have as many layers as `model` "
                             r"\(1\); got 2$") as info:
        resolution_stats(model, ref)
    assert isinstance(info.value, ValueError)


# --- exact metrics: known answers ---------------------------------------------

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from vecslice.metrics import (  # noqa: E402
    contour_errors,
    layer_xor_areas,
    move_stats,
    simplification_errors,
    volume_error,
)


@pytest.mark.parametrize("d", [1, 5, 7, 25])
def test_square_with_one_vertex_pushed_out_deviates_by_d(d):
    # 800 µm square, the midpoint of one edge pushed out by d: simplification
    # (max_resolution 500 > the 400 µm half edges) removes it
    raw = vs.LayerPaths([[0, 0], [800, 0], [800 + d, 400], [800, 800], [0, 800]],
                        [0, 5], [0, 1])
    err, cleaned = simplification_errors(raw, vs.SliceSettings(max_deviation=25))
    assert cleaned.coords.tolist() == [[0, 0], [800, 0], [800, 800], [0, 800]]
    assert err.max_deviation_um == d
    assert err.raw_to_simplified_um.tolist() == [d]
    assert err.simplified_to_raw_um.tolist() == [0.0]
    assert err.area_error_um2 == 400 * d  # the triangle 800 x d / 2
    assert err.relative_area_error == pytest.approx(400 * d / (640000 + 400 * d))
    assert err.layer_max_deviation_um().tolist() == [d]
    assert err.rings_beyond(d) == 0 and err.rings_beyond(d - 0.5) == 1
    for bad, kind in (("5", vs.InputTypeError), (None, vs.InputTypeError),
                      (float("nan"), vs.SettingsError), (-1, vs.SettingsError)):
        with pytest.raises(kind, match="`limit_um` must be"):
            err.rings_beyond(bad)


def test_dropped_ring_counts_its_area():
    # a 200 µm triangle: perimeter < 1 mm, dropped before simplification
    raw = vs.LayerPaths([[0, 0], [200, 0], [0, 200]], [0, 3], [0, 1])
    err, cleaned = simplification_errors(raw)
    assert cleaned.ring_offsets.tolist() == [0, 0]
    assert err.dropped.tolist() == [True]
    assert np.isnan(err.max_deviation_um)
    assert err.area_error_um2 == 20000.0 and err.relative_area_error == 1.0


def test_cleaned_rings_are_clean_loops(cylinder):
    s = vs.SliceSettings(max_resolution=800, max_deviation=40)
    z, _, _ = vs.layer_heights(cylinder, s)
    raw = vs.slice_contours(cylinder, z)
    _, cleaned = simplification_errors(raw, s)
    want = vs.clean_loops(raw, s)
    keep = np.diff(cleaned.ring_offsets) > 0
    assert np.array_equal(cleaned.coords, want.coords)
    assert np.array_equal(np.diff(cleaned.ring_offsets)[keep],
                          np.diff(want.ring_offsets))


def test_ring_xor_matches_manifold3d_layer_xor_on_real_layers(meshes_dir):
    # the Voron cube's rings are simple and disjoint: ring-by-ring XOR areas
    # summed per layer equal the boolean XOR of whole layers
    mesh = vs.load_mesh(meshes_dir / "Voron_Design_Cube_v7.stl")
    s = vs.SliceSettings(layer_height=300, max_resolution=2000, max_deviation=100)
    z, _, _ = vs.layer_heights(mesh, s)
    raw = vs.slice_contours(mesh, z)
    err, cleaned = simplification_errors(raw, s)
    want = layer_xor_areas(raw, vs.clean_loops(raw, s))
    assert want.sum() > 1e6
    np.testing.assert_allclose(err.layer_xor_area_um2(), want, rtol=1e-6, atol=1e-2)
    assert err.linear.all()


def test_contour_errors_checks_its_input():
    a = vs.LayerPaths([[0, 0], [10, 0], [0, 10]], [0, 3], [0, 1])
    b = vs.LayerPaths([[0, 0], [10, 0], [0, 10]], [0, 3], [0, 0, 1])
    with pytest.raises(vs.InputValueError, match=r"`simplified` must have one ring.*"
                       "got 2 layers against 1 in `raw`"):
        contour_errors(a, b)
    c = vs.LayerPaths([[0, 0], [10, 0], [0, 10]] * 2, [0, 3, 6], [0, 2])
    with pytest.raises(vs.InputValueError, match="got 2 rings in layer 0 against 1"):
        contour_errors(a, c)
    with pytest.raises(vs.InputTypeError, match=r"`raw` must be a vecslice\.Layer"):
        contour_errors([1], a)
    with pytest.raises(vs.InputTypeError, match="`settings` must be"):
        simplification_errors(a, {"max_deviation": 3})


@pytest.mark.parametrize("n, r", [(12, 10_000), (200, 1_000), (6, 5_000)])
def test_regular_polygon_moves_by_hand(n, r):
    ang = 2 * np.pi * np.arange(n) / n
    pts = np.rint(np.stack([r * np.cos(ang), r * np.sin(ang)], 1)).astype(np.int64)
    st_ = move_stats(vs.Paths(pts, [0, n]), speed_mm_s=60, controller_ms=1.0,
                     percentiles=(0, 50, 100))
    edge = 2 * r * np.sin(np.pi / n)  # every side, up to the 0.5 µm rounding
    assert st_.moves == n
    assert st_.shortest_um == pytest.approx(edge, abs=1.0)
    assert st_.length_percentiles_um[1] == pytest.approx(edge, abs=1.0)
    assert st_.duration_percentiles_ms[1] == pytest.approx(edge / 60, abs=1 / 60)
    assert st_.moves_per_s == pytest.approx(60_000 / edge, rel=1e-3)
    assert st_.total_length_um == pytest.approx(n * edge, abs=n)
    # 60 mm/s for 1 ms is 60 µm: the 200-gon's 31.4 µm sides are all short
    assert st_.short_move_fraction == (1.0 if edge < 60 else 0.0)
    assert st_.print_time_s == pytest.approx(n * edge / 60_000, rel=1e-3)


def test_move_stats_checks_its_input():
    sq = vs.Paths([[0, 0], [10, 0], [10, 10], [0, 10]], [0, 4])
    with pytest.raises(vs.SettingsError, match="`speed_mm_s` must be finite and > 0"):
        move_stats(sq, speed_mm_s=0)
    with pytest.raises(vs.SettingsError, match="`controller_ms` must be finite"):
        move_stats(sq, controller_ms=float("nan"))
    with pytest.raises(vs.InputTypeError, match="`speed_mm_s` must be a number"):
        move_stats(sq, speed_mm_s="fast")
    with pytest.raises(vs.InputTypeError, match="`source` must be"):
        move_stats([[0, 0]])
    for bad in (50, "50", None):
        with pytest.raises(vs.InputTypeError, match="`percentiles` must be a sequence"):
            move_stats(sq, percentiles=bad)
    assert move_stats(sq, percentiles=np.array([50])).length_percentiles_um == (10.0,)
    none = move_stats(vs.Paths(np.zeros((0, 2), np.int64), [0]))
    assert none.moves == 0 and none.total_length_um == 0.0
    assert np.isnan([none.shortest_um, none.short_move_fraction, none.moves_per_s,
                     *none.length_percentiles_um]).all()  # as documented


def _prism(w, d, h):
    import trimesh

    box = trimesh.creation.box((w, d, h))
    box.apply_translation((0, 0, h / 2))
    return vs.Mesh.from_arrays(np.rint(box.vertices).astype(np.int64), box.faces)


@settings(max_examples=25)
@given(st.integers(2, 40).map(lambda k: 10 * k),
       st.integers(2, 40).map(lambda k: 10 * k),
       st.sampled_from(["middle", "inclusive"]))
def test_prism_has_no_volume_error_at_any_layer_height(th, init, tol):
    # an odd height in µm is never hit by the even cut heights, so no layer is
    # cut exactly at the top face ('exclusive' empties the top layer by design:
    # see the next test)
    mesh = _prism(10_000, 20_000, 5_001)
    s = vs.SliceSettings(layer_height=th, initial_layer_height=init,
                         slicing_tolerance=tol)
    st_ = volume_error(vs.slice_mesh(mesh, s), mesh)
    assert st_.mesh_volume_mm3 == pytest.approx(10 * 20 * 5.001, rel=1e-12)
    assert st_.volume_error_mm3 == pytest.approx(0.0, abs=1e-9)
    assert st_.layers == vs.slice_mesh(mesh, s).n_layers


def test_exclusive_prism_loses_exactly_its_top_layer():
    mesh = _prism(10_000, 20_000, 5_001)
    model = vs.slice_mesh(mesh, vs.SliceSettings(slicing_tolerance="exclusive"))
    bottom = int(model.print_z[-1] - model.thickness[-1])
    top = min(int(model.print_z[-1]), 5001) - bottom
    st_ = volume_error(model, mesh)
    assert model.layer_areas()[-1] == 0
    assert st_.volume_error_mm3 == pytest.approx(-200 * top / 1000, rel=1e-12)


@pytest.mark.parametrize("t", [100, 200, 300])
def test_square_cone_staircase_error_closed_form(t):
    # frustum of a square cone, half-width a - z: A(z) = 4 (a - z)^2, A'' = 8;
    # a cut at mid-layer loses A'' t^3 / 24 = t^3 / 3 per layer
    a, init, n = 20_000, 300, 40
    h = init + (n - 1) * t  # the layers tile [0, h] exactly
    v = np.array([[-a, -a, 0], [a, -a, 0], [a, a, 0], [-a, a, 0],
                  [-(a - h), -(a - h), h], [a - h, -(a - h), h], [a - h, a - h, h],
                  [-(a - h), a - h, h]])
    f = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                  [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    mesh = vs.Mesh.from_arrays(v, f)
    s = vs.SliceSettings(layer_height=t, initial_layer_height=init,
                         minimum_polygon_circumference=0)
    model = vs.slice_mesh(mesh, s)
    st_ = volume_error(model, mesh)
    assert st_.layers == n and st_.stack_height_um == h == st_.height_um
    want_um3 = -(init**3 + (n - 1) * t**3) / 3
    assert st_.mesh_volume_mm3 == pytest.approx(4 * (a**3 - (a - h) ** 3) / 3 * 1e-9)
    assert st_.volume_error_mm3 * 1e9 == pytest.approx(want_um3, rel=1e-6)
    assert st_.staircase_error_mm3 * 1e9 == pytest.approx(want_um3, rel=1e-6)


def test_the_staircase_alone_is_independent_of_the_xy_settings():
    """Audit s25 sweep D3: the volume error called "the staircase alone" held the
    XY simplification's area changes, 4.6x the staircase on this cone at the
    defaults and 44x at (2000, 100); the closed form held only with
    simplification off."""
    import trimesh

    mesh = vs.load_mesh(trimesh.creation.cone(radius=6, height=4, sections=48))
    off = vs.SliceSettings(max_resolution=0, max_deviation=0, max_area_deviation=0,
                           minimum_polygon_circumference=0)
    stats = [volume_error(vs.slice_mesh(mesh, s), mesh) for s in
             (off, vs.SliceSettings(),
              vs.SliceSettings(max_resolution=2000, max_deviation=100))]
    assert len({st_.staircase_error_mm3 for st_ in stats}) == 1
    z_only = stats[0].staircase_error_mm3
    assert z_only < 0  # a cone loses volume at mid-layer cuts
    assert stats[0].volume_error_mm3 == pytest.approx(z_only, abs=1e-4)
    assert stats[1].volume_error_mm3 < 3 * z_only  # the defaults: 4.6x
    assert stats[2].volume_error_mm3 < 30 * z_only
    assert stats[1].relative_staircase_error == pytest.approx(
        z_only / stats[1].reference_volume_mm3)


def test_short_stack_is_measured_against_the_volume_below_it():
    # 2.04 mm box at 0.1 mm: 18 layers reach 2.0 mm; the staircase error is 0
    mesh = _prism(10_000, 10_000, 2_040)
    st_ = volume_error(vs.slice_mesh(mesh), mesh)
    assert (st_.stack_height_um, st_.height_um) == (2000, 2040)
    assert st_.reference_volume_mm3 == pytest.approx(200.0, rel=1e-12)
    assert st_.volume_error_mm3 == pytest.approx(0.0, abs=1e-9)


def test_volume_error_measures_the_solid_whatever_the_winding(meshes_dir):
    """The slicer fills a body whatever its faces' winding; so does the
    staircase reference. hourglass.stl has 1,622 of 2,146 facets inside out:
    read without repair its signed volume is 7,858 mm³ for a solid of
    34,297 mm³ (its sections match trimesh's)."""
    path = meshes_dir / "hourglass.stl"
    fixed = vs.load_mesh(path, scale=1000)
    want = volume_error(vs.slice_mesh(fixed), fixed)
    assert want.mesh_volume_mm3 == pytest.approx(34_297.036, abs=1e-3)
    assert abs(want.relative_volume_error) < 1e-4
    raw = vs.load_mesh(path, scale=1000, repair=False)
    assert raw.volume * 1e-9 == pytest.approx(7_857.706, abs=1e-3)
    got = volume_error(vs.slice_mesh(raw), raw)
    assert got.mesh_volume_mm3 == pytest.approx(want.mesh_volume_mm3, rel=1e-12)
    # (the unrepaired faces slice a few µm differently: 0.003 mm³ of 34,297)
    assert got.volume_error_mm3 == pytest.approx(want.volume_error_mm3, abs=0.01)
    cura = vs.load_mesh(path, scale=1000, compat="cura")
    s = vs.SliceSettings(compat="cura")
    got = volume_error(vs.slice_mesh(cura, s), cura)
    assert got.mesh_volume_mm3 == pytest.approx(want.mesh_volume_mm3, rel=1e-9)
    assert abs(got.relative_volume_error) < 1e-4
    # and in the sweep's row, where a compat="cura" row reads the file itself
    t = vs.sweep({"hourglass": path}, {"compat": ["vecslice", "cura"]}, scale=1000)
    assert (t["relative_volume_error"].abs() < 1e-4).all(), t.to_string()


def test_volume_error_of_a_mesh_wholly_inside_out():
    # closed and consistent, every face reversed: the same solid, the same error
    mesh = _prism(10_000, 20_000, 5_001)
    inside_out = vs.Mesh(mesh.vertices, mesh.faces[:, ::-1])
    assert inside_out.volume < 0
    for tol in ("middle", "exclusive"):  # exclusive: the reference below the stack
        s = vs.SliceSettings(slicing_tolerance=tol)
        want = volume_error(vs.slice_mesh(mesh, s), mesh)
        got = volume_error(vs.slice_mesh(inside_out, s), inside_out)
        assert got.mesh_volume_mm3 == pytest.approx(10 * 20 * 5.001, rel=1e-12)
        assert got.reference_volume_mm3 == pytest.approx(want.reference_volume_mm3,
                                                         rel=1e-12)
        assert got.volume_error_mm3 == pytest.approx(want.volume_error_mm3,
                                                     abs=1e-9)


def test_volume_error_checks_its_input(cylinder):
    model = vs.slice_mesh(cylinder)
    with pytest.raises(vs.InputTypeError, match="`model` must be"):
        volume_error(cylinder, cylinder)
    with pytest.raises(vs.InputTypeError, match="`mesh` must be"):
        volume_error(model, model)


def test_threaded_compare_rings_matches_the_serial_kernel(monkeypatch):
    import sys

    from vecslice._kernels.metrics import compare_rings
    from vecslice._kernels.simplify import simplify_rings
    from vecslice._threads import chunk_bounds

    vm = sys.modules["vecslice.metrics"]
    monkeypatch.setattr(vm, "chunk_bounds",
                        lambda offs, threads=None: chunk_bounds(offs, threads=2,
                                                                min_chunk=300))
    rng = np.random.default_rng(5)
    lengths = rng.integers(3, 150, 300)
    offs = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    ring = np.repeat(np.arange(300), lengths)
    ang = 2 * np.pi * (np.arange(offs[-1]) - offs[ring]) / lengths[ring]
    rad = 2000 + rng.integers(-60, 61, offs[-1])
    coords = np.stack([np.rint(rad * np.cos(ang)) + 5000 * (ring % 20),
                       np.rint(rad * np.sin(ang)) + 5000 * (ring // 20)],
                      1).astype(np.int64)
    sc, so = simplify_rings(coords, offs, True, 500, 25, 50000)
    assert len(chunk_bounds(offs + so, threads=2, min_chunk=300)) > 3
    got = vm._compare_rings(coords, offs, sc, so)
    want = compare_rings(coords, offs, sc, so)
    assert want[2].max() > 0
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)


def test_deviation_is_measured_from_vertices():
    # a sliver whose middle vertex is dropped: every vertex is within 10 µm of the
    # other ring ((500, 90) is 10 µm from the top edge), though the simplified
    # edge's midpoint (500, 0) is 88.6 µm from the raw ring: as documented, the
    # deviation is a lower bound of the Hausdorff distance
    raw = vs.LayerPaths([[0, 0], [500, 90], [1000, 0], [1000, 100], [0, 100]],
                        [0, 5], [0, 1])
    simp = vs.LayerPaths([[0, 0], [1000, 0], [1000, 100], [0, 100]], [0, 4], [0, 1])
    err = contour_errors(raw, simp)
    assert err.max_deviation_um == 10.0
    assert err.raw_to_simplified_um.tolist() == [10.0]
    assert err.simplified_to_raw_um.tolist() == [0.0]
    mid_gap = 500 * 90 / np.hypot(500, 90)  # (500, 0) to the edge (0,0)-(500,90)
    assert mid_gap > 88 > err.max_deviation_um


def test_contour_errors_arrays_are_read_only():
    """Writing into a result array used to change max_deviation_um behind it."""
    from vecslice.metrics import simplification_errors

    raw = vs.slice_contours(vs.demo_mesh(), [2000, 7000])
    err, _ = simplification_errors(raw)
    for name in ("raw_to_simplified_um", "simplified_to_raw_um", "xor_area_um2",
                 "linear", "ring_layer", "raw_area_um2"):
        a = getattr(err, name)
        with pytest.raises(ValueError, match="read-only"):
            a[0] = a[0]


def test_contour_errors_never_freezes_or_keeps_the_callers_arrays():
    """Audit s25 api D1: a ContourErrors made from the caller's arrays made them
    read-only in place and kept them, so a write through an earlier view changed
    the result."""
    from vecslice.metrics import ContourErrors

    mine = {name: np.array(v) for name, v in [
        ("raw_to_simplified_um", [1.0, 2.0]), ("simplified_to_raw_um", [0.0, 0.0]),
        ("xor_area_um2", [5.0, 5.0]), ("linear", [True, True]),
        ("ring_layer", [0, 0]), ("raw_area_um2", [100.0])]}
    err = ContourErrors(**mine)
    view = mine["raw_to_simplified_um"][:1]
    view[0] = 999.0  # still writable, and not the result's
    assert err.raw_to_simplified_um.tolist() == [1.0, 2.0]
    for name, a in mine.items():
        assert a.flags.writeable, name
        assert not np.may_share_memory(getattr(err, name), a), name


@pytest.mark.parametrize("value", [10**400, -10**400])
def test_a_speed_beyond_float_range_is_a_settings_error(cylinder, value):
    """Audit s25 sweep D4: a bare OverflowError escaped."""
    model = vs.slice_mesh(cylinder)
    with pytest.raises(vs.SettingsError, match=r"`speed_mm_s` must be finite and > 0 "
                       r"\(mm/s\); got about -?10\*\*400$"):
        resolution_stats(model, model, speed_mm_s=value)
    with pytest.raises(vs.SettingsError, match=r"`controller_ms` must be finite and "
                                               r">= 0 \(ms\); got about -?10\*\*400$"):
        vs.metrics.move_stats(model, controller_ms=value)


def test_contour_errors_copies_stay_read_only():
    """Audit s26 state D3: a pickled or deep-copied ContourErrors had writeable
    arrays (unpickling skipped __post_init__'s freezing); a write then changed
    max_deviation_um."""
    import copy
    import pickle

    raw = vs.LayerPaths([[0, 0], [800, 0], [807, 400], [800, 800], [0, 800]],
                     [0, 5], [0, 1])
    err, _ = simplification_errors(raw)
    names = ("raw_to_simplified_um", "simplified_to_raw_um", "xor_area_um2",
             "linear", "ring_layer", "raw_area_um2")
    for clone in (pickle.loads(pickle.dumps(err)), copy.deepcopy(err),
                  copy.copy(err)):
        assert type(clone) is type(err)
        for name in names:
            a = getattr(clone, name)
            assert np.array_equal(a, getattr(err, name))
            assert not a.flags.writeable
            with pytest.raises(ValueError):
                a.flags.writeable = True
        assert clone.max_deviation_um == err.max_deviation_um == 7.0
