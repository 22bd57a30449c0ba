import math

import numpy as np
import pytest
import reference_adaptive as ref
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import vecslice as vs
from conftest import load_testdata
from vecslice.adaptive import adaptive_layer_heights, allowed_heights, face_slopes


def _data():
    return load_testdata("cura_adaptive_vectors.json")


def _mesh(m):
    # the faces exactly as given (no merging): every face counts
    return vs.Mesh(np.array(m["vertices"]), np.array(m["faces"]))


def _settings(s, **kw):
    return vs.SliceSettings(
        layer_height=s["layer_height"], initial_layer_height=s["layer_height_0"],
        adaptive_variation=s["variation"], adaptive_variation_step=s["step"],
        adaptive_threshold=s["threshold"], slicing_tolerance=s["slicing_tolerance"],
        **kw,
    )


def _vectors():
    return [pytest.param(v, id=v["name"]) for v in _data()["vectors"]]


def _hex(values):
    return ["nan" if math.isnan(x) else float(x).hex() for x in values]


def test_all_vectors_are_here():
    data = _data()
    assert len(data["vectors"]) == 25 and len(data["meshes"]) == 13
    assert sum("face_slope_hex" in m for m in data["meshes"].values()) == 12


@pytest.mark.parametrize("v", _vectors())
def test_cura_vector_exact(v):
    mesh = _mesh(_data()["meshes"][v["mesh_name"]])
    s = _settings(v["settings"])
    assert allowed_heights(s.layer_height, s.adaptive_variation,
                           s.adaptive_variation_step).tolist() == v["allowed_heights"]
    # the vectors are in CuraEngine's bed frame
    z, p, t = adaptive_layer_heights(mesh, s, frame="bed")
    assert [list(row) for row in zip(z.tolist(), p.tolist(), t.tolist(),
                                     strict=True)] == v["layers"]
    assert len(z) == v["n_layers"]
    assert z.dtype == p.dtype == t.dtype == np.int64
    if mesh.zrange[0] == 0:  # resting on the bed: the project's frame is the same
        z2, p2, t2 = vs.layer_heights(mesh, s.replace(adaptive_layers=True))
        assert z2.tolist() == z.tolist() and p2.tolist() == p.tolist()
        assert t2.tolist() == t.tolist()


def test_floating_box_in_both_frames():
    data = _data()
    (v,) = [v for v in data["vectors"] if v["name"] == "floating_box__cura_defaults"]
    mesh = _mesh(data["meshes"]["floating_box"])
    s = _settings(v["settings"])
    assert mesh.zrange == (1000, 3000)
    bed = adaptive_layer_heights(mesh, s, frame="bed")
    # bed frame (CuraEngine): 69 layers of 10 µm in the empty gap below the box
    assert bed[2][1:70].tolist() == [10] * 69 and bed[0][69] == 990
    # project frame: the box as if it rested on the bed, slice_z in its own frame
    z, p, t = adaptive_layer_heights(mesh, s)
    on_bed = vs.Mesh(mesh.vertices - np.array([0, 0, 1000]), mesh.faces)
    z0, p0, t0 = adaptive_layer_heights(on_bed, s, frame="bed")
    assert (z == z0 + 1000).all() and (p == p0).all() and (t == t0).all()
    assert t[1] == 200 and len(t) < len(bed[2])


@pytest.mark.parametrize("name", [n for n, m in _data()["meshes"].items()
                                  if "face_slope_hex" in m])
def test_face_slopes_bit_for_bit(name):
    m = _data()["meshes"][name]
    face_z, slope = face_slopes(_mesh(m), frame="bed")
    assert face_z[:, 0].tolist() == m["face_zmin"]
    assert face_z[:, 1].tolist() == m["face_zmax"]
    assert _hex(slope) == m["face_slope_hex"]


def test_allowed_heights():
    assert allowed_heights(100, 100, 10).tolist() == list(range(200, 9, -10))
    assert allowed_heights(100, 0, 10).tolist() == [100]
    assert allowed_heights(100, 100, 30).tolist()[-1] == 20  # 2V not a multiple
    assert allowed_heights(100, 100, 50).tolist() == [200, 150, 100, 50]
    assert allowed_heights(5, 20, 4).tolist() == [25, 21, 17, 13, 9, 5, 1]


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        ((100, 100, 0), "`adaptive_variation_step` must be >= 1; got 0"),
        ((100, 100, -10), "`adaptive_variation_step` must be >= 1; got -10"),
        ((100, -1, 10), "`adaptive_variation` must be >= 0; got -1"),
        ((0, 100, 10), "`layer_height` must be >= 1; got 0"),
    ],
)
def test_allowed_heights_rejects(args, fragment):
    with pytest.raises(vs.SettingsError, match=fragment):
        allowed_heights(*args)


def test_allowed_heights_refuses_a_list_beyond_its_cap():
    # values SliceSettings accepts would list 2**31 heights (16 GiB): refused
    # before any allocation; the largest list allowed is still given
    with pytest.raises(vs.SettingsError, match=r"allow 2147483648 heights; "
                       r"allowed_heights lists at most 1048576") as info:
        allowed_heights(2**30, 2**30, 1)
    assert isinstance(info.value, ValueError)
    assert allowed_heights(2**19, 2**19, 1).shape == (2**20,)  # 2**20 .. 1
    with pytest.raises(vs.SettingsError, match="allow 1048577 heights"):
        allowed_heights(2**19 + 1, 2**19, 1)
    s = vs.SliceSettings(layer_height=2**30, adaptive_layers=True,
                         adaptive_variation=2**30, adaptive_variation_step=1)
    assert s.adaptive_variation_step == 1  # the schedule itself needs no list


def test_bad_arguments():
    mesh = vs.Mesh([[0, 0, 0], [1000, 0, 0], [0, 1000, 1000]], [[0, 1, 2]])
    with pytest.raises(vs.InputTypeError, match=r"`mesh` must be a vecslice\.Mesh"):
        adaptive_layer_heights(np.zeros((3, 3)))
    with pytest.raises(vs.InputTypeError, match=r"`mesh` must be a vecslice\.Mesh"):
        face_slopes("cube.stl")
    with pytest.raises(vs.InputTypeError, match="`settings` must be"):
        adaptive_layer_heights(mesh, {"adaptive_layers": True})
    with pytest.raises(vs.SettingsError, match="`frame` must be one of 'mesh', 'bed'"):
        adaptive_layer_heights(mesh, frame="Bed")
    with pytest.raises(ValueError, match="got 'up'"):
        face_slopes(mesh, frame="up")


# --- random meshes against the reference --------------------------------------------

coord = st.integers(-3000, 3000)
on_grid = st.integers(-12, 12).map(lambda k: 250 * k)  # ties, flat, vertical faces


@st.composite
def small_meshes(draw):
    """Triangle soups with degenerate faces, unused vertices and any z offset."""
    c = draw(st.sampled_from([coord, on_grid]))
    n_v = draw(st.integers(3, 8))
    verts = draw(st.lists(st.tuples(c, c, st.integers(0, 2500) | on_grid.map(abs)),
                          min_size=n_v, max_size=n_v))
    idx = st.integers(0, n_v - 1)
    faces = draw(st.lists(st.tuples(idx, idx, idx), min_size=1, max_size=10))
    lift = draw(st.sampled_from([0, 0, 1, 777, 5000, -2000]))
    v = np.array(verts, dtype=np.int64) + np.array([0, 0, lift])
    return vs.Mesh(v, np.array(faces, dtype=np.int64))


@st.composite
def adaptive_settings(draw):
    base = draw(st.integers(1, 250))
    variation = draw(st.integers(0, 150))
    return vs.SliceSettings(
        adaptive_layers=True, layer_height=base,
        initial_layer_height=draw(st.integers(1, 400)),
        adaptive_variation=variation,
        adaptive_variation_step=draw(st.integers(max(1, -(-2 * variation // 40)), 80)),
        adaptive_threshold=draw(st.integers(-100, 500) | st.sampled_from([0, 200])),
        slicing_tolerance=draw(st.sampled_from(vs.settings.SLICING_TOLERANCES)),
    )


def _reference(mesh, s, frame):
    used = mesh.vertices[np.unique(mesh.faces)]
    dz = 0 if frame == "bed" else int(used[:, 2].min())
    layers = ref.adaptive_layers(
        (mesh.vertices - np.array([0, 0, dz])).tolist(), mesh.faces.tolist(),
        base=s.layer_height, first=s.initial_layer_height,
        variation=s.adaptive_variation, step=s.adaptive_variation_step,
        threshold=s.adaptive_threshold, tolerance=s.slicing_tolerance)
    top = [zt for _, zt in layers]
    return [[zt + dz for zt in top], top, [h for h, _ in layers]]


@given(small_meshes(), adaptive_settings(), st.sampled_from(["mesh", "bed"]))
def test_matches_reference_on_random_meshes(mesh, s, frame):
    got = adaptive_layer_heights(mesh, s, frame=frame)
    want = _reference(mesh, s, frame)
    assert [a.tolist() for a in got] == want
    if frame == "mesh":
        assert [a.tolist() for a in vs.layer_heights(mesh, s)] == want


@given(small_meshes(), st.sampled_from(["mesh", "bed"]))
def test_face_slopes_in_either_frame_match_reference(mesh, frame):
    # the project's frame computes the slopes from z - lowest z, bit for bit
    used = mesh.vertices[np.unique(mesh.faces)]
    dz = 0 if frame == "bed" else int(used[:, 2].min())
    shifted = mesh.vertices - np.array([0, 0, dz])
    zmin, zmax, slope = ref.face_data(shifted.tolist(), mesh.faces.tolist())
    face_z, got = face_slopes(mesh, frame=frame)
    assert face_z.tolist() == [list(r) for r in zip(zmin, zmax, strict=True)]
    assert _hex(got) == _hex(slope)


@given(small_meshes(), adaptive_settings(), st.integers(-10**6, 10**6))
def test_translation_in_z_moves_slice_z_only(mesh, s, dz):
    # the project's frame works on z - lowest z, so the slope bits do not change
    moved = vs.Mesh(mesh.vertices + np.array([0, 0, dz]), mesh.faces)
    z0, p0, t0 = vs.layer_heights(mesh, s)
    z1, p1, t1 = vs.layer_heights(moved, s)
    assert (z1 == z0 + dz).all() and (p1 == p0).all() and (t1 == t0).all()


@st.composite
def printable_models(draw):
    """Small trimesh primitives, randomly rotated and placed, a few mm tall."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["box", "icosphere", "cylinder", "cone", "capsule"]))
    if kind == "box":
        m = trimesh.creation.box(rng.uniform(1, 6, 3))
    elif kind == "icosphere":
        m = trimesh.creation.icosphere(subdivisions=1, radius=rng.uniform(1, 4))
    elif kind == "cylinder":
        m = trimesh.creation.cylinder(rng.uniform(1, 4), rng.uniform(1, 6),
                                      sections=int(rng.integers(3, 24)))
    elif kind == "cone":
        m = trimesh.creation.cone(rng.uniform(1, 6), rng.uniform(0.5, 6),
                                  sections=int(rng.integers(3, 24)))
    else:
        m = trimesh.creation.capsule(rng.uniform(1, 4), rng.uniform(0.5, 2),
                                     count=[8, 8])
    if draw(st.booleans()):
        m.apply_transform(trimesh.transformations.random_rotation_matrix(
            rng.random(3)))
    m.apply_translation(rng.uniform(-50, 50, 3))
    return vs.load_mesh(m)


@st.composite
def print_settings(draw):
    base = draw(st.integers(50, 300))
    variation = draw(st.integers(0, base - 20))
    return vs.SliceSettings(
        adaptive_layers=True, layer_height=base,
        initial_layer_height=draw(st.integers(50, 400)),
        adaptive_variation=variation,
        adaptive_variation_step=draw(st.integers(5, 60)),
        adaptive_threshold=draw(st.integers(-50, 400)),
        slicing_tolerance=draw(st.sampled_from(vs.settings.SLICING_TOLERANCES)),
    )


@settings(max_examples=25)
@given(printable_models(), print_settings(), st.sampled_from(["mesh", "bed"]))
def test_matches_reference_on_printable_models(mesh, s, frame):
    got = adaptive_layer_heights(mesh, s, frame=frame)
    assert [a.tolist() for a in got] == _reference(mesh, s, frame)


def test_unused_vertices_do_not_count():
    # CuraEngine's vertex list holds only vertices of faces: a stray vertex far
    # above or below changes neither the model top nor the lowest point
    tri = [[0, 0, 0], [1000, 0, 0], [0, 1000, 1000]]
    s = vs.SliceSettings(adaptive_layers=True)
    plain = vs.layer_heights(vs.Mesh(tri, [[0, 1, 2]]), s)
    stray = vs.layer_heights(vs.Mesh([*tri, [0, 0, 9000], [0, 0, -500]],
                                     [[0, 1, 2]]), s)
    assert [a.tolist() for a in plain] == [a.tolist() for a in stray]
    assert plain[1][-2] <= 1000 < plain[1][-1]  # ends above the top at 1000


# --- slicing with adaptive layers -------------------------------------------------


def test_slice_mesh_cuts_layer_tops_and_post_processes():
    cube = vs.load_mesh(trimesh.creation.box((10, 10, 10)))
    base = vs.SliceSettings(adaptive_layers=True)
    area = 100e6  # µm²
    for mode in ("middle", "inclusive", "exclusive"):
        s = base.replace(slicing_tolerance=mode)
        z, p, t = vs.layer_heights(cube, s)
        model = vs.slice_mesh(cube, s)
        assert model.slice_z.tolist() == z.tolist()
        assert model.print_z.tolist() == p.tolist() and (z - p == -5000).all()
        assert len(z) == 50 and p[-1] == 10100  # the last layer ends above the cube
        areas = model.layer_areas().tolist()
        raw = [area] * 49 + [0.0]  # layer tops; the top one is above the cube
        if mode == "exclusive":  # each layer intersected with the next, top cleared
            assert areas == [*raw[1:], 0.0]
        else:  # 'inclusive' unions each layer with the next: the same here
            assert areas == raw


def test_slice_mesh_inclusive_unions_with_the_layer_above():
    # an inverted cone (overhang): the layer above is the larger one
    cone = trimesh.creation.cone(5, 2, sections=16)
    cone.apply_transform(trimesh.transformations.rotation_matrix(math.pi, [1, 0, 0]))
    mesh = vs.load_mesh(cone)
    s = vs.SliceSettings(adaptive_layers=True, slicing_tolerance="inclusive")
    z, _, _ = vs.layer_heights(mesh, s)
    raw = vs.slice_contours(mesh, z).layer_area2() / 2
    areas = vs.slice_mesh(mesh, s).layer_areas()
    k = int((raw > 0).sum())  # the top layers (above the cone) are empty
    assert k >= 10 and (raw[k:] == 0).all() and (np.diff(raw[:k]) > 0).all()
    np.testing.assert_allclose(areas[:k - 1], raw[1:k], rtol=1e-3)
    np.testing.assert_allclose(areas[k - 1:], raw[k - 1:], rtol=1e-3)


def test_slice_mesh_compat_cura_uses_the_adaptive_schedule():
    # CuraEngine's on-plane nudge only touches planes at the lowest z; adaptive
    # planes start at initial_layer_height above it
    cube = vs.load_mesh(trimesh.creation.box((10, 10, 10)))
    s = vs.SliceSettings(adaptive_layers=True, compat="cura")
    z, p, t = vs.layer_heights(cube, s)
    model = vs.slice_mesh(cube, s)
    assert model.slice_z.tolist() == z.tolist()
    assert model.thickness.tolist() == t.tolist()
    assert model.layer_areas().tolist() == [*[100e6] * 49, 0.0]


def test_max_layers_stops_the_adaptive_loop():
    # a 5 mm wall at threshold 0: 372 layers (300, 200, 180, ..., 20, then 10 µm)
    wall = vs.Mesh([[0, 0, 0], [1000, 0, 0], [0, 0, 5000]], [[0, 1, 2]])
    s = vs.SliceSettings(adaptive_layers=True, adaptive_threshold=0)
    assert len(vs.layer_heights(wall, s)[0]) == 372
    assert len(vs.layer_heights(wall, s.replace(max_layers=372))[0]) == 372
    with pytest.raises(vs.SettingsError) as info:
        vs.layer_heights(wall, s.replace(max_layers=371))
    msg = str(info.value)
    assert "must be <= `max_layers` (371); got 372 layers" in msg
    assert "down to 10 µm thick on an object 5000 µm tall" in msg
    assert "SliceSettings(max_layers=472)" in msg  # enough for any schedule
    assert info.value.layers_needed == 472  # for the command line's own hint
    assert len(vs.layer_heights(wall, s.replace(max_layers=472))[0]) == 372
    with pytest.raises(vs.SettingsError, match=r"`max_layers` \(5\); got 6 layers"):
        vs.slice_mesh(wall, s.replace(max_layers=5))


def test_faces_are_prepared_once_per_mesh_and_frame(monkeypatch):
    import vecslice.adaptive as adaptive

    calls = []
    build = adaptive._face_slopes

    def counted(vertices, faces, dz):
        calls.append(dz)
        return build(vertices, faces, dz)

    monkeypatch.setattr(adaptive, "_face_slopes", counted)
    box = trimesh.creation.box((20, 20, 10))
    box.apply_translation((0, 0, 8))  # floating: the frames differ
    mesh = vs.load_mesh(box)
    runs = [(threshold, frame) for frame in ("mesh", "mesh", "bed", "mesh", "bed")
            for threshold in (50, 200, 400)]
    got = [adaptive_layer_heights(mesh, vs.SliceSettings(adaptive_threshold=t),
                                  frame=f) for t, f in runs]
    # one per frame, also when the frames alternate (the cache kept one frame
    # at a time and rebuilt on every switch)
    assert len(calls) == 2 and calls[0] != calls[1]
    # every schedule equals that of a fresh mesh (nothing cached)
    for (t, f), schedule in zip(runs, got, strict=True):
        fresh = vs.Mesh.from_arrays(mesh.vertices, mesh.faces)
        want = adaptive_layer_heights(fresh, vs.SliceSettings(adaptive_threshold=t),
                                      frame=f)
        for a, b in zip(schedule, want, strict=True):
            assert a.tolist() == b.tolist()


@pytest.mark.parametrize("frame", ["mesh", "bed"])
def test_faces_in_small_chunks_on_threads_give_the_same_bits(monkeypatch, frame):
    # the faces' slopes are computed in chunks on threads (a plain kernel per
    # chunk, not a parfor): in chunks of 97 faces they equal the serial kernel's
    import vecslice.adaptive as adaptive
    from vecslice._kernels.adaptive import face_slopes as serial

    sphere = trimesh.creation.icosphere(subdivisions=3, radius=10)
    sphere.apply_translation((0, 0, 12))
    mesh = vs.load_mesh(sphere)
    want_z, want_slope = serial(mesh.vertices, mesh.faces,
                                0 if frame == "bed" else mesh.zrange[0])
    want = adaptive_layer_heights(mesh, frame=frame)
    monkeypatch.setattr(adaptive, "_FACE_CHUNK", 97)
    face_z, slope = face_slopes(mesh, frame=frame)
    assert face_z.tolist() == want_z.tolist()
    assert slope.tobytes() == want_slope.tobytes()
    fresh = vs.Mesh.from_arrays(mesh.vertices, mesh.faces)
    got = adaptive_layer_heights(fresh, frame=frame)
    assert all(g.tolist() == w.tolist() for g, w in zip(got, want, strict=True))


@pytest.mark.parametrize("frame", ["mesh", "bed"])
def test_schedule_beyond_the_coordinate_limit_is_refused(frame):
    # the last adaptive layer ends above the model: for a mesh whose top is just
    # below 2**30 µm it would be cut beyond the limit; layer_heights refused
    # this, adaptive_layer_heights (the public function) returned it
    top = 2**30 - 10
    m = vs.Mesh(np.array([[0, 0, top - 990], [1000, 0, top - 990], [0, 1000, top]]),
                np.array([[0, 1, 2]]))
    # 0.1 m layers: in the 'bed' frame the gap below the mesh is ~10^4 layers
    s = vs.SliceSettings(adaptive_layers=True, layer_height=100_000,
                         initial_layer_height=100_000, adaptive_variation=0)
    with pytest.raises(vs.InputValueError, match=r"2\*\*30") as err:
        adaptive_layer_heights(m, s, frame=frame)
    assert isinstance(err.value, ValueError)
    if frame == "mesh":
        assert "move the mesh down" in str(err.value)
        assert f"top is at {top} µm" in str(err.value)
        with pytest.raises(vs.InputValueError, match="move the mesh down"):
            vs.layer_heights(m, s)
    # the same mesh 0.2 m lower is fine
    low = vs.Mesh(m.vertices - np.array([0, 0, 200_000]), m.faces)
    z, p, t = adaptive_layer_heights(low, s, frame=frame)
    assert int(z.max()) < 2**30 and int(p.max()) < 2**30
