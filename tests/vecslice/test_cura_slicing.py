"""CuraEngine's raw stage (vecslice/cura_slicing.py): segments, loops, stitching."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_cura as ref
import vecslice as vs
from strategies import closed_meshes
from vecslice.cura_slicing import NO_COMPENSATION, cura_raw


def _layers(paths):
    """LayerPaths -> per layer, list of rings as lists of (x, y), in order."""
    out = []
    for k in range(paths.n_layers):
        out.append([[tuple(map(int, p)) for p in r] for r in paths.layer(k)])
    return out


@st.composite
def damaged_meshes(draw):
    """Closed meshes, then some faces dropped, flipped or doubled and some vertices
    moved onto a plane: open chains, vertices on planes, non-manifold edges. Also
    faces that repeat a vertex index and edges of length zero (two indices at one
    position, on three faces: a non-manifold edge), which ``vs.Mesh`` accepts."""
    v, f, planes = draw(closed_meshes())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    planes = np.unique(np.append(planes, v[:, 2].min()))
    n = len(f)
    ops = draw(st.lists(st.sampled_from(["drop", "flip", "double", "snap",
                                         "repeat", "zero_edge"]), max_size=4))
    for op in ops:
        i = int(rng.integers(0, len(f)))
        if op == "drop" and len(f) > 4:
            f = np.delete(f, i, axis=0)
        elif op == "flip":
            f[i] = f[i][::-1]
        elif op == "double":
            f = np.vstack([f, f[i : i + 1]])
        elif op == "snap":
            j = int(rng.integers(0, len(v)))
            v[j, 2] = planes[int(rng.integers(0, len(planes)))]
        elif op == "repeat":  # a face [a, a, b]
            a, b = f[i][0], f[i][1]
            f = np.vstack([f, [[a, a, b]]])
        elif op == "zero_edge":  # a copy c of vertex a: edge a-c of length 0
            a, b, w = f[i]
            c = len(v)
            v = np.vstack([v, v[a : a + 1]])
            f = np.vstack([f, [[a, c, b], [c, a, w], [a, c, w]]])
    assert len(f) >= min(n, 4)
    return v, f, planes


@given(damaged_meshes(), st.booleans())
def test_raw_stage_matches_reference(case, compensate):
    v, f, planes = case
    mesh = vs.Mesh(v, f)
    limit = int(v[:, 2].min()) + 1 if compensate else NO_COMPENSATION
    got = cura_raw(mesh, planes, compensate_below=limit)
    polys = _layers(got.polygons)
    chains = _layers(got.polygons.open)
    assert got.explicit.all() and len(got.explicit) == got.polygons.n_rings
    for k, z in enumerate(planes.tolist()):
        want_polys, want_open = ref.slice_layer(v.tolist(), f.tolist(), z, limit)
        assert polys[k] == want_polys, f"plane {k} (z = {z})"
        assert chains[k] == want_open, f"plane {k} (z = {z})"


def _prism(z_top=1000):
    """A 2 x 2 mm square prism, outward faces, resting on z = 0."""
    import trimesh

    box = trimesh.creation.box((2, 2, z_top / 1000))
    box.apply_translation((1, 1, z_top / 2000))
    return vs.load_mesh(box, compat="cura")


def test_loop_keeps_its_closing_point():
    # a closed loop repeats (within 10 µm) its first point: 8 segments give 9
    # points, the first segment's start then every end
    raw = cura_raw(_prism(), [500])
    ring = raw.polygons.layer(0)[0]
    assert len(ring) == raw.stats[0, 0] + 1 == 9
    d = ring[-1] - ring[0]
    assert ref.shorter_than(int(d[0]), int(d[1]), 10)
    assert raw.explicit.tolist() == [True]
    assert raw.stats[0].tolist() == [8, 1, 0, 0]


def test_loop_starts_at_the_lowest_segment():
    mesh = _prism()
    raw = cura_raw(mesh, [500])
    segs = ref.layer_segments(mesh.vertices.tolist(), mesh.faces.tolist(),
                              ref.face_neighbours(mesh.vertices.tolist(),
                                                  mesh.faces.tolist()), 500, 1)
    assert tuple(raw.polygons.layer(0)[0][0]) == segs[0]["start"]


def test_vertex_exactly_on_a_plane():
    # the prism's top and bottom vertices sit on planes 0 and 1000: the bottom
    # plane (z <= min z) moves them 1 µm down, so the side faces cut it just above
    # the corners; the top plane gives nothing (no vertex above it)
    mesh = _prism()
    raw = cura_raw(mesh, [0, 1000])
    assert raw.polygons.rings_per_layer().tolist() == [1, 0]
    bottom = raw.polygons.layer(0)[0]
    assert abs(ref.path_length(bottom.tolist()) - 8000) <= 16
    assert raw.stats[0].tolist() == [8, 1, 0, 0]
    # without the compensation, a side face with two vertices on the plane and the
    # third above gives its bottom edge (rows B/D/F, ending on a vertex: endVertex
    # search); the other side face only touches the plane: no segment. The far
    # ends come out 1 µm short: interpolate(0, 1000, 0, 0, 2000) = 1999
    raw = cura_raw(mesh, [0], compensate_below=NO_COMPENSATION)
    ring = raw.polygons.layer(0)[0].tolist()
    assert ring == [[0, 0], [1999, 0], [2000, 1999], [1, 2000], [0, 1]]
    assert raw.stats[0].tolist() == [4, 1, 0, 0]
    want, _ = ref.slice_layer(mesh.vertices.tolist(), mesh.faces.tolist(), 0,
                              NO_COMPENSATION)
    assert [list(map(tuple, ring))] == want


def test_vertex_on_a_plane_searches_the_faces_around_it():
    # a tetrahedron-like spike: a vertex of a closed mesh exactly on plane z = 500
    # with faces above and below; the end on that vertex chains through the
    # faces around it (last hit wins) and the result equals the reference
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=1, radius=2)
    v = np.rint(m.vertices * 1000).astype(np.int64)
    v[:, 2] -= v[:, 2].min()
    f = np.asarray(m.faces, dtype=np.int64)
    z = int(np.sort(v[:, 2])[len(v) // 2])  # through vertices
    mesh = vs.Mesh(v, f)
    raw = cura_raw(mesh, [z])
    want_polys, want_open = ref.slice_layer(v.tolist(), f.tolist(), z, 1)
    assert _layers(raw.polygons)[0] == want_polys
    assert _layers(raw.polygons.open)[0] == want_open
    assert (v[:, 2] == z).sum() >= 2 and raw.polygons.rings_per_layer()[0] >= 1


def test_unsorted_planes_rejected():
    with pytest.raises(vs.InputValueError, match="`slice_z` must be sorted"):
        cura_raw(_prism(), [500, 100])


def test_cura_topology_is_built_once_per_mesh(monkeypatch):
    import trimesh

    from vecslice._kernels import cura_mesh

    calls = []
    build = cura_mesh.face_neighbours

    def counted(vertices, faces, *args):
        calls.append(len(faces))
        return build(vertices, faces, *args)

    monkeypatch.setattr(cura_mesh, "face_neighbours", counted)
    mesh = vs.load_mesh(trimesh.creation.icosphere(subdivisions=2, radius=10),
                        compat="cura")
    settings = vs.SliceSettings(compat="cura")
    first = vs.slice_mesh(mesh, settings)
    again = vs.slice_mesh(mesh, settings)
    cura_raw(mesh, [0, 2500])
    assert calls == [mesh.n_faces]
    assert first.coords.tolist() == again.coords.tolist()
    # the neighbours read the vertices: a moved copy and a new mesh build their own
    vs.slice_mesh(mesh.translated(1000, 0, 0), settings)
    vs.slice_mesh(vs.Mesh.from_arrays(mesh.vertices, mesh.faces), settings)
    assert len(calls) == 3


def _raw_arrays(raw):
    p = raw.polygons
    return [p.coords, p.ring_offsets, p.layer_offsets, p.open.coords,
            p.open.ring_offsets, p.open.layer_offsets, raw.explicit, raw.stats]


@pytest.mark.parametrize("name", ["teapot.stl", "Voron_Design_Cube_v7.stl"])
def test_small_chunks_on_threads_give_the_same_slices(meshes_dir, monkeypatch, name):
    # the compat kernels run in chunks (of corners, faces, planes) on threads: in
    # chunks of a few items each, loading, the raw stage and the whole slice come
    # out as in one chunk. teapot.stl has open edges, the cube faces on planes
    import vecslice._kernels.cura_loops as cura_loops
    import vecslice._kernels.cura_mesh as cura_mesh
    import vecslice._kernels.cura_segments as cura_segments

    settings = vs.SliceSettings(compat="cura", layer_height=150)

    def run():
        mesh = vs.load_mesh(meshes_dir / name, compat="cura")
        lo, hi = mesh.zrange
        raw = cura_raw(mesh, np.arange(lo, hi + 1, 50))  # also through vertices
        model = vs.slice_mesh(mesh, settings)
        return [mesh.vertices, mesh.faces, *_raw_arrays(raw), model.coords,
                model.ring_offsets, model.part_offsets, model.layer_offsets]

    want = run()
    for module, name_, size in [(cura_mesh, "_MELD_CHUNK", 40),
                                (cura_mesh, "_FACE_CHUNK", 30),
                                (cura_segments, "_SLOT_CHUNK", 50),
                                (cura_loops, "_SEGMENT_CHUNK", 20)]:
        monkeypatch.setattr(module, name_, size)
    got = run()
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)
    assert want[2].shape[0] > 10_000  # the raw loops' points
    if name == "teapot.stl":
        assert want[9][:, 2].sum() > 100  # open chains before stitching


def test_heights_are_checked_on_the_copy_the_kernels_read(write_when_copied):
    """Audit s26 state D2: the sorted order of slice_z was checked in the caller's
    memory, which the kernels then read (a write in between reached them
    unchecked). Here the write lands just before the copy."""
    z = np.array([100, 500], np.int64)
    writes = write_when_copied(z, 0, 900)
    with pytest.raises(vs.InputValueError, match=r"`slice_z` must be sorted "
                       r"\(non-decreasing\); got 900 > 500 at index 0"):
        cura_raw(_prism(), z)
    assert writes == [0]


def test_cura_layers_copies_stay_read_only():
    """Audit s26 state D3 (as ContourErrors): CuraLayers froze its arrays in
    __post_init__, which unpickling and deepcopy skip."""
    import copy
    import pickle

    raw = cura_raw(_prism(), [500])
    for clone in (pickle.loads(pickle.dumps(raw)), copy.deepcopy(raw), copy.copy(raw)):
        for name in ("explicit", "stats"):
            a = getattr(clone, name)
            assert np.array_equal(a, getattr(raw, name)) and not a.flags.writeable
            with pytest.raises(ValueError):
                a.flags.writeable = True
        assert clone.polygons.coords.tolist() == raw.polygons.coords.tolist()
