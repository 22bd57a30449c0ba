"""What slicing must give on the broken meshes in ../shared/meshes (issue: broken
meshes degrade gracefully). Each test states the expected result."""

import numpy as np
import pytest
import trimesh

import vecslice as vs
from conftest import MESHES

SETTINGS = vs.SliceSettings(layer_height=200)


def _path(name):
    path = MESHES / name
    if not path.exists():
        pytest.skip(f"{path} not found (../shared beside the project)")
    return path


def _z_up(name):
    """The two Stanford bunnies are Y-up: stand them on their base (z up)."""
    tm = trimesh.load(_path(name), process=False)
    tm.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    return vs.load_mesh(tm, scale=1000)


def test_flipped_hourglass_has_the_areas_of_its_repaired_copy():
    flipped = vs.load_mesh(_path("hourglass.stl"), scale=1000)
    # an independent repair: trimesh's fix_normals on the file as read
    tm = trimesh.load(_path("hourglass.stl"))
    tm.merge_vertices()
    trimesh.repair.fix_normals(tm)
    reference = vs.load_mesh(tm, scale=1000, repair=False)
    assert vs.check_mesh(reference).inconsistent_edges == 0
    a = vs.slice_mesh(flipped, SETTINGS)
    b = vs.slice_mesh(reference, SETTINGS)
    assert np.array_equal(a.slice_z, b.slice_z)
    assert np.array_equal(a.layer_areas(), b.layer_areas())
    assert vs.check_mesh(flipped).inconsistent_edges == 0
    # every layer but the last (cut exactly at the top, which gives nothing)
    assert a.open.n_rings == 0 and (a.layer_areas()[:-1] > 0).all()


def test_inside_out_mesh_gives_the_same_areas():
    box = trimesh.creation.box((10, 20, 5))
    inverted = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    expect = vs.slice_mesh(vs.load_mesh(box), SETTINGS).layer_areas()
    for repair in (True, False):
        got = vs.slice_mesh(vs.load_mesh(inverted, repair=repair), SETTINGS)
        assert np.array_equal(got.layer_areas(), expect)
    # 5 mm: the last plane lies exactly on the top face, which gives nothing
    assert (expect[:-1] == 10_000 * 20_000).all() and expect[-1] == 0


def test_open_bunny_base_still_gives_closed_layers_above_it():
    mesh = _z_up("stanford-bunny.obj")
    z, _, _ = vs.layer_heights(mesh, SETTINGS)
    raw = vs.slice_contours(mesh, z, stitch=False)
    stitched = vs.slice_contours(mesh, z)
    above = z - mesh.zrange[0] > 10_000  # more than 10 mm above the base
    # the scan's holes leave open chains up to ~26 mm; stitching closes every
    # layer more than 10 mm above the base, and nothing is lost below it
    assert (raw.open.rings_per_layer()[above] > 0).sum() >= 10
    assert (stitched.open.rings_per_layer()[above] == 0).all()
    assert stitched.open.rings_per_layer()[~above].sum() > 0  # reported, kept
    model = vs.slice_mesh(mesh, SETTINGS)
    assert (model.open_chains[above] == 0).all()
    assert model.stitched_gaps.sum() > 0
    assert (model.layer_areas()[above] > 0).all()


def test_duplicated_faces_bunny_matches_the_full_resolution_scan():
    coarse = _z_up("bun_zipper_res2.ply")
    fine = _z_up("stanford-bunny.obj")
    z0, z1 = fine.zrange
    z = np.linspace(z0 + 0.2 * (z1 - z0), z0 + 0.8 * (z1 - z0), 25).astype(np.int64)
    a = vs.make_parts(vs.slice_contours(coarse, z))
    b = vs.make_parts(vs.slice_contours(fine, z))
    area = [vs.Paths(p.coords, p.ring_offsets).area2() for p in (a, b)]
    per_layer = []
    for parts, a2 in zip((a, b), area):
        ring_layer = np.repeat(np.repeat(np.arange(25), np.diff(parts.layer_offsets)),
                               np.diff(parts.part_offsets))
        per_layer.append(np.bincount(ring_layer, a2, minlength=25) / 2)
    rel = np.abs(per_layer[0] - per_layer[1]) / per_layer[1]
    assert (rel < 0.03).all(), rel  # same object, 1/4 of the vertices


def test_nonmanifold_openscad_output_closes_and_merges_overlaps():
    mesh = vs.load_mesh(_path("openscad-nonmanifold-crash.obj"))
    z, _, _ = vs.layer_heights(mesh, SETTINGS)
    loops = vs.slice_contours(mesh, z)
    assert loops.open.n_rings == 0  # every layer closes after stitching
    union = vs.slice_mesh(mesh, SETTINGS)
    xor = vs.slice_mesh(mesh, SETTINGS.replace(union_overlapping_volumes=False))
    # overlapping shells: NonZero fills every covered point, EvenOdd cancels
    assert (union.layer_areas() >= xor.layer_areas() - 1).all()
    assert (union.layer_areas()[:-1] > 0).all()  # the last plane is the top


def test_teapot_open_pierced_surfaces_give_closed_parts():
    mesh = vs.load_mesh(_path("teapot.stl"))
    z0, z1 = mesh.zrange
    raw = vs.slice_contours(mesh, [z0 + (z1 - z0) * p // 100 for p in (25, 50, 75)],
                            stitch=False)
    assert raw.open.n_rings > 0  # the surfaces are open where they pierce
    assert vs.slice_mesh(mesh, SETTINGS).open.n_rings == 0
    # at 25/50/75 % height: body; body, spout, handle; body and handle (as listed
    # in meshes/README.md)
    z = [z0 + (z1 - z0) * p // 100 for p in (25, 50, 75)]
    parts = vs.make_parts(vs.clean_loops(vs.slice_contours(mesh, z), SETTINGS))
    assert np.diff(parts.layer_offsets).tolist() == [1, 3, 2]


def test_every_mesh_slices_with_default_settings():
    for name, scale in [("3DBenchy.3mf", 1), ("bun_zipper_res2.ply", 1000),
                        ("stanford-bunny.obj", 1000), ("teapot.stl", 1),
                        ("openscad-nonmanifold-crash.obj", 1),
                        ("hourglass.stl", 1000)]:
        model = vs.slice_mesh(vs.load_mesh(_path(name), scale=scale))
        assert model.n_layers > 0 and model.n_parts > 0
        assert model.open_chains.shape == (model.n_layers,)
