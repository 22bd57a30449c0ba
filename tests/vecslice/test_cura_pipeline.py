"""compat="cura" end to end against CuraEngine's own stages (testdata/cura_e2e)."""

import numpy as np
import pytest
import trimesh

import vecslice as vs
from vecslice.cura_pipeline import cura_before_union, cura_clean, cura_stages
from vecslice.cura_slicing import CuraLayers, cura_raw

E2E = {
    "voron": "Voron_Design_Cube_v7.stl",
    "plate_holes": "plate_holes.STL",
    "cube": "cura/cube.stl",
    "cylinder1000": "cura/cylinder1000.stl",
}
CURA = vs.SliceSettings(compat="cura")


def _canon(ring):
    """A ring as a cyclic sequence: rotated to start at its smallest vertex."""
    r = [tuple(map(int, p)) for p in ring]
    i = min(range(len(r)), key=r.__getitem__)
    return tuple(r[i:] + r[:i])


def _stage(coords, ring_offsets, layer_offsets, explicit=None):
    """Per layer: sorted list of (cyclic ring, explicit flag)."""
    out = []
    for k in range(len(layer_offsets) - 1):
        rings = []
        for i in range(layer_offsets[k], layer_offsets[k + 1]):
            flag = bool(explicit[i]) if explicit is not None else False
            rings.append((_canon(coords[ring_offsets[i] : ring_offsets[i + 1]]), flag))
        out.append(sorted(rings))
    return out


def _ours(layers: CuraLayers):
    p = layers.polygons
    return _stage(p.coords, p.ring_offsets, p.layer_offsets, layers.explicit)


def _theirs(data, name):
    return _stage(data[f"{name}_coords"], data[f"{name}_ring_offsets"],
                  data[f"{name}_layer_offsets"], data[f"{name}_explicit"])


@pytest.fixture(scope="module", params=list(E2E))
def case(request, meshes_dir, testdata_dir):
    data = np.load(testdata_dir / "cura_e2e" / f"{request.param}.npz")
    mesh = vs.load_mesh(meshes_dir / E2E[request.param], compat="cura")
    return request.param, data, cura_stages(mesh, CURA), mesh


def _differing(ours, theirs):
    return [k for k, (a, b) in enumerate(zip(ours, theirs, strict=True)) if a != b]


def test_layer_heights(case):
    _, data, stages, _ = case
    assert np.array_equal(stages["slice_z"], data["z"])


@pytest.mark.parametrize("stage", ["raw", "simp", "before_union"])
def test_stage_identical_on_every_layer(case, stage):
    name, data, stages, _ = case
    ours, theirs = _ours(stages[stage]), _theirs(data, stage)
    assert len(ours) == len(theirs) == len(data["z"])
    assert _differing(ours, theirs) == [], f"{name}: {stage} differs"


@pytest.mark.parametrize(("stage", "theirs"), [("raw", "raw_open"),
                                               ("simp", "open_after_make"),
                                               ("before_union", "open_final")])
def test_open_polylines_identical(case, stage, theirs):
    _, data, stages, _ = case
    o = stages[stage].polygons.open
    assert _stage(o.coords, o.ring_offsets, o.layer_offsets) == _stage(
        data[f"{theirs}_coords"], data[f"{theirs}_ring_offsets"],
        data[f"{theirs}_layer_offsets"])


def test_layer_statistics(case):
    _, data, stages, _ = case
    # segments, loops closed by topology, open chains before stitching
    assert np.array_equal(stages["raw"].stats[:, :3], data["layer_stats"])


def _part_counts(layer_offsets, part_offsets):
    parts = np.diff(layer_offsets)
    rings = np.add.reduceat(np.diff(part_offsets), layer_offsets[:-1]) * (parts > 0)
    return parts.tolist(), (rings - parts).tolist()


def test_part_and_hole_counts(case):
    _, data, stages, _ = case
    p = stages["parts"]
    assert _part_counts(p.layer_offsets, p.part_offsets) == _part_counts(
        data["parts_layer_offsets"], data["parts_part_offsets"])


def test_slice_mesh_compat(case):
    _, data, stages, mesh = case
    model = vs.slice_mesh(mesh, CURA)
    assert np.array_equal(model.slice_z, data["z"])
    assert _part_counts(model.layer_offsets, model.part_offsets) == _part_counts(
        data["parts_layer_offsets"], data["parts_part_offsets"])
    assert np.array_equal(model.coords, stages["parts"].coords)


def _parts(coords, ring_offsets, part_offsets, layer_offsets):
    """Per layer: sorted (outline, sorted holes), rings as cyclic sequences."""
    out = []
    for k in range(len(layer_offsets) - 1):
        parts = []
        for q in range(layer_offsets[k], layer_offsets[k + 1]):
            rings = [_canon(coords[ring_offsets[r] : ring_offsets[r + 1]])
                     for r in range(part_offsets[q], part_offsets[q + 1])]
            parts.append((rings[0], sorted(rings[1:])))
        out.append(sorted(parts))
    return out


def test_parts_equal_clipper_parts(case):
    # manifold3d's union of CuraEngine's polygons gives Clipper 6.4.2's parts on
    # these meshes exactly (outlines and holes as cyclic sequences); only the
    # order of parts and holes differs. The unions can differ where edges are
    # nearly parallel or a hole is a few µm² (see the README); none here.
    name, data, stages, _ = case
    p = stages["parts"]
    ours = _parts(p.coords, p.ring_offsets, p.part_offsets, p.layer_offsets)
    theirs = _parts(data["parts_coords"], data["parts_ring_offsets"],
                    data["parts_part_offsets"], data["parts_layer_offsets"])
    assert _differing(ours, theirs) == [], name


def _open_box(width_um, side_missing=True):
    """A width x width x 1 mm box resting on z = 0, one side's faces removed."""
    box = trimesh.creation.box((width_um / 1000, width_um / 1000, 1))
    box.apply_translation((0, 0, 0.5))
    faces = np.asarray(box.faces)
    if side_missing:
        normals = np.asarray(box.face_normals)
        faces = faces[~np.isclose(normals[:, 0], 1.0)]
    return vs.load_mesh(trimesh.Trimesh(box.vertices, faces, process=False),
                        compat="cura")


def test_stitched_loop_is_measured_without_its_closing_gap():
    # a 300 µm box with one side missing: three sides (900 µm) chain openly, the
    # stitch closes the gap, and CuraEngine measures the loop without it: 900 <
    # 1000, dropped; vecslice's default measures 1200 and keeps it
    mesh = _open_box(300)
    raw = cura_raw(mesh, [500])
    # chains start at the lowest unused segment, so the open ring comes out as 4
    # chains; round 1 joins them (gaps 0-1 µm, joint points kept), round 2 closes
    # the 300 µm gap
    assert raw.stats[0].tolist() == [6, 0, 4, 4]
    assert raw.polygons.layer(0)[0].tolist() == [
        [150, 150], [1, 150], [0, 150], [-150, 150], [-150, 150], [-150, 1],
        [-150, 0], [-150, -150], [-1, -150], [150, -150]]
    assert raw.explicit.tolist() == [True]
    assert cura_clean(raw, CURA).polygons.n_rings == 0
    keep = cura_clean(raw, CURA.replace(minimum_polygon_circumference=800))
    assert keep.polygons.n_rings == 1
    default = vs.clean_loops(vs.slice_contours(vs.Mesh(mesh.vertices, mesh.faces),
                                               [500]), vs.SliceSettings())
    assert default.n_rings == 1


def test_closed_loop_is_measured_up_to_its_closing_point():
    # a closed 250 µm square prism: the loop ends at its near-duplicate closing
    # point [-125, 1], 1 µm from its first point [-125, 0]; measured without that
    # last 1 µm it is 999 < 1000 and CuraEngine drops it
    mesh = _open_box(250, side_missing=False)
    raw = cura_raw(mesh, [500])
    ring = raw.polygons.layer(0)[0].tolist()
    assert ring[0] == [-125, 0] and ring[-1] == [-125, 1] and len(ring) == 9
    assert cura_clean(raw, CURA).polygons.n_rings == 0
    assert cura_clean(raw, CURA.replace(
        minimum_polygon_circumference=999)).polygons.n_rings == 1


def test_open_polylines_are_stitched_before_the_union():
    # open polylines reaching createLayerWithParts: two 2 mm lines forming an L
    # and its mirror, gaps of 5 µm at the corners -> one closed polygon (explicit)
    a = np.array([[0, 0], [2000, 0], [2000, 2000]], dtype=np.int64)
    b = np.array([[2000, 2005], [0, 2000], [0, 5]], dtype=np.int64)
    lines = vs.LayerPaths(np.vstack([a, b]), [0, 3, 6], [0, 2])
    empty = vs.LayerPaths.empty(1)
    clean = CuraLayers(vs.LayerPaths(empty.coords, empty.ring_offsets,
                                     empty.layer_offsets, open=lines),
                       np.zeros(0, dtype=bool))
    out = cura_before_union(clean, CURA)
    assert out.polygons.n_rings == 1 and out.explicit.tolist() == [True]
    assert out.polygons.layer(0)[0].tolist() == [[0, 0], [2000, 0], [2000, 2000],
                                                 [0, 2000], [0, 5]]
    assert out.polygons.open.n_rings == 0


def test_settings_compat_option():
    assert vs.SliceSettings().compat == "vecslice"
    assert CURA.replace(layer_height=200).compat == "cura"
    with pytest.raises(vs.SettingsError, match="`compat` must be one of"):
        vs.SliceSettings(compat="curaengine")
    assert "compat" in vs.SliceSettings.option_names()


@pytest.mark.parametrize("tolerance", ["inclusive", "exclusive"])
def test_slicing_tolerance_in_compat_mode(tolerance):
    mesh = _open_box(2000, side_missing=False)
    s = CURA.replace(slicing_tolerance=tolerance)
    model = vs.slice_mesh(mesh, s)
    z, _, _ = vs.layer_heights(mesh, s)
    assert np.array_equal(model.slice_z, z)
    areas = model.layer_areas()
    assert np.all(np.abs(areas[:-1] - 4e6) <= 4e6 * 0.01)


def test_open_chains_count_the_chains_left_open(meshes_dir):
    """``open_chains`` counts the chains CuraEngine's stitching leaves open (as in
    the default mode), not those open before it (teapot: 477 before, none after)."""
    mesh = vs.load_mesh(meshes_dir / "teapot.stl", compat="cura")
    raw = cura_raw(mesh, vs.layer_heights(mesh, CURA)[0])
    model = vs.slice_mesh(mesh, CURA)
    assert raw.stats[:, 2].sum() > 0  # chains open before stitching
    assert np.array_equal(model.open_chains, raw.polygons.open.rings_per_layer())
    assert model.open_chains.sum() == 0 == model.open.n_rings
    assert np.array_equal(model.stitched_gaps, raw.stats[:, 3])


def test_faces_repeating_a_vertex_index_are_dropped(meshes_dir):
    """CuraEngine's addFace drops a face [a, a, b]; a vs.Mesh may hold one (it used
    to crash the parallel neighbour kernel: a division by a zero-length edge)."""
    mesh = vs.load_mesh(meshes_dir / "Voron_Design_Cube_v7.stl", compat="cura")
    a, b = (int(i) for i in mesh.faces[7, :2])
    faces = np.vstack([mesh.faces[:5], [[a, a, b]], mesh.faces[5:], [[b, a, b]]])
    damaged = vs.Mesh(mesh.vertices, faces)
    want = vs.slice_mesh(mesh, CURA)
    got = vs.slice_mesh(damaged, CURA)
    assert np.array_equal(got.coords, want.coords)
    assert np.array_equal(got.part_offsets, want.part_offsets)
    assert np.array_equal(got.layer_offsets, want.layer_offsets)
