import numpy as np
import pytest
import trimesh

import vecslice as vs
from conftest import MESHES, load_testdata

WATERTIGHT = [
    ("Voron_Design_Cube_v7.stl", 1.0), ("featuretype.STL", 25.4),
    ("plate_holes.STL", 1.0), ("pyramids.3mf", 1.0), ("hourglass.stl", 1000.0),
    ("cura/cylinder1000.stl", 1.0),
]
_cache: dict = {}


def mesh_of(name, scale=1.0):
    if name not in _cache:
        path = MESHES / name
        if not path.exists():
            pytest.skip(f"{path} not found (../shared beside the project)")
        _cache[name] = vs.load_mesh(path, scale=scale)
    return _cache[name]


def counts(model, k):
    parts = model.layer(k)
    return len(parts), sum(len(h) for _, h in parts)


def check_layout(model):
    a2 = vs.Paths(model.coords, model.ring_offsets).area2()
    first = np.zeros(len(a2), dtype=bool)
    first[model.part_offsets[:-1]] = True
    assert (a2[first] > 0).all() and (a2[~first] < 0).all()


@pytest.mark.parametrize(("name", "scale"), WATERTIGHT)
def test_part_and_hole_counts_match_manifold3d(name, scale):
    import manifold3d as m3

    mesh = mesh_of(name, scale)
    man = m3.Manifold(m3.Mesh(vert_properties=mesh.vertices.astype(np.float32),
                              tri_verts=mesh.faces.astype(np.uint32)))
    assert man.status() == m3.Error.NoError
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings())
    model = vs.make_parts(vs.slice_contours(mesh, z))
    for k in np.linspace(0, len(z) - 1, 9).astype(int):
        pieces = man.slice(float(z[k])).decompose()
        want = (len(pieces), sum(len(p.to_polygons()) - 1 for p in pieces))
        q0, q1 = model.layer_offsets[k], model.layer_offsets[k + 1]
        holes = int((np.diff(model.part_offsets)[q0:q1] - 1).sum())
        assert (int(q1 - q0), holes) == want, (name, k)


def test_plate_holes_is_one_part_with_five_holes_everywhere():
    model = vs.slice_mesh(mesh_of("plate_holes.STL"))
    assert model.n_layers == 125  # 12.7 mm: round((12700 - 300) / 100) + 1
    assert all(counts(model, k) == (1, 5) for k in range(model.n_layers))
    check_layout(model)


def test_multi_body_plate_gives_one_part_per_body():
    mesh = mesh_of("pyramids.3mf")
    model = vs.slice_mesh(mesh)
    z0, z1 = mesh.zrange
    # bodies at 25/50/75 % height: 9 pyramids; 9 pyramids + 3 floating cubes
    for frac, want in ((0.25, 9), (0.5, 12), (0.75, 9)):
        k = int(np.searchsorted(model.slice_z, z0 + frac * (z1 - z0)))
        assert counts(model, k) == (want, 0)


def _two_overlapping_boxes():
    a = trimesh.creation.box((10, 10, 2))
    b = trimesh.creation.box((10, 10, 2))
    b.apply_translation((5, 0, 0))
    return vs.load_mesh(trimesh.util.concatenate([a, b]))


def test_overlapping_bodies_merge_with_nonzero_not_with_even_odd():
    mesh = _two_overlapping_boxes()
    union = vs.slice_mesh(mesh)
    xor = vs.slice_mesh(mesh, vs.SliceSettings(union_overlapping_volumes=False))
    k = union.n_layers // 2
    assert counts(union, k) == (1, 0)
    assert union.layer_areas()[k] == 15_000 * 10_000
    assert counts(xor, k) == (2, 0)
    assert xor.layer_areas()[k] == 2 * 5_000 * 10_000


def cura_settings(case):
    """SliceSettings from a CuraEngine slicing test's settings."""
    cfg = case["settings_microns"]
    return vs.SliceSettings(initial_layer_height=cfg["initial_layer_thickness"],
                            layer_height=cfg["layer_thickness"],
                            max_resolution=cfg["max_resolution"],
                            max_deviation=cfg["max_deviation"],
                            max_area_deviation=cfg["max_area_deviation"],
                            minimum_polygon_circumference=cfg["min_circumference"])


def test_cura_cube_end_to_end_is_the_square():
    case = load_testdata("cura_slice_vectors.json")["Cube"]
    s = cura_settings(case)
    model = vs.slice_mesh(mesh_of("cura/cube.stl"), s)
    assert model.n_layers == 99 and model.slice_z.tolist() == case["layer_z"]
    square = sorted(map(tuple, case["expectation"]["square"]))
    for k in range(99):
        ((outline, holes),) = model.layer(k)
        assert holes == [] and sorted(map(tuple, outline.tolist())) == square
    check_layout(model)


def test_cura_cylinder_end_to_end_within_cura_tolerance():
    shapely = pytest.importorskip("shapely")
    case = load_testdata("cura_slice_vectors.json")["Cylinder1000"]
    s = cura_settings(case)
    model = vs.slice_mesh(mesh_of("cura/cylinder1000.stl"), s)
    ref = shapely.Polygon(case["expectation"]["reference_circle"])
    for k in range(0, 99, 7):
        ((outline, holes),) = model.layer(k)
        poly = shapely.Polygon(outline)
        ham = poly.symmetric_difference(ref).area / (poly.area + ref.area)
        assert ham <= case["expectation"]["max_relative_hamming"]


def _upside_down_pyramid():
    v = np.array([[-5000, -5000, 5000], [5000, -5000, 5000], [5000, 5000, 5000],
                  [-5000, 5000, 5000], [0, 0, 0]], dtype=np.int64)
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 1], [1, 4, 2], [2, 4, 3], [3, 4, 0]])
    return vs.Mesh.from_arrays(v, f)


def test_inclusive_and_exclusive_tolerance():
    mesh = _upside_down_pyramid()  # grows upwards
    raw = {}
    for mode in ("inclusive", "exclusive"):
        s = vs.SliceSettings(slicing_tolerance=mode, max_deviation=0,
                             max_resolution=0, minimum_polygon_circumference=0)
        z, _, _ = vs.layer_heights(mesh, s)
        raw[mode] = vs.slice_contours(mesh, z).layer_area2() / 2
        assert (raw[mode][1:] > 0).all()  # layer 0 of inclusive is at the tip
        model = vs.slice_mesh(mesh, s)
        areas = model.layer_areas()
        if mode == "inclusive":  # layer n = union(n, n + 1) = the larger, upper one
            assert np.allclose(areas[:-1], raw[mode][1:], rtol=2e-3)
        else:  # layer n = intersection(n, n + 1) = the lower one; top layer cleared
            assert np.allclose(areas[:-1], raw[mode][:-1], rtol=2e-3)
            assert areas[-1] == 0


def test_memory_is_at_most_17_bytes_per_vertex():
    path = MESHES / "3DBenchy.3mf"
    if not path.exists():
        pytest.skip(f"{path} not found")
    model = vs.slice_mesh(vs.load_mesh(path))
    n = model.coords.shape[0]
    assert n > 40_000
    assert model.nbytes / n <= 17


def test_save_load_round_trip_and_progress(tmp_path, capsys):
    model = vs.slice_mesh(mesh_of("Voron_Design_Cube_v7.stl"), progress=True)
    err = capsys.readouterr().err
    assert "stage" in err and "done" in err
    model.save(tmp_path / "voron.npz")
    back = vs.load_sliced(tmp_path / "voron.npz")
    for name in ("coords", "ring_offsets", "part_offsets", "layer_offsets",
                 "slice_z", "print_z", "thickness"):
        assert np.array_equal(getattr(back, name), getattr(model, name))


def test_stage_times_and_defaults_are_reported():
    times = vs.StageTimes()
    vs.slice_mesh(mesh_of("Voron_Design_Cube_v7.stl"), times=times)
    assert set(times.seconds) == {"layers", "contours", "stitch", "simplify",
                                  "tolerance", "parts", "store"}
    assert "total" in str(times)


def test_slice_mesh_rejects_bad_settings():
    with pytest.raises(vs.InputTypeError, match="`settings` must be"):
        vs.slice_mesh(mesh_of("Voron_Design_Cube_v7.stl"), {"layer_height": 100})


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        # Issue 8 C3: times={} raised AttributeError after the whole slice
        ({"times": {}}, "`times` must be a vecslice.StageTimes or None; got dict"),
        ({"times": []}, "got list"),
        # Issue 8 D8: options by truthiness
        ({"progress": "no"}, "`progress` must be True or False; got str 'no'"),
        ({"progress": 1}, "`progress` must be True or False; got int 1"),
    ],
)
def test_slice_mesh_checks_arguments_before_any_work(kwargs, fragment, monkeypatch):
    def no_work(*args, **kw):
        raise AssertionError("slicing started before the arguments were checked")

    monkeypatch.setattr(vs.pipeline, "layer_heights", no_work)
    mesh = vs.load_mesh(trimesh.creation.box((10, 10, 2)))
    with pytest.raises(vs.InputTypeError, match=fragment):
        vs.slice_mesh(mesh, **kwargs)


def test_memory_per_layer_is_arrays_not_python_objects():
    """Issue 8 A5: per-layer Python objects made a tall mesh cost > 1 kB per layer.

    Traced allocations (numpy arrays and Python objects) at their peak stay
    within 5x the model's own bytes per layer (before: 7.5x, 893 B per layer).
    """
    import tracemalloc

    v = [[0, 0, 0], [10_000, 0, 0], [0, 10_000, 0], [3000, 3000, 2_000_000]]
    mesh = vs.Mesh.from_arrays(v, [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
    settings = vs.SliceSettings(initial_layer_height=100)
    vs.slice_mesh(mesh, settings.replace(layer_height=100_000))  # compile, caches
    tracemalloc.start()
    try:
        model = vs.slice_mesh(mesh, settings)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert model.n_layers == 20_000
    assert peak / model.n_layers <= 5 * model.nbytes / model.n_layers


def test_clean_loops_checks_its_arguments():
    raw = vs.slice_contours(vs.demo_mesh(), [2000, 7000])
    assert vs.clean_loops(raw).coords.tolist() == vs.clean_loops(
        raw, vs.SliceSettings()).coords.tolist()  # settings default to Cura's
    with pytest.raises(vs.InputTypeError, match="`settings` must be a vecslice"):
        vs.clean_loops(raw, {"max_deviation": 25})
    with pytest.raises(vs.InputTypeError, match="`loops` must be a vecslice"):
        vs.clean_loops(raw.paths(), vs.SliceSettings())  # used to be AttributeError


def _filter_then_simplify(loops, s):
    """_clean_closed as it was: the short loops taken out first, then simplified."""
    from vecslice._kernels.rings import take_rings
    from vecslice._kernels.simplify import remove_degenerate_vertices, ring_perimeters
    from vecslice.simplify import simplify_rings

    keep = ring_perimeters(loops.coords, loops.ring_offsets) >= (
        s.minimum_polygon_circumference)
    kc, ko = take_rings(loops.coords, loops.ring_offsets, keep)
    c, o = simplify_rings(kc, ko, True, s.max_resolution, s.max_deviation,
                          s.max_area_deviation)
    c, o = remove_degenerate_vertices(c, o)
    lens = np.zeros(loops.n_rings, dtype=np.int64)
    lens[keep] = np.diff(o)
    return c, np.concatenate([[0], np.cumsum(lens)])


@pytest.mark.parametrize("seed", range(12))
def test_clean_closed_drops_short_loops_after_simplifying_as_before(seed):
    # every loop is simplified on its own, so simplifying all of them and leaving
    # the short ones out afterwards gives what filtering first gave
    from vecslice.pipeline import _clean_closed

    rng = np.random.default_rng(seed)
    rings, layers = [], [0]
    for _ in range(int(rng.integers(1, 6))):  # layers
        for _ in range(int(rng.integers(0, 8))):  # loops of the layer
            n = int(rng.integers(3, 60))
            radius = float(rng.choice([60.0, 150.0, 2000.0]))  # some under 1 mm
            t = np.sort(rng.uniform(0, 2 * np.pi, n))
            r = radius + rng.normal(0, radius / 20, n)
            rings.append(np.stack([r * np.cos(t), r * np.sin(t)], axis=1).round())
        layers.append(len(rings))
    offsets = np.concatenate([[0], np.cumsum([len(r) for r in rings])])
    coords = (np.concatenate(rings) if rings else np.zeros((0, 2))).astype(np.int64)
    loops = vs.LayerPaths(coords, offsets, layers)
    for s in (vs.SliceSettings(), vs.SliceSettings(minimum_polygon_circumference=0),
              vs.SliceSettings(minimum_polygon_circumference=50_000)):
        got_c, got_o = _clean_closed(loops, s)
        ref_c, ref_o = _filter_then_simplify(loops, s)
        assert got_o.tolist() == ref_o.tolist()
        assert got_c.tolist() == ref_c.tolist()
