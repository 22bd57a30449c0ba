import numpy as np
import pytest

import vecslice as vs
from conftest import load_testdata
from vecslice.layers import layer_count, layer_schedule


def _cases():
    data = load_testdata("cura_slice_vectors.json")
    return data["layer_schedules"]["cases"]


def test_every_cura_schedule_matches_exactly():
    cases = _cases()
    assert len(cases) >= 27
    for c in cases:
        s = vs.SliceSettings(layer_height=c["layer_height"],
                             initial_layer_height=c["layer_height_0"],
                             slicing_tolerance=c["mode"])
        z, p, t = layer_schedule(c["mesh_max_z"], s)
        assert layer_count(c["mesh_max_z"], s) == c["slice_layer_count"], c
        assert z.tolist() == c["layer_z"], c
        assert p.tolist() == c["printZ"], c
        assert t.tolist() == c["thickness"], c
        assert z.dtype == p.dtype == t.dtype == np.int64


def test_layer_heights_are_measured_from_the_lowest_point():
    base = vs.Mesh.from_arrays(
        np.array([[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 10000]]),
        np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]),
    )
    shift = np.array([5, -7, -12345])
    shifted = vs.Mesh.from_arrays(base.vertices + shift, base.faces)
    s = vs.SliceSettings(initial_layer_height=200)
    z0, p0, t0 = vs.layer_heights(base, s)
    z1, p1, t1 = vs.layer_heights(shifted, s)
    assert len(z0) == 99
    assert (z1 == z0 - 12345).all()
    assert (p0 == p1).all() and (t0 == t1).all()


@pytest.mark.parametrize("compat", ["vecslice", "cura"])
@pytest.mark.parametrize("stray_z", [-50, 500_000])
def test_a_vertex_no_face_uses_does_not_move_the_schedule(compat, stray_z):
    """vs.Mesh keeps unused vertices; the schedule is the faces' (as CuraEngine's
    vertex list, and the adaptive schedule, hold only vertices of faces)."""
    v = np.array([[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 3000]])
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    base = vs.Mesh(v, f)
    stray = vs.Mesh(np.vstack([v, [[9, 9, stray_z]]]), f)
    s = vs.SliceSettings(compat=compat)
    for got, want in zip(vs.layer_heights(stray, s), vs.layer_heights(base, s),
                         strict=True):
        assert np.array_equal(got, want)
    a, b = vs.slice_mesh(stray, s), vs.slice_mesh(base, s)
    assert np.array_equal(a.coords, b.coords) and a.n_layers == b.n_layers
    from vecslice.metrics import volume_error

    va = volume_error(a, stray)
    vb = volume_error(b, base)
    assert va == vb
    assert stray._corner_zrange() == (0, 3000) and stray.zrange[0] == min(0, stray_z)


def _needle_box_stl(path):
    """A 10 mm cube with a 1 mm needle on top whose base corners are 10 µm
    apart: CuraEngine's 30 µm melding drops the needle's faces, but its tip
    vertex stays in CuraEngine's vertex list and bounding box."""
    def tri(a, b, c):
        return ("facet normal 0 0 0\n outer loop\n"
                + "".join(f"  vertex {p[0]} {p[1]} {p[2]}\n" for p in (a, b, c))
                + " endloop\nendfacet\n")

    p = [(0, 0, 0), (10, 0, 0), (10, 10, 0), (0, 10, 0), (0, 0, 10), (10, 0, 10),
         (10, 10, 10), (0, 10, 10)]
    f = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4),
         (1, 2, 6), (1, 6, 5), (2, 3, 7), (2, 7, 6), (3, 0, 4), (3, 4, 7)]
    b0, b1, b2, tip = (5, 5, 10), (5.01, 5, 10), (5, 5.01, 10), (5, 5, 11)
    text = ("solid needle\n" + "".join(tri(p[a], p[b], p[c]) for a, b, c in f)
            + tri(b0, b1, tip) + tri(b1, b2, tip) + tri(b2, b0, tip)
            + "endsolid needle\n")
    path.write_text(text)
    return path


def test_compat_cura_schedules_reach_curaengines_bounding_box(tmp_path):
    """CuraEngine's layer count (the mesh's bounding box height) and adaptive
    model_max_z (its largest vertex z) count the vertices of faces its melding
    dropped (CURA_COMPAT.md 2, ADAPTIVE.md 1). Expected values from an
    independent transcription of the spec (validated on every adaptive vector):
    108 uniform layers (98 from the box alone), 141 adaptive layers up to
    slice_z 11010 (the last ones 10 µm thick above the faces)."""
    import pickle

    mesh = vs.load_mesh(_needle_box_stl(tmp_path / "needle.stl"), compat="cura")
    assert mesh.zrange == (0, 11000) and mesh.faces.shape[0] == 12
    assert mesh._corner_zrange() == (0, 11000)
    uniform = vs.SliceSettings(compat="cura")
    adaptive = vs.SliceSettings(compat="cura", adaptive_layers=True)
    z, _, _ = vs.layer_heights(mesh, uniform)
    assert len(z) == 108 and int(z[-1]) == 10950
    z, _, t = vs.layer_heights(mesh, adaptive)
    assert len(z) == 141 and int(z[-1]) == 11010 and int(t[-1]) == 10
    # the range travels with the mesh: a pickle (sweep workers), a translation
    again = pickle.loads(pickle.dumps(mesh))
    assert again._corner_zrange() == (0, 11000)
    assert len(vs.layer_heights(again, uniform)[0]) == 108
    moved = mesh.translated(0, 0, 500)
    assert moved._corner_zrange() == (500, 11500)
    assert np.array_equal(vs.layer_heights(moved, uniform)[0],
                          vs.layer_heights(mesh, uniform)[0] + 500)
    # read the vecslice way, the needle's faces are kept: the top is 11000 too
    assert vs.load_mesh(tmp_path / "needle.stl")._corner_zrange() == (0, 11000)


def test_a_schedule_beyond_the_coordinate_limit_is_refused_by_name():
    """The last adaptive layer ends above the model: on a mesh whose top is near
    2**30 µm it used to fail later, blaming a `slice_z` the user never gave."""
    x = 2**30 - 1
    m = vs.Mesh.from_arrays([[-x, -x, -x], [x, -x, -x], [0, x, -x], [0, 0, x]],
                            [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    s = vs.SliceSettings(layer_height=10**8, initial_layer_height=10**8,
                         adaptive_layers=True, adaptive_variation=0)
    match = (r"the layer schedule must stay below z = 2\*\*30 µm .*; got layer 21 at "
             r"z = 1126258177 µm, above a mesh whose top is at 1073741823 µm \(the "
             r"last adaptive layer ends above the model\): move the mesh down")
    with pytest.raises(vs.InputValueError, match=match):
        vs.layer_heights(m, s)
    with pytest.raises(vs.InputValueError, match=match):
        vs.slice_mesh(m, s)


def test_a_mesh_whose_layers_would_print_beyond_the_limit_is_refused_first():
    """Audit s25 api D4: print_z is measured from the mesh's lowest point, so a mesh
    taller than 2**30 µm (every coordinate valid) sliced fully and was refused only
    when stored, naming a `print_z` the user never gave."""
    x = 2**30 - 1
    m = vs.Mesh.from_arrays([[-x, -x, -x], [x, -x, -x], [-x, x, -x], [x, x, x]],
                            [[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]])
    s = vs.SliceSettings(layer_height=2_000_000, initial_layer_height=2_000_000)
    match = (r"the layers must print below 2\*\*30 µm \(about 1 km\) above the bed; "
             r"got layer 536 at 1074000000 µm, for a mesh 2147483646 µm tall \(from "
             r"z = -1073741823 to 1073741823 µm\)")
    with pytest.raises(vs.InputValueError, match=match):
        vs.layer_heights(m, s)
    with pytest.raises(vs.InputValueError, match=match):
        vs.slice_mesh(m, s)
    low = vs.Mesh.from_arrays(m.vertices // 4, m.faces)  # a quarter as tall: sliced
    assert vs.slice_mesh(low, s).n_layers == 268


def test_default_settings():
    mesh = vs.Mesh.from_arrays(
        np.array([[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 1000]]),
        np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]),
    )
    z, p, t = vs.layer_heights(mesh)
    assert z.tolist() == [150, 350, 450, 550, 650, 750, 850, 950]
    assert t[0] == 300 and (t[1:] == 100).all()


@pytest.mark.parametrize(
    ("kwargs", "error", "fragment"),
    [
        ({"layer_height": 0}, vs.SettingsError, "`layer_height` must be >= 1; got 0"),
        ({"layer_height": -100}, ValueError, "`layer_height` must be >= 1"),
        ({"initial_layer_height": 0}, ValueError, "`initial_layer_height`"),
        ({"layer_height": 0.5}, TypeError, "`layer_height` must be an integer"),
        ({"layer_height": "100"}, TypeError, "got str '100'"),
        ({"layer_height": True}, TypeError, "`layer_height`"),
        ({"slicing_tolerance": "mid"}, vs.SettingsError, "got 'mid'"),
        ({"slicing_tolerance": None}, ValueError, "`slicing_tolerance` must be one"),
        ({"max_deviation": -1}, ValueError, "`max_deviation` must be >= 0"),
        ({"union_overlapping_volumes": 1}, TypeError, "`union_overlapping_volumes`"),
        ({"layer_height": 2**31}, ValueError, "`layer_height` must be <="),
        ({"adaptive_layers": 1}, TypeError,
         "`adaptive_layers` must be True or False; got int 1"),
        ({"adaptive_layers": "yes"}, vs.InputTypeError, "got str 'yes'"),
        ({"adaptive_variation_step": 0}, vs.SettingsError,
         "`adaptive_variation_step` must be >= 1; got 0"),
        ({"adaptive_variation_step": -10}, ValueError,
         "`adaptive_variation_step` must be >= 1; got -10"),
        ({"adaptive_variation": -1}, vs.SettingsError,
         "`adaptive_variation` must be >= 0 .*no height is allowed.*; got -1"),
        ({"adaptive_variation": 0.5}, TypeError, "`adaptive_variation` must be an int"),
        ({"adaptive_threshold": None}, TypeError, "`adaptive_threshold` must be an"),
        ({"adaptive_threshold": 2**31}, ValueError, "`adaptive_threshold` must be <="),
    ],
)
def test_bad_settings(kwargs, error, fragment):
    with pytest.raises(error, match=fragment.replace("(", r"\(")) as info:
        vs.SliceSettings(**kwargs)
    assert isinstance(info.value, vs.VecsliceError)
    # every bad setting is a SettingsError (as errors.py says), wrong types also
    # TypeErrors: `except vs.SettingsError` catches them all
    assert isinstance(info.value, vs.SettingsError)


def test_unknown_setting_is_rejected():
    with pytest.raises(TypeError, match="layer_hieght") as info:
        vs.SliceSettings(layer_hieght=100)
    assert isinstance(info.value, vs.SettingsError)


def test_layer_heights_rejects_non_settings():
    mesh = vs.Mesh.from_arrays(
        np.array([[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 1000]]),
        np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]),
    )
    with pytest.raises(vs.InputTypeError, match="`settings` must be"):
        vs.layer_heights(mesh, {"layer_height": 100})
    with pytest.raises(vs.InputTypeError, match="`mesh` must be"):
        vs.layer_heights("cube.stl", vs.SliceSettings())


def test_adaptive_settings_defaults_and_replace():
    s = vs.SliceSettings()
    assert (s.adaptive_layers, s.adaptive_variation, s.adaptive_variation_step,
            s.adaptive_threshold) == (False, 100, 10, 200)
    t = s.replace(adaptive_layers=True, adaptive_threshold=-5)
    assert t.adaptive_layers is True and t.adaptive_threshold == -5
    assert vs.SliceSettings(adaptive_layers=np.True_).adaptive_layers is True
    names = s.option_names()
    i = names.index("adaptive_layers")
    assert names[i:i + 4] == ("adaptive_layers", "adaptive_variation",
                              "adaptive_variation_step", "adaptive_threshold")


def test_layer_heights_switches_to_the_adaptive_schedule():
    from vecslice.adaptive import adaptive_layer_heights

    # a tetrahedron 2 mm tall, lowest point 3 mm below z = 0, one face at 45 deg
    mesh = vs.Mesh.from_arrays(
        np.array([[0, 0, 0], [0, 2000, 0], [2000, 0, 2000], [2000, 0, 0]]) - [
            0, 0, 3000],
        np.array([[0, 2, 1], [0, 3, 2], [1, 2, 3], [0, 1, 3]]),
    )
    uniform = vs.layer_heights(mesh, vs.SliceSettings())
    s = vs.SliceSettings(adaptive_layers=True)
    z, p, t = vs.layer_heights(mesh, s)
    assert [a.tolist() for a in (z, p, t)] == [
        a.tolist() for a in adaptive_layer_heights(mesh, s)]
    # 200 / tan(45 deg) is 200.00000000000003 > 200 µm: 190 µm layers
    assert t.tolist() == [300, 200] + [190] * 8 and (z == p - 3000).all()
    assert p[-2] <= 2000 < p[-1]  # the last layer ends above the model
    assert len(z) != len(uniform[0])  # not the uniform schedule


def test_from_arrays_knows_its_corner_range_without_a_gather():
    """from_arrays drops unused vertices, so its vertex range is the corners'."""
    rng = np.random.default_rng(5)
    v = rng.integers(-5000, 5000, (40, 3))
    f = rng.integers(0, 30, (25, 3))  # vertices 30..39 unused, dropped
    m = vs.Mesh.from_arrays(v, f)
    used = np.unique(m.faces)
    assert m._zcorners == (int(m.vertices[used, 2].min()),
                           int(m.vertices[used, 2].max()))
    raw = vs.Mesh(v, f)
    assert raw._corner_zrange() == (int(v[np.unique(f), 2].min()),
                                    int(v[np.unique(f), 2].max()))
