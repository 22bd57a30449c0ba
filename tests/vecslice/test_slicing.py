import numpy as np
import pytest
import trimesh
from hypothesis import assume, given

import reference
import vecslice as vs
from conftest import MESHES, load_testdata
from strategies import closed_meshes

# (file, scale to mm) of every mesh in ../shared/meshes
ALL_MESHES = [
    ("3DBenchy.3mf", 1.0), ("Voron_Design_Cube_v7.stl", 1.0),
    ("bun_zipper_res2.ply", 1000.0), ("featuretype.STL", 25.4),
    ("hourglass.stl", 1000.0), ("openscad-nonmanifold-crash.obj", 1.0),
    ("plate_holes.STL", 1.0), ("pyramids.3mf", 1.0),
    ("stanford-bunny.obj", 1000.0), ("teapot.stl", 1.0),
    ("cura/cube.stl", 1.0), ("cura/cylinder1000.stl", 1.0),
]
WATERTIGHT = [
    "Voron_Design_Cube_v7.stl", "featuretype.STL", "plate_holes.STL",
    "pyramids.3mf", "hourglass.stl", "cura/cube.stl", "cura/cylinder1000.stl",
]
_cache: dict[str, vs.Mesh] = {}


def mesh_of(name: str) -> vs.Mesh:
    if name not in _cache:
        path = MESHES / name
        if not path.exists():
            pytest.skip(f"{path} not found (../shared beside the project)")
        _cache[name] = vs.load_mesh(path, scale=dict(ALL_MESHES)[name])
    return _cache[name]


def simplify_collinear(ring: np.ndarray) -> list[tuple[int, int]]:
    """Drop repeated and exactly collinear vertices of a closed ring."""
    pts = [tuple(map(int, p)) for p in ring]
    changed = True
    while changed and len(pts) > 2:
        changed = False
        for i in range(len(pts)):
            a, b, c = pts[i - 1], pts[i], pts[(i + 1) % len(pts)]
            cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
            if b == a or cross == 0:
                del pts[i]
                changed = True
                break
    return pts


def test_cura_cube_gives_the_exact_square_on_every_layer():
    case = load_testdata("cura_slice_vectors.json")["Cube"]
    cfg = case["settings_microns"]
    mesh = mesh_of("cura/cube.stl")
    s = vs.SliceSettings(initial_layer_height=cfg["initial_layer_thickness"],
                         layer_height=cfg["layer_thickness"])
    z, _, _ = vs.layer_heights(mesh, s)
    assert z.tolist() == case["layer_z"]
    loops = vs.slice_contours(mesh, z)
    assert loops.n_layers == case["num_layers"] == 99
    square = [tuple(p) for p in case["expectation"]["square"]]
    for k in range(loops.n_layers):
        (ring,) = loops.layer(k)
        pts = simplify_collinear(ring)
        assert len(pts) == 4
        start = square.index(pts[0])
        assert pts == square[start:] + square[:start]  # same corners, CCW
    assert loops.open.n_rings == 0


def test_cura_cylinder_gives_one_loop_per_layer_close_to_the_circle():
    case = load_testdata("cura_slice_vectors.json")["Cylinder1000"]
    mesh = mesh_of("cura/cylinder1000.stl")
    loops = vs.slice_contours(mesh, case["layer_z"])
    assert loops.rings_per_layer().tolist() == [1] * 99
    ref = np.array(case["expectation"]["reference_circle"], dtype=np.int64)
    ref_area2 = reference.ring_area2(ref, [0, len(ref)])[0]
    for a2 in loops.area2():
        # relative difference of areas bounds the relative Hamming distance
        assert abs(a2 - ref_area2) / (abs(a2) + abs(ref_area2)) <= 0.002


@pytest.mark.parametrize("name", [n for n, _ in ALL_MESHES])
def test_every_mesh_slices(name):
    mesh = mesh_of(name)
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings(layer_height=200))
    loops = vs.slice_contours(mesh, z)
    assert loops.n_layers == len(z) > 0
    lo, hi = mesh.vertices[:, :2].min(axis=0), mesh.vertices[:, :2].max(axis=0)
    for part in (loops, loops.open):
        assert part.n_layers == len(z)
        if part.coords.size:
            assert (part.coords >= lo).all() and (part.coords <= hi).all()


def _manifold_area(mesh: vs.Mesh, z: int) -> float:
    import manifold3d as m3

    m = m3.Manifold(m3.Mesh(vert_properties=mesh.vertices.astype(np.float32),
                            tri_verts=mesh.faces.astype(np.uint32)))
    assert m.status() == m3.Error.NoError
    return m.slice(float(z)).area()


@pytest.mark.parametrize("name", WATERTIGHT)
def test_watertight_layers_close_and_match_manifold3d(name):
    mesh = mesh_of(name)
    z, _, t = vs.layer_heights(mesh, vs.SliceSettings())
    loops = vs.slice_contours(mesh, z)
    assert loops.open.n_rings == 0  # every loop closes
    area = loops.layer_area2() / 2
    # the crossings are rounded to 1 µm: the area moves by at most 1 µm per µm of
    # perimeter
    perim = np.zeros(loops.n_layers)
    for k in range(loops.n_layers):
        for ring in loops.layer(k):
            perim[k] += np.hypot(*(np.roll(ring, -1, 0) - ring).T).sum()
    for k in np.linspace(0, loops.n_layers - 1, 7).astype(int):
        assert abs(area[k] - _manifold_area(mesh, z[k])) <= perim[k] + 1, k
    vol = abs(float((area * t).sum()))
    assert abs(vol - abs(mesh.volume)) / abs(mesh.volume) < 0.01


@pytest.mark.parametrize("name", ["Voron_Design_Cube_v7.stl", "pyramids.3mf"])
def test_translation_in_xy_is_exact(name):
    mesh = mesh_of(name)
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings(layer_height=300))
    a = vs.slice_contours(mesh, z)
    shift = np.array([123_457, -98_761, 0])
    moved = vs.Mesh.from_arrays(mesh.vertices + shift, mesh.faces)
    b = vs.slice_contours(moved, z)
    assert (b.coords == a.coords + shift[:2]).all()
    assert (b.ring_offsets == a.ring_offsets).all()
    assert (b.layer_offsets == a.layer_offsets).all()


def test_uneven_and_unsorted_heights():
    mesh = mesh_of("Voron_Design_Cube_v7.stl")
    zmin = int(mesh.vertices[:, 2].min())
    z = zmin + np.array([29000, 50, 51, 7000, 12345, 50, 29999], dtype=np.int64)
    loops = vs.slice_contours(mesh, z)
    for k, zk in enumerate(z):
        single = vs.slice_contours(mesh, [zk])
        got = [r.tolist() for r in loops.layer(k)]
        assert got == [r.tolist() for r in single.layer(0)]
    assert [r.tolist() for r in loops.layer(1)] == [r.tolist() for r in loops.layer(5)]


def test_on_plane_rule_bottom_yes_top_no():
    mesh = mesh_of("cura/cube.stl")
    zmin, zmax = int(mesh.vertices[:, 2].min()), int(mesh.vertices[:, 2].max())
    loops = vs.slice_contours(mesh, [zmin, zmax, zmin - 1, zmax + 1])
    assert loops.rings_per_layer().tolist() == [1, 0, 0, 0]
    assert loops.layer_area2()[0] == 2 * 10000 * 10000


def test_holes_are_clockwise():
    mesh = mesh_of("plate_holes.STL")
    z, _, _ = vs.layer_heights(mesh, vs.SliceSettings(layer_height=1000))
    loops = vs.slice_contours(mesh, z)
    assert (loops.rings_per_layer() == 6).all()
    a2 = loops.area2().reshape(-1, 6)
    assert ((a2 > 0).sum(axis=1) == 1).all() and ((a2 < 0).sum(axis=1) == 5).all()


@given(closed_meshes())
def test_matches_slow_reference(case):
    v, f, planes = case
    mesh = vs.Mesh.from_arrays(v, f)
    assume(mesh.n_faces == len(f))  # rounding merged nothing: topology as built
    loops = vs.slice_contours(mesh, planes)
    assert loops.open.n_rings == 0
    for k, zk in enumerate(planes):
        ref_loops, ref_chains = reference.slice_layer(
            mesh.vertices, mesh.faces, int(zk)
        )
        assert ref_chains == []
        assert reference.canonical_layer(loops.layer(k)) == \
            reference.canonical_layer(ref_loops)


def test_empty_schedule_gives_no_layers():
    mesh = mesh_of("cura/cube.stl")
    loops = vs.slice_contours(mesh, np.empty(0, dtype=np.int64))
    assert loops.n_layers == 0 and loops.open.n_layers == 0


@pytest.mark.parametrize(
    ("mesh_arg", "z", "error", "fragment"),
    [
        ("cube.stl", [0], vs.InputTypeError, "`mesh` must be a vecslice.Mesh"),
        (None, [0.5], vs.InputTypeError, "`slice_z` must be integer microns"),
        (None, [[0, 1]], vs.InputValueError, r"`slice_z` must have shape \(N\)"),
        (None, [2**30], vs.InputValueError, "`slice_z` must satisfy"),
        (None, "10", vs.InputTypeError, "`slice_z` must be an integer array"),
        (None, None, vs.InputTypeError, "`slice_z`"),
    ],
)
def test_bad_input(mesh_arg, z, error, fragment):
    mesh = mesh_arg if mesh_arg is not None else mesh_of("cura/cube.stl")
    with pytest.raises(error, match=fragment) as info:
        vs.slice_contours(mesh, z)
    assert isinstance(info.value, (ValueError, TypeError))


def test_topology_is_built_once_per_mesh(monkeypatch):
    from concurrent.futures import ThreadPoolExecutor

    from vecslice._kernels import topology

    calls = []
    build = topology.half_edge_twins

    def counted(faces, n_vertices, **kw):
        calls.append(len(faces))
        return build(faces, n_vertices, **kw)

    monkeypatch.setattr(topology, "half_edge_twins", counted)
    mesh = vs.load_mesh(trimesh.creation.icosphere(subdivisions=2, radius=10))
    first = vs.slice_contours(mesh, [-5000, 0, 5000])
    again = vs.slice_contours(mesh, [-5000, 0, 5000])
    vs.slice_contours(mesh, [-2500, 2500])
    vs.slice_mesh(mesh)
    assert calls == [mesh.n_faces]
    assert first.coords.tolist() == again.coords.tolist()
    # same faces: a translated copy shares the topology; a new mesh builds its own
    moved = mesh.translated(1000, 0, 0)
    assert (vs.slice_contours(moved, [0]).coords
            == first.layer(1)[0] + [1000, 0]).all()
    assert len(calls) == 1
    fresh = vs.Mesh.from_arrays(mesh.vertices, mesh.faces)
    vs.slice_contours(fresh, [0])
    assert len(calls) == 2
    # threads slicing one new mesh at once: built at most once per thread, and
    # every result is the one a single thread gets
    shared = vs.Mesh.from_arrays(mesh.vertices, mesh.faces)
    with ThreadPoolExecutor(4) as pool:
        outs = list(pool.map(lambda _: vs.slice_contours(shared, [-5000, 0, 5000]),
                             range(8)))
    assert 3 <= len(calls) <= 6
    assert all(o.coords.tolist() == first.coords.tolist() for o in outs)
    assert all(o.ring_offsets.tolist() == first.ring_offsets.tolist() for o in outs)


def test_pickled_mesh_leaves_its_topology_behind_and_slices_the_same():
    import pickle

    mesh = vs.load_mesh(trimesh.creation.icosphere(subdivisions=2, radius=10))
    first = vs.slice_contours(mesh, [-5000, 0, 5000])
    payload = pickle.dumps(mesh)
    assert len(payload) < mesh.vertices.nbytes + mesh.faces.nbytes + 2000
    copy = pickle.loads(payload)
    assert not copy.vertices.flags.writeable and not copy.faces.flags.writeable
    again = vs.slice_contours(copy, [-5000, 0, 5000])
    assert again.coords.tolist() == first.coords.tolist()
    assert again.ring_offsets.tolist() == first.ring_offsets.tolist()


@pytest.mark.parametrize(("module", "limit", "refused", "message"), [
    # the half-edge ids are int32: a mesh of 2**31 / 3 faces or more is refused
    # by name before the topology is built (such a mesh would take 17 GB of faces)
    ("topology", "TWIN_LIMIT", 36, r"`mesh` has 12 faces; slicing takes at most 11 "
     r"\(its half-edges are numbered in int32\)"),
    # the contour kernels read the faces as int32: a mesh of more than 2**31
    # vertices is refused by name (it would take 48 GB of vertices)
    ("contours", "NARROW_LIMIT", 7, r"`mesh` has 8 vertices; slicing takes at most 7 "
     r"\(its face indices are read as int32\)"),
])
def test_too_large_for_int32_ids_is_a_clear_error(monkeypatch, module, limit, refused,
                                                  message):
    # the limits are lowered here: a box has 12 faces and 8 vertices
    import importlib

    kernels = importlib.import_module(f"vecslice._kernels.{module}")
    box = vs.load_mesh(trimesh.creation.box((10, 10, 10)))
    monkeypatch.setattr(kernels, limit, refused)
    with pytest.raises(vs.InputValueError, match=message):
        vs.slice_contours(box, [0])
    monkeypatch.setattr(kernels, limit, refused + 1)
    assert vs.slice_contours(box, [0]).layer_area2().tolist() == [200_000_000]


def test_int32_faces_are_made_once_per_mesh_and_equal_its_faces():
    mesh = vs.load_mesh(trimesh.creation.icosphere(subdivisions=2, radius=10))
    vs.slice_contours(mesh, [0])
    f32 = mesh._narrow_faces()
    assert f32.dtype == np.int32 and (f32 == mesh.faces).all()
    assert not f32.flags.writeable
    vs.slice_contours(mesh, [-5000, 5000])
    vs.slice_mesh(mesh)
    assert mesh._narrow_faces() is f32
    assert mesh.translated(1000, 0, 0)._narrow_faces() is f32  # same faces


def test_closed_topology_is_found_once_per_mesh_and_kept_by_translated_copies():
    box = vs.load_mesh(trimesh.creation.box((10, 10, 10)))
    assert box._closed is None
    vs.slice_contours(box, [0])
    assert box._closed is True  # found by the first slice, with the twins
    assert box.translated(0, 0, 1000)._closed is True
    # a face taken away: three open edges, and the open chain is still found
    opened = vs.Mesh.from_arrays(box.vertices, box.faces[1:])
    loops = vs.slice_contours(opened, [0], stitch=False)
    assert opened._closed is False
    assert loops.n_rings + loops.open.n_rings == 1


def test_slice_contours_checks_the_heights_it_cuts(write_when_copied, monkeypatch):
    """Audit s26 state D2: slice_z was checked (range, then sorted or not) in the
    caller's memory, which the kernels then read: a write by another thread in
    between reached them unchecked (they rely on the sorted order). Here the
    write lands just before the copy, or after the checks."""
    import vecslice.slicing as slicing_module

    box = vs.load_mesh(trimesh.creation.box((10, 10, 10)))
    z = np.array([-1000, 1000], np.int64)
    writes = write_when_copied(z, 1, 2**30)
    with pytest.raises(vs.InputValueError,
                       match=r"`slice_z` must satisfy \|value\| < 2\*\*30"):
        vs.slice_contours(box, z)
    assert writes == [1]
    z[1] = 1000
    want = vs.slice_contours(box, z.copy()).layer_area2().tolist()
    real = slicing_module.check_layer_count

    def racing(*args, **kwargs):
        z[:] = [1000, -6000]  # another thread, after the checks: a height below
        return real(*args, **kwargs)  # the box, and the order reversed

    monkeypatch.setattr(slicing_module, "check_layer_count", racing)
    assert vs.slice_contours(box, z).layer_area2().tolist() == want
