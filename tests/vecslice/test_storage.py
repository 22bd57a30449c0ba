"""Tests for vecslice.storage: SlicedModel layout, views, areas, save/load."""

from __future__ import annotations

import os

import numpy as np
import pytest
import shapely
import trimesh

from vecslice import (
    InputTypeError,
    InputValueError,
    LayerPaths,
    LayoutError,
    StorageFileError,
)
from vecslice.layerparts import LayerParts
from vecslice.parts import make_parts
from vecslice.storage import FORMAT, SlicedModel, load_sliced

FIELDS = (
    "slice_z", "print_z", "thickness", "layer_offsets", "part_offsets",
    "ring_offsets", "coords", "open_coords", "open_ring_offsets",
    "open_layer_offsets", "open_chains", "stitched_gaps",
)  # fmt: skip


def rect(x0, y0, x1, y1, *, cw=False):
    r = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    return r[::-1] if cw else r


def loops_of(*layers):
    rings = [np.asarray(r, np.int64) for lay in layers for r in lay]
    lens = [0] + [len(r) for r in rings]
    coords = np.concatenate(rings) if rings else np.empty((0, 2), np.int64)
    return LayerPaths(
        coords, np.cumsum(lens), np.cumsum([0] + [len(x) for x in layers])
    )


@pytest.fixture
def model():
    """3 layers: plate with a hole + island, empty layer, two squares; open chain."""
    parts = make_parts(
        loops_of(
            [rect(0, 0, 3000, 3000), rect(1000, 1000, 2000, 2000, cw=True),
             rect(1200, 1200, 1800, 1800)],
            [],
            [rect(0, 0, 1000, 1000), rect(2000, 0, 3000, 500)],
        )
    )  # fmt: skip
    opened = LayerPaths([[0, 0], [5, 5], [9, 0]], [0, 3], [0, 0, 1, 1])
    return SlicedModel.from_parts(
        parts, slice_z=[150, 350, 450], print_z=[300, 400, 500],
        thickness=[300, 100, 100], open=opened, stitched_gaps=[0, 2, 0],
    )  # fmt: skip


def test_layout_views_and_areas(model):
    assert (model.n_layers, model.n_parts, model.n_rings) == (3, 4, 5)
    assert model.layer_offsets.tolist() == [0, 2, 2, 4]
    assert model.part_offsets.tolist() == [0, 2, 3, 4, 5]
    assert model.layer_areas().tolist() == [9e6 - 1e6 + 0.36e6, 0.0, 1e6 + 0.5e6]
    assert model.layer_areas().dtype == np.float64
    (outline, holes), (island, no_holes) = model.layer(0)
    assert outline.tolist() == rect(0, 0, 3000, 3000)
    hole = [[1000, 1000], [1000, 2000], [2000, 2000], [2000, 1000]]
    assert [h.tolist() for h in holes] == [hole]
    assert island.min(axis=0).tolist() == [1200, 1200] and no_holes == []
    assert model.layer(1) == []
    assert model.part(2, 1)[0].min(axis=0).tolist() == [2000, 0]
    assert model.part(-1, -1)[0].tolist() == model.part(2, 1)[0].tolist()
    assert model.open_chains.tolist() == [0, 1, 0]
    assert model.stitched_gaps.tolist() == [0, 2, 0]
    assert model.open.layer(1)[0].tolist() == [[0, 0], [5, 5], [9, 0]]
    assert model.bounds().tolist() == [[0, 0], [3000, 3000]]
    assert "3 layers, 4 parts, 5 rings" in repr(model)


def test_arrays_are_frozen_int64_and_copied(model):
    for name in FIELDS:
        a = getattr(model, name)
        assert a.dtype == np.int64 and not a.flags.writeable, name
    slice_z = np.array([1], np.int64)
    m = SlicedModel(slice_z, [2], [2], [0, 0], [0], [0], np.empty((0, 2), int))
    slice_z[0] = 99
    assert m.slice_z.tolist() == [1]
    with pytest.raises(AttributeError):
        m.coords = None
    assert m.bounds() is None and m.layer_areas().tolist() == [0.0]


def test_to_shapely_in_mm(model):
    mp = model.to_shapely(0)
    assert isinstance(mp, shapely.MultiPolygon)
    assert mp.area == pytest.approx(9 - 1 + 0.36)
    assert mp.is_valid and len(mp.geoms) == 2
    assert model.to_shapely(1).is_empty


def test_round_trip_is_bit_exact(model, tmp_path):
    for compress in (False, True):
        path = tmp_path / f"m{compress}.npz"
        model.save(path, compress=compress)
        back = load_sliced(str(path))
        for name in FIELDS:
            a, b = getattr(model, name), getattr(back, name)
            assert a.dtype == b.dtype and a.shape == b.shape, name
            assert np.array_equal(a, b), name
        assert os.listdir(tmp_path).count(path.name) == 1
    assert sorted(os.listdir(tmp_path)) == ["mFalse.npz", "mTrue.npz"]  # no temp files


def test_save_keeps_the_name_and_overwrites(model, tmp_path):
    path = tmp_path / "model.vsl"
    path.write_bytes(b"old")
    model.save(path)
    assert sorted(os.listdir(tmp_path)) == ["model.vsl"]
    assert load_sliced(path).n_parts == 4


def test_realistic_model_bytes_per_vertex(tmp_path):
    """Sections of a torus knot and a capsule: ~17 B per vertex, offsets included."""
    mesh = trimesh.creation.torus(
        major_radius=20, minor_radius=6, major_sections=96, minor_sections=48
    )
    mesh = trimesh.util.concatenate(
        [
            mesh,
            trimesh.creation.capsule(height=30, radius=5).apply_translation([60, 0, 0]),
        ]
    )
    zs = np.arange(-5.95, 6.0, 0.1)
    rings, per_layer = [], []
    for z in zs:
        sec = mesh.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
        loops = (
            []
            if sec is None
            else [np.rint(d[:-1, :2] * 1000).astype(np.int64) for d in sec.discrete]
        )
        rings += loops
        per_layer.append(len(loops))
    lens = [0] + [len(r) for r in rings]
    loops = LayerPaths(
        np.concatenate(rings), np.cumsum(lens), np.cumsum([0, *per_layer])
    )
    parts = make_parts(loops, union_overlapping_volumes=False)
    z = np.rint(zs * 1000).astype(np.int64)
    model = SlicedModel.from_parts(
        parts, slice_z=z, print_z=z + 50, thickness=np.full(len(z), 100)
    )
    per_vertex = model.nbytes / model.coords.shape[0]
    print(f"{per_vertex:.3f} bytes per vertex")
    assert 16 < per_vertex <= 17, per_vertex
    model.save(tmp_path / "m.npz")
    assert os.path.getsize(tmp_path / "m.npz") <= 17.5 * model.coords.shape[0]


def _npz(path, **arrays):
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)
    return path


def _good(model):
    return {"format": np.array(FORMAT), "version": np.array(1)} | {
        k: getattr(model, k) for k in FIELDS
    }


@pytest.mark.parametrize(
    ("make", "fragment"),
    [
        (lambda d, m: d / "missing.npz", "missing.npz' does not exist"),
        (lambda d, m: d, "is a directory"),
        (lambda d, m: (d / "g.npz").write_bytes(b"garbage" * 50) and d / "g.npz",
         "is not an .npz file written by SlicedModel.save"),
        (lambda d, m: ((d / "e.npz").write_bytes(b"") and d / "e.npz")
         or d / "e.npz", "is not an .npz file"),
        (lambda d, m: np.save(d / "a.npy", np.arange(3)) or d / "a.npy",
         "is a single .npy array"),
        (lambda d, m: _npz(d / "o.npz", x=np.arange(3)),
         "is not a saved vecslice model \\(format marker None"),
        (lambda d, m: _npz(d / "f.npz", **(_good(m) | {"format": np.array("other")})),
         "format marker 'other'"),
        (lambda d, m: _npz(d / "v.npz", **(_good(m) | {"version": np.array(7)})),
         "format version 7; this vecslice reads versions 1 to 1"),
        (lambda d, m: _npz(d / "k.npz", **{k: v for k, v in _good(m).items()
                                           if k != "part_offsets"}),
         "misses the array 'part_offsets'"),
        (lambda d, m: _npz(d / "t.npz", **(_good(m) | {
            "coords": m.coords.astype(np.float64)})),
         "array 'coords' must have dtype int64; got float64"),
        (lambda d, m: _npz(d / "l.npz", **(_good(m) | {
            "part_offsets": np.array([0, 2, 3, 4, 6], np.int64)})),
         "invalid vecslice model: `part_offsets` must end at 5"),
        (lambda d, m: _npz(d / "p.npz", **(_good(m) | {
            "slice_z": np.array([1, 2], np.int64)})),
         "invalid vecslice model: `print_z` must have length 2"),
    ],
)  # fmt: skip
def test_bad_files(model, tmp_path, make, fragment):
    path = make(tmp_path, model)
    with pytest.raises(StorageFileError, match=fragment) as info:
        load_sliced(path)
    assert isinstance(info.value, OSError)
    assert str(path) in str(info.value)


def test_truncated_archive(model, tmp_path):
    path = tmp_path / "m.npz"
    model.save(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(StorageFileError, match=r"m\.npz"):
        load_sliced(path)


def test_failed_save_leaves_no_file(model, tmp_path):
    target = tmp_path / "nope" / "m.npz"
    with pytest.raises(
        StorageFileError, match=r"cannot save a vecslice model to .*nope"
    ):
        model.save(target)
    assert not (tmp_path / "nope").exists()
    (tmp_path / "dir.npz").mkdir()
    with pytest.raises(StorageFileError, match=r"dir\.npz"):
        model.save(tmp_path / "dir.npz")
    assert (
        os.listdir(tmp_path) == ["dir.npz"] and os.listdir(tmp_path / "dir.npz") == []
    )


def test_failed_write_removes_the_temp_file(model, tmp_path, monkeypatch):
    def boom(fh, **arrays):
        fh.write(b"partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(StorageFileError, match="No space left on device"):
        model.save(tmp_path / "m.npz")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"print_z": [1, 2]}, "`print_z` must have length 1 .* got 2"),
        ({"layer_offsets": [0, 0, 1]},
         "`layer_offsets` must have length 2 \\(layers \\+ 1, as `slice_z`\\); got 3"),
        ({"part_offsets": [0, 0, 1], "layer_offsets": [0, 2]},
         "part 0 is empty"),
        ({"ring_offsets": [0, 5]}, "`ring_offsets` must end at 4"),
        ({"open_chains": [0, 0]}, "`open_chains` must have length 1"),
        ({"open_coords": [[0, 0]], "open_ring_offsets": [0, 1],
          "open_layer_offsets": [0, 1, 1]}, "`open_layer_offsets` must have length 2"),
    ],
)  # fmt: skip
def test_layout_errors(kwargs, fragment):
    base = {
        "slice_z": [1],
        "print_z": [2],
        "thickness": [2],
        "layer_offsets": [0, 1],
        "part_offsets": [0, 1],
        "ring_offsets": [0, 4],
        "coords": rect(0, 0, 1, 1),
    }
    base |= kwargs
    positional = [base.pop(k) for k in FIELDS[:7]]
    with pytest.raises(LayoutError, match=fragment):
        SlicedModel(*positional, **base)


def test_index_errors(model):
    with pytest.raises(
        ValueError, match="`i` must be a layer index in \\[-3, 3\\); got 3"
    ):
        model.layer(3)
    with pytest.raises(ValueError, match="`j` must be a part index of layer 1"):
        model.part(1, 0)


@pytest.mark.parametrize("value", ["yes", 1, None])
def test_compress_must_be_a_bool(model, tmp_path, value):
    """Issue 8 D8: compress='yes' was taken by truthiness."""
    with pytest.raises(InputTypeError, match="`compress` must be True or False"):
        model.save(tmp_path / "m.npz", compress=value)
    assert os.listdir(tmp_path) == []


SQ = rect(0, 0, 10, 10)
HOLE = rect(2, 2, 8, 8, cw=True)


@pytest.mark.parametrize(
    ("coords", "ring_offsets", "part_offsets", "fragment"),
    [
        # Issue 8 B5: clockwise or empty outlines were accepted at load
        (rect(0, 0, 10, 10, cw=True), [0, 4], [0, 1],
         r"ring 0 \(the outline of part 0, layer 0\) must be counter-clockwise "
         r"\(area > 0\); got twice the signed area -200 µm²"),
        (SQ + rect(2, 2, 8, 8), [0, 4, 8], [0, 2],
         r"ring 1 \(a hole of part 0, layer 0\) must be clockwise \(area < 0\); "
         r"got twice the signed area 72"),
        ([[0, 0], [10, 0], [20, 0]], [0, 3], [0, 1],
         r"ring 0 \(the outline .*\) must be counter-clockwise .* got .* area 0 "),
        ([[0, 0], [10, 0]], [0, 2], [0, 1],
         r"every ring must have >= 3 vertices; ring 0 \(the outline of part 0, "
         r"layer 0\) has 2"),
        (SQ + HOLE[:2], [0, 4, 6], [0, 2], r"ring 1 \(a hole .*\) has 2"),
        (SQ + HOLE[:2], [0, 4, 4, 6], [0, 3], r"ring 1 \(a hole .*\) has 0"),
    ],
)  # fmt: skip
def test_ring_sizes_and_orientation_are_validated(
    tmp_path, coords, ring_offsets, part_offsets, fragment
):
    layout = {"slice_z": [1], "print_z": [2], "thickness": [2],
              "layer_offsets": [0, len(part_offsets) - 1],
              "part_offsets": part_offsets, "ring_offsets": ring_offsets,
              "coords": coords}  # fmt: skip
    with pytest.raises(LayoutError, match=fragment):
        SlicedModel(*(layout[k] for k in FIELDS[:7]))
    with pytest.raises(LayoutError, match=fragment):
        LayerParts(coords, ring_offsets, part_offsets, [0, len(part_offsets) - 1])
    good = SlicedModel([1], [2], [2], [0, 1], [0, 2], [0, 4, 8], SQ + HOLE)
    arrays = _good(good) | {k: np.asarray(v, np.int64).reshape(-1, 2)
                            if k == "coords" else np.asarray(v, np.int64)
                            for k, v in layout.items()}
    path = _npz(tmp_path / "bad.npz", **arrays)
    if 3 * (len(ring_offsets) - 1) > len(coords):  # seen in the .npy headers
        fragment = (rf"`ring_offsets` has {len(ring_offsets)} entries, too many for "
                    rf"{len(coords)} vertices \(every ring has >= 3 vertices\)")
    with pytest.raises(StorageFileError, match="holds an invalid vecslice model: "
                       r"(every ring must have >= 3 vertices; )?" + fragment):
        load_sliced(path)


def test_second_layer_second_part_is_located():
    coords = SQ + rect(20, 0, 30, 10) + rect(22, 2, 28, 8)  # 3rd ring: CCW hole
    with pytest.raises(LayoutError, match=r"ring 2 \(a hole of part 1, layer 1\)"):
        SlicedModel([1, 2], [2, 3], [2, 1], [0, 1, 2], [0, 1, 3], [0, 4, 8, 12],
                    coords)


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        # Issue 8 C2: an array-shaped version raised TypeError
        ({"version": np.array([1, 1])},
         r"`version` must be one integer; got an array of dtype int64 and shape "
         r"\(2,\)"),
        ({"version": np.array(1.0)}, "`version` must be one integer; got .*float64"),
        ({"version": np.array("1")}, "`version` must be one integer"),
        ({"format": np.array([FORMAT, FORMAT])},
         "format marker '<array of dtype <U20 and shape \\(2,\\)>'"),
        ({"format": np.array(FORMAT * 100)}, "format marker '<array of dtype <U"),
        ({"format": np.array(7)}, "format marker '<array of dtype int64"),
    ],
)  # fmt: skip
def test_format_and_version_fields_must_be_scalars(model, tmp_path, change, fragment):
    path = _npz(tmp_path / "v.npz", **(_good(model) | change))
    with pytest.raises(StorageFileError, match=fragment):
        load_sliced(path)


@pytest.mark.parametrize(
    ("schedule", "fragment"),
    [
        # audit s23 D10 / api D14: all of these loaded silently
        ({"slice_z": [100, 2**30]},
         r"`slice_z` must satisfy \|value\| < 2\*\*30 µm .*got 1073741824 at layer 1"),
        ({"slice_z": [-(2**62), 100]}, r"`slice_z` .* got -4611686018427387904 at "
                                       "layer 0"),
        ({"print_z": [200, 2**50]}, r"`print_z` .* got 1125899906842624 at layer 1"),
        ({"thickness": [-5, 100]}, r"`thickness` must be > 0 and < 2\*\*30 µm; got -5 "
                                   "at layer 0"),
        ({"thickness": [200, 0]}, "`thickness` .* got 0 at layer 1"),
        ({"thickness": [200, 2**30]}, "`thickness` .* got 1073741824 at layer 1"),
        ({"print_z": [300, 200]}, r"`print_z` must increase from layer to layer .*"
                                  "got 200 at layer 1 after 300 at layer 0"),
        # two layers at one height: no schedule vecslice makes has them
        ({"print_z": [200, 200]}, "got 200 at layer 1 after 200 at layer 0"),
    ],
)  # fmt: skip
def test_layer_schedule_is_validated(tmp_path, schedule, fragment):
    layout = {"slice_z": [100, 250], "print_z": [200, 300], "thickness": [200, 100],
              "layer_offsets": [0, 1, 1], "part_offsets": [0, 1],
              "ring_offsets": [0, 4], "coords": SQ} | schedule  # fmt: skip
    with pytest.raises(InputValueError, match=fragment):
        SlicedModel(*(layout[k] for k in FIELDS[:7]))
    good = SlicedModel([100, 250], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4],
                       SQ)
    arrays = _good(good) | {k: np.asarray(v, np.int64) for k, v in schedule.items()}
    path = _npz(tmp_path / "bad.npz", **arrays)
    with pytest.raises(StorageFileError,
                       match="holds an invalid vecslice model: .*" + fragment):
        load_sliced(path)


def test_every_schedule_vecslice_makes_is_a_valid_model(tmp_path):
    """The schedule checks accept what slicing produces: uniform in every
    tolerance mode, adaptive, Cura compatibility, negative mesh heights."""
    from vecslice import SliceSettings, demo_mesh, load_mesh, slice_mesh

    mesh = demo_mesh()
    low = trimesh.creation.box((20, 20, 8))
    low.apply_translation((0, 0, -20))  # entirely below z = 0
    for m, settings in [
        (mesh, SliceSettings(slicing_tolerance="middle")),
        (mesh, SliceSettings(slicing_tolerance="inclusive")),
        (mesh, SliceSettings(slicing_tolerance="exclusive", layer_height=400,
                             initial_layer_height=100)),
        (mesh, SliceSettings(adaptive_layers=True)),
        (mesh, SliceSettings(compat="cura")),
        (load_mesh(low), SliceSettings()),
    ]:
        model = slice_mesh(m, settings)
        assert model.n_layers > 10
        assert (np.diff(model.print_z) > 0).all() and (model.thickness > 0).all()
        model.save(tmp_path / "m.npz")
        assert load_sliced(tmp_path / "m.npz").print_z.tolist() == \
            model.print_z.tolist()


@pytest.mark.parametrize(
    ("counts", "fragment"),
    [
        # audit s24 D8: negative counts loaded; 2**62 twice summed to -2**63
        ({"open_chains": [0, -1]}, r"`open_chains` must be a count per layer, >= 0 "
                                   r"and < 2\*\*31; got -1 at layer 1"),
        ({"open_chains": [2**62, 2**62]}, r"`open_chains` .* got 4611686018427387904 "
                                          "at layer 0"),
        ({"stitched_gaps": [-5, 0]}, "`stitched_gaps` must be a count per layer, "
                                     ">= 0 and < 2\\*\\*31; got -5 at layer 0"),
        ({"stitched_gaps": [0, 2**31]}, "`stitched_gaps` .* got 2147483648 at layer 1"),
    ],
)  # fmt: skip
def test_broken_mesh_counts_are_validated(tmp_path, counts, fragment):
    good = SlicedModel([100, 250], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4],
                       SQ)
    with pytest.raises(InputValueError, match=fragment):
        SlicedModel([100, 250], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4], SQ,
                    **counts)
    arrays = _good(good) | {k: np.asarray(v, np.int64) for k, v in counts.items()}
    path = _npz(tmp_path / "bad.npz", **arrays)
    with pytest.raises(StorageFileError,
                       match="holds an invalid vecslice model: .*" + fragment):
        load_sliced(path)
    ok = SlicedModel([100, 250], [200, 300], [200, 100], [0, 1, 1], [0, 1], [0, 4], SQ,
                     open_chains=[0, 2**31 - 1], stitched_gaps=[7, 0])
    assert ok.open_chains.tolist() == [0, 2**31 - 1]


@pytest.mark.parametrize(
    ("open_coords", "fragment", "error"),
    [
        # audit s24 D9: these named `coords`, which was valid
        ([[0.5, 0.0], [1.0, 1.0]], "`open_coords` must be integer microns; got "
                                   "dtype float64", InputTypeError),
        ([[0, 0], [2**31, 0]], r"`open_coords` must satisfy \|value\| < 2\*\*30 µm "
                               r".*got 2147483648 at row 1", InputValueError),
        ([[0, 0, 0], [1, 1, 1]], r"`open_coords` must have shape \(N, 2\); got shape "
                                 r"\(2, 3\)", InputValueError),
    ],
)  # fmt: skip
def test_open_coords_errors_name_open_coords(tmp_path, open_coords, fragment, error):
    with pytest.raises(error, match=fragment):
        SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4], SQ,
                    open_coords=open_coords, open_ring_offsets=[0, 2],
                    open_layer_offsets=[0, 1])
    if error is InputValueError and len(open_coords[0]) == 2:
        good = SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4], SQ,
                           open_coords=[[0, 0], [5, 5]], open_ring_offsets=[0, 2],
                           open_layer_offsets=[0, 1])
        path = _npz(tmp_path / "o.npz", **(_good(good) | {
            "open_coords": np.asarray(open_coords, np.int64)}))
        with pytest.raises(StorageFileError, match="holds an invalid vecslice model: "
                           + fragment):
            load_sliced(path)


@pytest.mark.parametrize("cw", [True, False], ids=["clockwise", "counter-clockwise"])
def test_outline_wound_twice_near_the_limit_is_refused(tmp_path, cw):
    # audit s24 D6: the twice-area of a clockwise square wound twice wrapped to
    # +1.7e10 in int64, so the ring was accepted as an outline
    x = 2**30 - 1
    twice = rect(-x, -x, x, x, cw=cw) * 2
    fragment = (r"twice the signed area of ring 0 \(the outline of part 0, layer 0\) "
                r"must fit int64 \(\|value\| < 2\*\*63\); got "
                + ("-" if cw else "") + "18446744039349813264 µm²")
    with pytest.raises(InputValueError, match=fragment):
        SlicedModel([1], [2], [2], [0, 1], [0, 1], [0, 8], twice)
    with pytest.raises(InputValueError, match=fragment):
        LayerParts(twice, [0, 8], [0, 1], [0, 1])
    good = SlicedModel([1], [2], [2], [0, 1], [0, 1], [0, 8], rect(0, 0, 10, 10) * 2)
    path = _npz(tmp_path / "w.npz", **(_good(good) | {
        "coords": np.asarray(twice, np.int64)}))
    with pytest.raises(StorageFileError,
                       match="holds an invalid vecslice model: " + fragment):
        load_sliced(path)


def _model_arrays():
    return {
        "slice_z": np.array([1], np.int64), "print_z": np.array([2], np.int64),
        "thickness": np.array([2], np.int64), "layer_offsets": np.array([0, 1]),
        "part_offsets": np.array([0, 2]), "ring_offsets": np.array([0, 4, 8]),
        "coords": np.array(SQ + HOLE, np.int64),
        "open_coords": np.array([[0, 0], [5, 5]]),
        "open_ring_offsets": np.array([0, 2]),
        "open_layer_offsets": np.array([0, 1]), "open_chains": np.array([1]),
        "stitched_gaps": np.array([0]),
    }


@pytest.mark.parametrize(("name", "index", "value", "fragment"), [
    ("slice_z", 0, 2**30, r"`slice_z` must satisfy \|value\| < 2\*\*30"),
    ("print_z", 0, -(2**30), r"`print_z` must satisfy .* got -1073741824 at layer 0"),
    ("thickness", 0, 0, r"`thickness` must be > 0 .* got 0 at layer 0"),
    ("open_chains", 0, -1, r"`open_chains` must be a count .* got -1 at layer 0"),
    ("stitched_gaps", 0, 2**31, r"`stitched_gaps` must be a count .* got 2147483648"),
    ("coords", (5, 0), 2**30, r"`coords` must satisfy \|value\| < 2\*\*30"),
    ("coords", (5, 0), -100, r"ring 1 \(a hole of part 0, layer 0\) must be clockwise"),
    ("ring_offsets", 1, 2, r"ring 0 \(the outline of part 0, layer 0\) has 2"),
    ("part_offsets", 1, 10**12, r"`part_offsets` must end at 2 .* got 1000000000000"),
    ("layer_offsets", 1, 0, r"`layer_offsets` must end at 1 .* got 0 at index 1"),
    ("open_coords", (1, 1), 2**30, r"`open_coords` must satisfy \|value\|"),
    ("open_ring_offsets", 1, 10**12, r"`open_ring_offsets` must end at 2"),
    ("open_layer_offsets", 1, 10**12, r"`open_layer_offsets` must end at 1"),
])  # fmt: skip
def test_sliced_model_checks_the_copies_it_keeps(write_when_copied, name, index,
                                                 value, fragment):
    """Audit s26 state D2: SlicedModel checked the caller's arrays, then copied
    them; a write by another thread in between was kept unchecked (offsets out of
    range: kernels read out of bounds). Here the write lands just before the copy."""
    given = _model_arrays()
    SlicedModel(**given)  # valid as given
    writes = write_when_copied(given[name], index, value)
    with pytest.raises(ValueError, match=fragment):
        SlicedModel(**given)
    assert writes == [index]
