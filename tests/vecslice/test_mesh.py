import io
import json
import math
import random
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh

import vecslice as vs
from vecslice.demo import demo_mesh
from vecslice.meshcheck import components

# ---------------------------------------------------------------------------
# the shared meshes: facts from README.md / manifest.json, after our processing
# ---------------------------------------------------------------------------

SCALE = {
    "featuretype.STL": 25.4, "stanford-bunny.obj": 1000.0,
    "bun_zipper_res2.ply": 1000.0, "hourglass.stl": 1000.0,
}

# name: (faces read, faces loaded, faces repaired, vertices, bodies loaded,
#        bodies repaired, boundary, non-manifold loaded, duplicate faces loaded)
# Differences from the README table are ours on purpose and explained in
# test_differences_from_the_readme_are_explained.
FACTS = {
    "3DBenchy.3mf": (225154, 225146, 225146, 112565, 1, 1, 0, 0, 0),
    "Voron_Design_Cube_v7.stl": (3414, 3414, 3414, 1701, 1, 1, 0, 0, 0),
    "plate_holes.STL": (1252, 1252, 1252, 618, 1, 1, 0, 0, 0),
    "featuretype.STL": (3476, 3476, 3476, 1722, 1, 1, 0, 0, 0),
    "pyramids.3mf": (3276, 3276, 3276, 1662, 12, 12, 0, 0, 0),
    "stanford-bunny.obj": (69451, 69451, 69451, 34834, 1, 1, 223, 0, 0),
    "teapot.stl": (894, 894, 894, 480, 4, 4, 64, 0, 0),
    "openscad-nonmanifold-crash.obj": (1442, 1430, 1419, 635, 18, 6, 0, 37, 9),
    "hourglass.stl": (2146, 2146, 2146, 1075, 1, 1, 0, 0, 0),
    "bun_zipper_res2.ply": (16301, 16301, 16139, 8146, 94, 1, 123, 150, 87),
}

_raw: dict[str, vs.Mesh] = {}
_rep: dict[str, vs.Mesh] = {}


def manifest(meshes_dir: Path) -> dict[str, dict]:
    entries = json.loads((meshes_dir / "manifest.json").read_text())
    return {e["file"]: e for e in entries}


def raw(meshes_dir: Path, name: str) -> vs.Mesh:
    if name not in _raw:
        _raw[name] = vs.load_mesh(meshes_dir / name, scale=SCALE.get(name, 1.0),
                                  repair=False)
    return _raw[name]


def rep(meshes_dir: Path, name: str) -> vs.Mesh:
    if name not in _rep:
        _rep[name] = raw(meshes_dir, name).repaired()
    return _rep[name]


@pytest.mark.parametrize("name", sorted(FACTS))
def test_shared_mesh_facts(meshes_dir, name):
    e = manifest(meshes_dir)[name]
    assert e["scale_to_mm"] == SCALE.get(name, 1.0)
    f_in, f_raw, f_rep, n_v, bodies, bodies_rep, boundary, nonman, dup = FACTS[name]
    m, r = raw(meshes_dir, name), rep(meshes_dir, name)
    assert f_in == e["triangles"] == m.load_info.faces_in
    assert (m.n_faces, r.n_faces, m.n_vertices) == (f_raw, f_rep, n_v)
    assert m.vertices.dtype == m.faces.dtype == np.int64
    assert not m.vertices.flags.writeable and not m.faces.flags.writeable
    # bounding box in µm after the unit scale; the README rounds to 0.001 mm
    size = m.bounds[1] - m.bounds[0]
    assert np.abs(size - np.array(e["bbox_mm"]) * 1000).max() <= 1.5, size
    rm, rr = m.report(), r.report()
    assert (rm.n_bodies, rr.n_bodies) == (bodies, bodies_rep)
    assert (rm.boundary_edges, rm.nonmanifold_edges, rm.duplicate_faces) == (
        boundary, nonman, dup)
    assert rr.boundary_edges >= boundary and rr.duplicate_faces == 0
    assert rr.inconsistent_edges == 0
    assert rm.n_bodies == m.n_bodies and rm.is_watertight == m.is_watertight
    if e["watertight_after_merge"] and e["winding_consistent"]:
        assert m.is_watertight and r.is_watertight
        assert r.volume * 1e-9 == pytest.approx(e["volume_mm3"], rel=1e-5)
        assert r.volume == m.volume and r.load_info.faces_flipped == 0


def test_differences_from_the_readme_are_explained(meshes_dir):
    # README counts on trimesh's float merge with degenerate faces kept. We merge
    # exact µm positions and drop faces with a repeated vertex.
    # Benchy: the 4 two-triangle slivers (8 faces) collapse and are dropped, which
    # also removes the 6 non-manifold edges and the 4 extra bodies.
    benchy = raw(meshes_dir, "3DBenchy.3mf")
    assert benchy.load_info.faces_degenerate == 8
    assert benchy.load_info.vertices_merged == 112569 - 112565
    assert benchy.report().zero_area_faces + 8 == 19  # README: 19 zero-area faces
    assert benchy.is_watertight
    # openscad: vertices within 1 µm of each other merge too (717 records, 658
    # distinct float positions, 635 distinct µm positions), so more slivers
    # collapse than in the README (12 faces instead of 1).
    osc = raw(meshes_dir, "openscad-nonmanifold-crash.obj")
    li = osc.load_info
    assert (li.vertices_in, li.vertices_merged, li.vertices_unused) == (717, 82, 0)
    assert li.faces_degenerate == 12
    assert rep(meshes_dir, "openscad-nonmanifold-crash.obj").load_info \
        .faces_duplicate == 11
    # bun_zipper: 25 unused vertices (README); 79 of its 81 duplicate pairs are a
    # face and its reversed twin (they cancel), 2 are same-winding copies, and one
    # vertex set appears 3 times (net winding 1: keep 1) -> 162 faces removed
    bun = raw(meshes_dir, "bun_zipper_res2.ply")
    assert bun.load_info.vertices_unused == 25
    assert rep(meshes_dir, "bun_zipper_res2.ply").load_info.faces_duplicate == 162


def test_load_with_repair_equals_load_then_repaired(meshes_dir):
    m = vs.load_mesh(meshes_dir / "bun_zipper_res2.ply", scale=1000)
    r = rep(meshes_dir, "bun_zipper_res2.ply")
    assert np.array_equal(m.vertices, r.vertices) and np.array_equal(m.faces, r.faces)
    assert m.load_info == r.load_info


def test_unit_scales(meshes_dir):
    ft = raw(meshes_dir, "featuretype.STL")
    assert (ft.bounds[1] - ft.bounds[0]).tolist() == [127000, 63500, 34925]
    inch = vs.load_mesh(meshes_dir / "featuretype.STL", repair=False)
    assert (inch.bounds[1] - inch.bounds[0]).tolist() == [5000, 2500, 1375]
    hg = raw(meshes_dir, "hourglass.stl")
    assert hg.bounds.tolist() == [[-17000, -17000, -35000], [17000, 17000, 35000]]


def test_cura_meshes(meshes_dir):
    cube = vs.load_mesh(meshes_dir / "cura" / "cube.stl")
    assert cube.bounds.tolist() == [[0, 0, 0], [10000, 10000, 10000]]
    assert (cube.n_faces, cube.n_vertices, cube.is_watertight) == (12, 8, True)
    assert cube.volume == pytest.approx(1e12, rel=1e-12)
    cyl = vs.load_mesh(meshes_dir / "cura" / "cylinder1000.stl")
    assert cyl.n_faces == 3996 and cyl.is_watertight and cyl.zrange == (0, 10000)


def test_hourglass_repair(meshes_dir):
    e = manifest(meshes_dir)["hourglass.stl"]
    m, r = raw(meshes_dir, "hourglass.stl"), rep(meshes_dir, "hourglass.stl")
    rm = m.report()
    assert rm.is_closed and not rm.is_winding_consistent and not m.is_watertight
    assert rm.inconsistent_edges == 72
    # 1,622 of 2,146 facets were inside out; the README's signed volume after
    # consistent re-orientation is -34,297 mm³: outward repair makes it positive
    assert r.load_info.faces_flipped == e["faces_flipped_vs_repaired"] == 1622
    assert r.is_watertight and r.volume > 0
    assert r.volume * 1e-9 == pytest.approx(-e["volume_mm3"], rel=1e-5)
    assert np.array_equal(r.vertices, m.vertices)  # only windings change
    assert np.array_equal(np.sort(r.faces, axis=1), np.sort(m.faces, axis=1))
    again = r.repaired()
    assert again.load_info.faces_flipped == 1622  # nothing more flipped
    assert np.array_equal(again.faces, r.faces)


def test_ascii_and_binary_stl_agree(meshes_dir, tmp_path):
    data = (meshes_dir / "plate_holes.STL").read_bytes()
    assert data[:5] == b"solid" and len(data) == 84 + 50 * 1252  # binary, "solid"
    binary = raw(meshes_dir, "plate_holes.STL")
    soup = trimesh.load(meshes_dir / "plate_holes.STL", process=False)
    ascii_path = tmp_path / "plate_ascii.stl"
    ascii_path.write_text(trimesh.exchange.stl.export_stl_ascii(soup))
    assert ascii_path.read_bytes()[:5] == b"solid"
    text = vs.load_mesh(ascii_path, repair=False)
    assert np.array_equal(text.vertices, binary.vertices)
    assert np.array_equal(text.faces, binary.faces)


def test_hourglass_ascii_binary_roundtrip(meshes_dir, tmp_path):
    soup = trimesh.load(meshes_dir / "hourglass.stl", process=False)
    path = tmp_path / "hourglass_bin.stl"
    path.write_bytes(trimesh.exchange.stl.export_stl(soup))
    b = vs.load_mesh(path, scale=1000, repair=False)
    a = raw(meshes_dir, "hourglass.stl")
    # float32 storage moves no coordinate by more than a micron
    assert b.n_faces == a.n_faces and np.abs(b.vertices - a.vertices).max() <= 1


def test_3mf_build_items(meshes_dir):
    scene = trimesh.load(meshes_dir / "pyramids.3mf", process=False)
    assert len(scene.geometry) == 6 and len(scene.graph.nodes_geometry) == 12
    m = raw(meshes_dir, "pyramids.3mf")
    assert m.n_bodies == 12 and m.is_watertight
    assert m.zrange == (10025, 35025)  # placed z 10...35 mm
    # the three 4 mm cubes float at z 21...25 mm: 12 faces each, 8 vertices
    same = vs.load_mesh(scene, repair=False)
    # vecslice reads 3MF itself (in file order, trimesh in its graph's order):
    # the same triangles, each with the same winding
    assert np.array_equal(triangle_set(same), triangle_set(m))


def triangle_set(mesh):
    """The mesh's triangles as sorted rows of 9 coordinates, each triangle
    rotated (winding kept) to start at its lexicographically smallest corner."""
    t = mesh.vertices[mesh.faces]  # (F, 3, 3)
    key = (t[:, :, 0] * 2**21 + t[:, :, 1]) * 2**21 + t[:, :, 2]
    k = np.argmin(key, axis=1)
    idx = (k[:, None] + np.arange(3)) % 3
    rolled = np.take_along_axis(t, idx[:, :, None], axis=1).reshape(-1, 9)
    return rolled[np.lexsort(rolled.T[::-1])]


def test_trimesh_and_scene_input():
    box = trimesh.creation.box((10, 20, 30))
    m = vs.load_mesh(box)
    assert m.bounds.tolist() == [[-5000, -10000, -15000], [5000, 10000, 15000]]
    assert m.is_watertight and m.volume == 6e12 and m.load_info.source == \
        "trimesh.Trimesh"
    scene = trimesh.Scene()
    scene.add_geometry(box, transform=trimesh.transformations.translation_matrix(
        [100, 0, 0]))
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])  # a mirrored instance
    mirror[:3, 3] = [-100, 0, 0]
    scene.add_geometry(box, transform=mirror)
    s = vs.load_mesh(scene, repair=False)
    assert s.n_bodies == 2 and s.n_faces == 24 and s.is_watertight
    assert s.volume == 12e12  # the mirror's winding was reversed with it
    assert s.bounds.tolist() == [[-105000, -10000, -15000], [105000, 10000, 15000]]


def test_rounding_is_half_away_from_zero():
    tm = trimesh.Trimesh(vertices=[[0.0005, -0.0005, 0.0025], [1.0015, 0, 0],
                                   [0, 1, -0.0025]], faces=[[0, 1, 2]], process=False)
    m = vs.load_mesh(tm, repair=False)
    assert m.vertices.tolist() == [[1, -1, 3], [1002, 0, 0], [0, 1000, -3]]
    half = vs.load_mesh(tm, scale=0.5, repair=False)  # 0.00025 mm -> 0.25 µm
    assert half.vertices[1].tolist() == [501, 0, 0]  # 500.75 µm


def test_from_arrays_merges_and_cleans():
    v = [[0, 0, 0], [9, 0, 0], [5, 5, 5], [0, 9, 0], [9, 0, 0], [0, 0, 0]]
    f = [[0, 1, 3], [5, 3, 4], [0, 4, 1], [3, 5, 1]]
    m = vs.Mesh.from_arrays(v, f)
    # vertex 2 is unused, 4 == 1 and 5 == 0; face 2 then repeats vertex 1 (dropped);
    # faces 0 and 1 become the same triangle reversed (kept: repair's business)
    assert m.vertices.tolist() == [[0, 0, 0], [9, 0, 0], [0, 9, 0]]
    assert m.faces.tolist() == [[0, 1, 2], [0, 2, 1], [2, 0, 1]]
    li = m.load_info
    assert (li.vertices_merged, li.vertices_unused, li.faces_degenerate) == (2, 1, 1)
    assert m.report().duplicate_faces == 2
    # collinear (zero-area) faces are kept
    line = vs.Mesh.from_arrays([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]])
    assert line.n_faces == 1 and line.report().zero_area_faces == 1
    # merge=False keeps the arrays as given
    asis = vs.Mesh.from_arrays(v, f, merge=False)
    assert asis.vertices.tolist() == v and asis.faces.tolist() == f


def test_clean_mesh_is_unchanged_and_not_aliased():
    v = np.array([[0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6]])
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]], dtype=np.int32)
    m = vs.Mesh.from_arrays(v, f)
    assert np.array_equal(m.vertices, v) and np.array_equal(m.faces, f)
    v[0, 0] = 99
    assert m.vertices[0, 0] == 0
    with pytest.raises(ValueError):
        m.vertices[0, 0] = 1
    with pytest.raises(AttributeError):
        m.faces = f  # frozen


def tet(flip=()):
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    f[list(flip)] = f[list(flip)][:, ::-1]
    return vs.Mesh.from_arrays([[0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6]], f)


def test_repair_small_cases():
    assert tet().volume == 36.0 and tet().is_watertight
    inside_out = tet(flip=[0, 1, 2, 3])
    assert inside_out.volume == -36.0 and inside_out.report().is_winding_consistent
    assert inside_out.repaired().volume == 36.0
    one = tet(flip=[2])
    assert one.report().inconsistent_edges == 3
    r = one.repaired()
    assert r.is_watertight and r.volume == 36.0 and r.load_info.faces_flipped == 1
    # verbatim duplicate: one copy kept
    t = tet()
    dup = vs.Mesh.from_arrays(t.vertices, np.concatenate([t.faces, t.faces[:1]]))
    assert dup.repaired().n_faces == 4 and dup.repaired().is_watertight
    # two tetrahedra glued along a face: the face and its reversed twin cancel
    v = [[0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6], [0, 0, -6]]
    upper = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
    lower = [[0, 1, 2], [0, 4, 1], [1, 4, 2], [0, 2, 4]]
    glued = vs.Mesh.from_arrays(v, upper + lower)
    assert glued.report().nonmanifold_edges == 3 and not glued.is_watertight
    g = glued.repaired()
    assert g.n_faces == 6 and g.is_watertight and g.volume == 72.0
    assert g.load_info.faces_duplicate == 2
    # an open fan keeps the winding most of its faces had
    fan = vs.Mesh.from_arrays([[0, 0, 0], [10, 0, 0], [0, 10, 0], [-10, 0, 0],
                               [0, -10, 0]],
                              [[0, 1, 2], [0, 3, 2], [0, 3, 4]])
    fr = fan.repaired()
    assert fr.faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]
    # only a face and its twin: nothing left
    with pytest.raises(vs.InputValueError, match="no faces left"):
        vs.Mesh.from_arrays(t.vertices, [[0, 1, 2], [0, 2, 1]]).repaired()


def canonical(faces):
    f = np.asarray(faces)
    k = np.argmin(f, axis=1)
    rolled = np.stack([np.roll(row, -s) for row, s in zip(f, k)])
    return rolled[np.lexsort(rolled.T[::-1])]


@pytest.mark.parametrize("seed", range(5))
def test_repair_undoes_random_flips(seed):
    rng = np.random.default_rng(seed)
    base = demo_mesh() if seed % 2 else vs.load_mesh(
        trimesh.creation.icosphere(2, radius=5))
    f = base.faces.copy()
    flip = rng.random(len(f)) < 0.4
    f[flip] = f[flip][:, ::-1]
    perm = rng.permutation(len(f))
    broken = vs.Mesh.from_arrays(base.vertices, f[perm])
    fixed = broken.repaired()
    assert fixed.load_info.faces_flipped == flip.sum()
    assert np.array_equal(canonical(fixed.faces), canonical(base.faces))


def test_translated_and_to_trimesh():
    m = tet()
    t = m.translated(1000, -2000, 3)
    assert (t.bounds - m.bounds).tolist() == [[1000, -2000, 3]] * 2
    assert t.faces is m.faces
    back = vs.load_mesh(t.to_trimesh(), repair=False)
    assert np.array_equal(back.vertices, t.vertices)
    assert np.array_equal(back.faces, t.faces)
    with pytest.raises(vs.InputValueError, match="2\\*\\*30"):
        m.translated(2**30, 0, 0)


def test_report_text():
    r = tet(flip=[0]).report()
    text = str(r)
    assert "inconsistent edges  3" in text and "watertight          no" in text
    assert "source              arrays" in text
    assert not r.is_clean and tet().report().is_clean
    assert r.volume_mm3 == pytest.approx(r.volume * 1e-9)
    assert repr(tet()) == "Mesh(4 vertices, 4 faces, 0.006 x 0.006 x 0.006 mm)"


@pytest.mark.parametrize("seed", range(4))
def test_components_match_scipy(seed):
    csgraph = pytest.importorskip("scipy.sparse.csgraph")
    sparse = pytest.importorskip("scipy.sparse")
    rng = np.random.default_rng(seed)
    n = 2000
    a = rng.integers(0, n, 1500)
    b = rng.integers(0, n, 1500)
    labels, k = components(n, a, b)
    g = sparse.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    k2, lab2 = csgraph.connected_components(g, directed=False)
    assert k == k2
    pairs = set(zip(labels.tolist(), lab2.tolist()))
    assert len(pairs) == k  # the same partition
    _, first = np.unique(labels, return_index=True)
    assert np.all(np.diff(first) > 0)  # numbered in order of first node


def test_benchy_repair_changes_nothing_on_a_consistent_mesh(meshes_dir):
    # (its time is measured by benchmarks/bench_mesh.py::test_vecslice_repair)
    m = vs.load_mesh(meshes_dir / "3DBenchy.3mf", repair=False)
    r = m.repaired()
    assert r.n_faces == m.n_faces == 225146
    assert (r.load_info.faces_flipped, r.load_info.faces_duplicate,
            r.load_info.shells_reversed) == (0, 0, 0)
    assert np.array_equal(r.faces, m.faces) and np.array_equal(r.vertices, m.vertices)


# ---------------------------------------------------------------------------
# bad input: exact error type, builtin base and message fragment
# ---------------------------------------------------------------------------

TRI = [[0, 0, 0], [1000, 0, 0], [0, 1000, 0]]

ARRAY_CASES = [
    ("float", np.array(TRI, dtype=float), [[0, 1, 2]], vs.InputTypeError,
     TypeError, r"integer microns; got dtype float64.*load_mesh.*to_microns"),
    ("face out of range", TRI, [[0, 1, 3]], vs.InputValueError, ValueError,
     r"`faces` must index vertices in \[0, 3\); got 3 at face 0"),
    ("negative face", TRI, [[0, 1, 2], [0, -1, 2]], vs.InputValueError,
     ValueError, r"got -1 at face 1"),
    ("vertices 2d", [[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], vs.InputValueError,
     ValueError, r"`vertices` must have shape \(N, 3\); got shape \(3, 2\)"),
    ("faces quads", [*TRI, [5, 5, 5]], [[0, 1, 2, 3]], vs.InputValueError,
     ValueError, r"`faces` must have shape \(N, 3\)"),
    ("faces 1d", TRI, [0, 1, 2], vs.InputValueError, ValueError,
     r"`faces` must have shape"),
    ("no faces", TRI, np.empty((0, 3), dtype=np.int64), vs.InputValueError,
     ValueError, r"at least one triangle"),
    ("huge", [[0, 0, 0], [2**30, 0, 0], [0, 1, 0]], [[0, 1, 2]],
     vs.InputValueError, ValueError, r"`vertices` must satisfy \|value\| < 2\*\*30"),
    ("degenerate only", TRI, [[0, 1, 1], [2, 2, 0]], vs.InputValueError,
     ValueError, r"non-degenerate"),
    ("float faces", TRI, [[0.0, 1.0, 2.0]], vs.InputTypeError, TypeError,
     r"`faces` must be integer"),
    ("string", "abc", [[0, 1, 2]], vs.InputTypeError, TypeError,
     r"`vertices` must be an integer array"),
]


@pytest.mark.parametrize(("label", "v", "f", "err", "builtin", "match"),
                         ARRAY_CASES, ids=[c[0] for c in ARRAY_CASES])
def test_from_arrays_rejects(label, v, f, err, builtin, match):
    with pytest.raises(err, match=match) as info:
        vs.Mesh.from_arrays(v, f)
    assert isinstance(info.value, builtin) and isinstance(info.value, vs.VecsliceError)


def _write(tmp_path: Path, name: str, data: bytes | str) -> Path:
    p = tmp_path / name
    if isinstance(data, str):
        data = data.encode()
    p.write_bytes(data)
    return p


def _rezip(meshes_dir, how):
    """pyramids.3mf with its model XML damaged ('cut') or left out ('drop')."""
    src = zipfile.ZipFile(meshes_dir / "pyramids.3mf")
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as dst:
        for n in src.namelist():
            data = src.read(n)
            if n.endswith(".model"):
                if how == "drop":
                    continue
                data = data[: len(data) // 2]
            dst.writestr(n, data)
    return out.getvalue()


def _shared(meshes_dir, name, n=None):
    data = (meshes_dir / name).read_bytes()
    return data if n is None else data[:n]


FILE_CASES = [
    # (label, file name, content maker(meshes_dir) or None, error, builtin, match)
    ("missing", "missing.stl", None, vs.MeshFileError, OSError,
     r"mesh file not found: '.*missing\.stl'"),
    ("directory", "folder.stl", "DIR", vs.MeshFileError, OSError,
     r"'.*folder\.stl' is a directory"),
    ("empty", "empty.stl", lambda d: b"", vs.MeshFileError, OSError,
     r"'.*empty\.stl' is empty \(0 bytes\)"),
    ("empty obj", "empty.obj", lambda d: b"", vs.MeshFileError, OSError,
     r"is empty"),
    ("garbage stl", "garbage.stl",
     lambda d: random.Random(1).randbytes(500),
     vs.MeshFileError, OSError, r"garbage\.stl' is truncated or corrupt: its binary "
     r"STL header announces [\d,]+ triangles, which take [\d,]+ bytes \(84 \+ 50 "
     r"each\), but the file has 500 bytes$"),
    ("text stl", "text.stl", lambda d: "hello world\n", vs.MeshFileError,
     OSError, r"holds no triangles \(ASCII STL without"),
    ("truncated binary stl", "trunc.stl", lambda d: _shared(d, "teapot.stl", 3000),
     vs.MeshFileError, OSError,
     r"trunc\.stl' is truncated or corrupt: its binary STL header announces 894 "
     r"triangles, which take 44,784 bytes \(84 \+ 50 each\), but the file has 3,000 "
     r"bytes$"),
    ("truncated ascii stl", "trunc_ascii.stl",
     lambda d: _shared(d, "hourglass.stl", 3000), vs.MeshFileError, OSError,
     r"truncated\?"),
    ("garbage 3mf", "garbage.3mf", lambda d: b"PK\x03\x04" + b"\x00" * 300,
     vs.MeshFileError, OSError, r"cannot read '.*garbage\.3mf' as 3MF: BadZipFile"),
    ("truncated 3mf", "trunc.3mf", lambda d: _shared(d, "pyramids.3mf", 3000),
     vs.MeshFileError, OSError, r"cannot read .* as 3MF"),
    ("3mf cut xml", "cut.3mf", lambda d: _rezip(d, "cut"), vs.MeshFileError,
     OSError, r"as 3MF: XMLSyntaxError"),
    ("3mf no model", "nomodel.3mf", lambda d: _rezip(d, "drop"), vs.MeshFileError,
     OSError, r"nomodel\.3mf': 3MF holds no 3D model: _rels/\.rels names "
     r"'/3D/3dmodel\.model', which the package does not contain"),
    ("garbage ply", "garbage.ply", lambda d: b"\x13\x37" * 100, vs.MeshFileError,
     OSError, r"garbage\.ply' is not a PLY file"),
    ("truncated ply", "trunc.ply", lambda d: _shared(d, "bun_zipper_res2.ply", 3000),
     vs.MeshFileError, OSError, r"trunc\.ply' is truncated or corrupt: its PLY header "
     r"announces 8,171 'vertex' and 16,301 'face' elements \(at least 114,312 "
     r"bytes\), but 2,766 bytes follow"),
    ("points only obj", "points.obj", lambda d: "v 0 0 0\nv 1 0 0\n",
     vs.MeshFileError, OSError, r"holds no triangles"),
    ("bad index ply", "idx.ply", lambda d: (
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
     vs.MeshFileError, OSError, r"corrupt: face 0 refers to vertex 7"),
    ("bad index obj", "idx.obj", lambda d: "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
     vs.MeshFileError, OSError,
     r"idx\.obj' is corrupt: face 1 \(line 4\) refers to vertex 9; the file has 3 "
     r"vertices"),
    ("unknown extension", "mesh.foo", lambda d: "solid x\nendsolid x\n",
     vs.MeshFileError, OSError, r"unsupported mesh file type '\.foo'"),
    ("nan obj", "nan.obj", lambda d: "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
     vs.InputValueError, ValueError,
     r"`vertices` must be finite; got \[1\.0, 0\.0, nan\] at vertex 1"),
    ("inf obj", "inf.obj", lambda d: "v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n",
     vs.InputValueError, ValueError, r"`vertices` must be finite"),
    ("huge obj", "huge.obj", lambda d: "v 0 0 0\nv 2e6 0 0\nv 0 1 0\nf 1 2 3\n",
     vs.InputValueError, ValueError, r"`vertices` must be below"),
]


@pytest.mark.parametrize(("label", "name", "make", "err", "builtin", "match"),
                         FILE_CASES, ids=[c[0] for c in FILE_CASES])
def test_load_mesh_rejects_bad_files(meshes_dir, tmp_path, label, name, make, err,
                                     builtin, match):
    path = tmp_path / name
    if make == "DIR":
        path.mkdir()
    elif make is not None:
        data = make(meshes_dir)
        path.write_bytes(data.encode() if isinstance(data, str) else data)
    with pytest.raises(err, match=match) as info:
        vs.load_mesh(path)
    assert isinstance(info.value, builtin) and isinstance(info.value, vs.VecsliceError)
    with pytest.raises(err):  # str paths too
        vs.load_mesh(str(path))


BAD_ARGS = [
    ("int path", dict(path_or_trimesh=123), vs.InputTypeError, TypeError,
     r"`path_or_trimesh` must be a file path, trimesh\.Trimesh or trimesh\.Scene; "
     r"got int"),
    ("none", dict(path_or_trimesh=None), vs.InputTypeError, TypeError, r"got NoneType"),
    ("pointcloud", dict(path_or_trimesh=trimesh.PointCloud([[0, 0, 0]])),
     vs.InputTypeError, TypeError, r"got PointCloud"),
    ("empty trimesh", dict(path_or_trimesh=trimesh.Trimesh()), vs.InputValueError,
     ValueError, r"holds no triangles"),
    ("nan trimesh", dict(path_or_trimesh=trimesh.Trimesh(
        [[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], [[0, 1, 2]], process=False)),
     vs.InputValueError, ValueError, r"`vertices` must be finite.*vertex 2"),
    ("scale 0", dict(scale=0), vs.InputValueError, ValueError,
     r"`scale` must be a positive finite number \(file units to mm\); got 0\.0"),
    ("scale -1", dict(scale=-1), vs.InputValueError, ValueError, r"got -1\.0"),
    ("scale nan", dict(scale=float("nan")), vs.InputValueError, ValueError,
     r"`scale` must be a positive finite number.*got nan"),
    ("scale inf", dict(scale=math.inf), vs.InputValueError, ValueError, r"got inf"),
    ("scale str", dict(scale="2"), vs.InputTypeError, TypeError,
     r"`scale` must be a real number \(file units to mm\); got str '2'"),
    ("scale bool", dict(scale=True), vs.InputTypeError, TypeError, r"got bool"),
    ("scale huge", dict(scale=1e9), vs.InputValueError, ValueError,
     r"`vertices` must be below"),
    ("repair str", dict(repair="no"), vs.InputTypeError, TypeError,
     r"`repair` must be True or False; got str 'no'"),
    ("repair int", dict(repair=0), vs.InputTypeError, TypeError,
     r"`repair` must be True or False; got int 0"),
    ("repair none", dict(repair=None), vs.InputTypeError, TypeError,
     r"`repair` must be True or False; got NoneType None"),
]


@pytest.mark.parametrize(("label", "kwargs", "err", "builtin", "match"), BAD_ARGS,
                         ids=[c[0] for c in BAD_ARGS])
def test_load_mesh_rejects_bad_arguments(label, kwargs, err, builtin, match):
    kwargs = {"path_or_trimesh": trimesh.creation.box((1, 1, 1)), **kwargs}
    with pytest.raises(err, match=match) as info:
        vs.load_mesh(kwargs.pop("path_or_trimesh"), **kwargs)
    assert isinstance(info.value, builtin) and isinstance(info.value, vs.VecsliceError)


def test_boolean_options_must_be_bools():
    # issue 8 D8: "no" repaired and merged (truthiness)
    v = [[0, 0, 0], [9, 0, 0], [0, 9, 0], [9, 0, 0]]
    f = [[0, 1, 2], [0, 3, 2]]
    for bad in ("no", 0, 1.0, None, [True]):
        with pytest.raises(vs.InputTypeError, match=r"`merge` must be True or "
                           r"False; got "):
            vs.Mesh.from_arrays(v, f, merge=bad)
    assert vs.Mesh.from_arrays(v, f, merge=np.bool_(False)).n_vertices == 4
    assert vs.Mesh.from_arrays(v, f, merge=np.bool_(True)).n_vertices == 3
    box = trimesh.creation.box((1, 1, 1))
    inverted = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    assert vs.load_mesh(inverted, repair=np.bool_(False)).volume < 0
    assert vs.load_mesh(inverted, repair=np.True_).volume > 0


def test_layer_heights_rejects_a_trimesh():
    # issue 8 B4: a trimesh's millimetres were read as µm, giving 0 layers
    box = trimesh.creation.box((10, 10, 10))
    with pytest.raises(vs.InputTypeError, match=r"`mesh` must be a vecslice\.Mesh "
                       r"\(see vecslice\.load_mesh\); got Trimesh"):
        vs.layer_heights(box)
    z, _, _ = vs.layer_heights(vs.load_mesh(box))
    assert len(z) == 98  # 10 mm: 0.3 mm first layer, then 0.1 mm


def test_check_mesh_rejects_non_mesh():
    with pytest.raises(vs.InputTypeError, match=r"`mesh` must be a vecslice\.Mesh"):
        vs.check_mesh(trimesh.creation.box((1, 1, 1)))


@pytest.mark.parametrize("name", ["teapot.stl", "hourglass.stl", "pyramids.3mf",
                                  "openscad-nonmanifold-crash.obj",
                                  "bun_zipper_res2.ply"])
def test_damaged_files_never_leak_raw_exceptions(meshes_dir, tmp_path, name):
    data = (meshes_dir / name).read_bytes()
    rng = random.Random(name)
    path = tmp_path / name
    for trial in range(24):
        d = bytearray(data)
        if trial % 3 == 0:
            d = d[: rng.randrange(len(d))]
        elif trial % 3 == 1:
            for _ in range(rng.randrange(1, 40)):
                d[rng.randrange(len(d))] = rng.randrange(256)
        else:
            i = rng.randrange(len(d))
            d = d[:i] + bytes(rng.randrange(256) for _ in range(50)) + d[i:]
        path.write_bytes(bytes(d))
        try:
            m = vs.load_mesh(path)
        except vs.VecsliceError:
            continue
        assert m.n_faces > 0 and m.vertices.dtype == np.int64


def test_repair_errors_name_the_file(tmp_path):
    # audit s24 D11: a file whose faces all cancel in the repair gave an
    # InputValueError about `mesh`, not a MeshFileError naming the file
    facets = "".join(
        f"facet normal 0 0 0\nouter loop\nvertex {a}\nvertex {b}\nvertex {c}\n"
        "endloop\nendfacet\n"
        for a, b, c in [("0 0 0", "1 0 0", "0 1 0"), ("0 0 0", "0 1 0", "1 0 0")])
    path = tmp_path / "two_sided.stl"
    path.write_text(f"solid t\n{facets}endsolid t\n")
    with pytest.raises(vs.MeshFileError, match=r"'.*two_sided\.stl': `mesh` has no "
                       r"faces left after repair: every face cancels"):
        vs.load_mesh(path)
    assert vs.load_mesh(path, repair=False).n_faces == 2


class _Wrapped:
    """An array-like whose __array__ hands out the array it holds (xarray does)."""

    def __init__(self, a):
        self.a = a

    def __array__(self, dtype=None, copy=None):
        return self.a


def test_mesh_keeps_no_memory_its_caller_can_write():
    """Audit s25 api D1: ``Mesh(wrapped(V), wrapped(F))`` kept V and F themselves and
    froze them in place; writes through the caller's earlier views changed the
    validated mesh (9x the area), and a face index written afterwards crashed a
    kernel (SIGSEGV)."""
    box = trimesh.creation.box((10, 10, 10))
    V = np.round(np.asarray(box.vertices) * 1000).astype(np.int64)
    F = np.asarray(box.faces, dtype=np.int64)
    mesh = vs.Mesh(_Wrapped(V), _Wrapped(F))
    assert V.flags.writeable and F.flags.writeable
    assert not np.may_share_memory(mesh.vertices, V)
    assert not np.may_share_memory(mesh.faces, F)
    before = vs.slice_contours(mesh, [0]).coords.copy()
    V[:, :2] *= 3
    F[0, 2] = 10**6
    assert np.array_equal(vs.slice_contours(mesh, [0]).coords, before)
    assert int(mesh.faces.max()) == 7


@pytest.mark.parametrize("make", [vs.Mesh, vs.Mesh.from_arrays])
def test_load_info_of_another_type_is_refused(make):
    """Audit s25 api D3: AttributeError at once (from_arrays) or later (repaired,
    check_mesh)."""
    with pytest.raises(vs.InputTypeError,
                       match=r"`load_info` must be a vecslice.mesh.LoadInfo or None; "
                             r"got int 5"):
        make([[0, 0, 0], [9, 0, 0], [0, 9, 0]], [[0, 1, 2]], load_info=5)


def _tetra_arrays():
    v = np.array([[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 1000]], np.int64)
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]], np.int64)
    return v, f


@pytest.mark.parametrize("make", [
    vs.Mesh, vs.Mesh.from_arrays,
    lambda v, f: vs.Mesh.from_arrays(v, f, merge=False),
], ids=["Mesh", "from_arrays", "from_arrays-merge=False"])
@pytest.mark.parametrize(("which", "index", "value", "match"), [
    ("faces", (1, 0), 10**12,
     r"`faces` must index vertices in \[0, 4\); got 1000000000000 at face 1"),
    ("vertices", (2, 1), 2**40,
     r"`vertices` must satisfy \|value\| < 2\*\*30 µm .*got 1099511627776 at row 2"),
])
def test_mesh_checks_the_copy_it_keeps(write_when_copied, make, which, index, value,
                                       match):
    """Audit s26 state D2: Mesh() checked the caller's arrays, then copied them; a
    write by another thread in between gave a 'valid' mesh with face index 10**12
    for 4 vertices (slice_contours: SIGSEGV). from_arrays merged the caller's
    arrays in place of a copy: its kernels read indices the caller could change.
    Here the write lands just before the copy: the copy is what is checked."""
    v, f = _tetra_arrays()
    writes = write_when_copied({"faces": f, "vertices": v}[which], index, value)
    with pytest.raises(vs.InputValueError, match=match):
        make(v, f)
    assert writes == [index]


def test_from_arrays_merges_the_arrays_it_checked(monkeypatch):
    """D2: the merge kernels read the private copy, not the caller's arrays (a
    write after the checks, still in range here, changes nothing)."""
    import vecslice.mesh as mesh_module

    v, f = _tetra_arrays()
    expected = vs.Mesh.from_arrays(v.copy(), f.copy())
    real = mesh_module.clean_arrays

    def racing(*args, **kwargs):
        f[0] = [0, 1, 2]  # another thread, after the checks
        v[3, 2] = 5
        return real(*args, **kwargs)

    monkeypatch.setattr(mesh_module, "clean_arrays", racing)
    mesh = vs.Mesh.from_arrays(v, f)
    assert mesh.faces.tolist() == expected.faces.tolist()
    assert mesh.vertices.tolist() == expected.vertices.tolist()


def test_load_mesh_hands_its_own_arrays_over_without_a_copy(meshes_dir, monkeypatch):
    """D2 fix: from_arrays copies what its caller could write; load_mesh's arrays
    (the reader's, to_microns') are its own and are not copied again."""
    import vecslice.ragged as ragged

    copied = []
    real = ragged.adopt

    def counting(new, given):
        out = real(new, given)
        if not np.shares_memory(out, new):
            copied.append(len(new))
        return out

    real_copy = ragged._copy_extremes

    def counting_copy(src, dst):  # the copy private_int_extremes takes
        if dst is not None:
            copied.append(src.shape[0] // 3)
        return real_copy(src, dst)

    monkeypatch.setattr(ragged, "adopt", counting)
    monkeypatch.setattr(ragged, "_copy_extremes", counting_copy)
    mesh = vs.load_mesh(meshes_dir / "Voron_Design_Cube_v7.stl", repair=False)
    assert mesh.n_faces > 0 and copied == []
    tm = trimesh.creation.box((10, 10, 10))
    vs.load_mesh(tm, repair=False)
    assert copied == [len(tm.faces)]  # a trimesh's faces are its own: copied


def test_from_arrays_of_a_clean_mesh_keeps_its_own_copies():
    # a clean mesh's cleaning returns the arrays it was given: from_arrays gives
    # it private copies, so the caller's arrays stay the caller's (and writable)
    v, f = _tetra_arrays()
    mesh = vs.Mesh.from_arrays(v, f)
    assert mesh.load_info.vertices_merged == mesh.load_info.faces_degenerate == 0
    assert not np.shares_memory(mesh.vertices, v)
    assert not np.shares_memory(mesh.faces, f)
    assert v.flags.writeable and f.flags.writeable
    before = mesh.vertices.tolist(), mesh.faces.tolist()
    v[0] = [7, 7, 7]
    f[0] = f[0, ::-1]
    assert (mesh.vertices.tolist(), mesh.faces.tolist()) == before
