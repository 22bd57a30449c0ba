"""Tests for vecslice.ragged: immutable arrays, index checks, offsets helpers."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import vecslice as vs
from vecslice import ragged
from vecslice.layerparts import LayerParts
from vecslice.ragged import adopt, freeze, is_frozen, private_int_extremes


def assert_immutable(a: np.ndarray) -> None:
    """Neither ``a`` nor any array it is a view of can be made writeable again."""
    assert isinstance(a, np.ndarray) and not a.flags.writeable
    x = a
    while isinstance(x, np.ndarray):
        with pytest.raises(ValueError, match="WRITEABLE"):
            x.flags.writeable = True
        assert not x.flags.writeable
        x = x.base
    # the end of the chain exports no writeable buffer
    try:
        view = memoryview(x)
    except TypeError:
        pass
    else:
        assert view.readonly


def square_model():
    sq = [[0, 0], [10, 0], [10, 10], [0, 10]]
    return vs.SlicedModel([100], [200], [200], [0, 1], [0, 1], [0, 4], sq)


def containers():
    """Every container vecslice returns, built the usual ways."""
    box = vs.load_mesh(trimesh.creation.box((10, 10, 2)))
    model = vs.slice_mesh(box)
    loops = vs.slice_contours(box, model.slice_z)
    parts = vs.make_parts(loops)
    sq = [[0, 0], [10, 0], [10, 10], [0, 10]]
    return {
        "Mesh": box,
        "Mesh.from_arrays": vs.Mesh.from_arrays(box.vertices, box.faces),
        "SlicedModel": model,
        "SlicedModel()": square_model(),
        "SlicedModel.open": model.open,
        "LayerPaths": loops,
        "LayerPaths.open": loops.open,
        "LayerPaths()": vs.LayerPaths(sq, [0, 4], [0, 1]),
        "LayerPaths.paths()": loops.paths(),
        "LayerParts": parts,
        "LayerParts()": LayerParts(sq, [0, 4], [0, 1], [0, 1]),
        "Paths": vs.Paths(sq, [0, 4]),
        "Paths.from_rings": vs.Paths.from_rings([sq]),
        "simplify": vs.simplify(vs.Paths(sq, [0, 4])),
        "load_sliced": _saved_and_loaded(model),
    }


def _saved_and_loaded(model):
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        model.save(Path(d) / "m.npz")
        return vs.load_sliced(Path(d) / "m.npz")


def arrays_of(obj):
    for name in ("vertices", "faces", "coords", "ring_offsets", "part_offsets",
                 "layer_offsets", "slice_z", "print_z", "thickness", "open_coords",
                 "open_ring_offsets", "open_layer_offsets", "open_chains",
                 "stitched_gaps"):  # fmt: skip
        a = getattr(obj, name, None)
        if a is not None:
            yield name, a


@pytest.mark.parametrize("kind", sorted(containers()))
def test_container_arrays_cannot_be_made_writeable(kind):
    obj = containers()[kind]
    names = []
    for name, a in arrays_of(obj):
        names.append(name)
        assert_immutable(a)
        if a.shape[0]:
            assert_immutable(a[:1])  # views too
    assert names


def _other_results():
    """Arrays held by other results: mesh reports, stitching, Cura stages."""
    from vecslice.cura_pipeline import cura_stages

    box = vs.load_mesh(trimesh.creation.box((10, 10, 2)))
    model = vs.slice_mesh(box)
    loops, gaps = vs.stitch(vs.slice_contours(box, model.slice_z))
    raw = cura_stages(box, vs.SliceSettings())["raw"]
    return {
        "MeshReport.bounds": vs.check_mesh(box).bounds,
        "Stitched.gaps_stitched": gaps,
        "Mesh twins cache": box._half_edge_twins(),
        "Mesh int32 faces cache": box._narrow_faces(),
        "CuraLayers.explicit": raw.explicit,
        "CuraLayers.stats": raw.stats,
    }


@pytest.mark.parametrize("kind", sorted(_other_results()))
def test_other_result_arrays_cannot_be_made_writeable(kind):
    a = _other_results()[kind]
    assert_immutable(a)
    assert_immutable(a[:1])


def test_mesh_faces_cannot_be_made_writeable_and_corrupted():
    """Issue 8 A6: flipping the flag and writing a bad index crashed a kernel."""
    mesh = vs.load_mesh(trimesh.creation.box((10, 10, 2)))
    with pytest.raises(ValueError):
        mesh.faces.flags.writeable = True
    with pytest.raises((ValueError, AttributeError)):  # the base has no flags
        mesh.faces.base.flags.writeable = True
    with pytest.raises(ValueError, match="read-only"):
        mesh.faces[0, 0] = 10**9
    assert vs.slice_mesh(mesh).n_layers == 18


def test_caller_arrays_are_copied_and_frozen_arrays_shared():
    c = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], np.int64)
    o = np.array([0, 4], np.int64)
    p = vs.Paths(c, o)
    c[0, 0] = 5
    o.flags.writeable = False  # read-only but owning: still the caller's array
    p2 = vs.Paths(p.coords, o)
    assert p.coords[0, 0] == 0
    assert p2.coords is p.coords  # immutable: shared without a copy
    assert not np.shares_memory(p2.ring_offsets, o)
    view = np.arange(8, dtype=np.int64).reshape(4, 2)[:, :]
    p3 = vs.Paths(view, [0, 4])
    assert not np.shares_memory(p3.coords, view)


def test_freeze_keeps_memory_and_data_alive_without_a_copy():
    a = np.arange(10, dtype=np.int64).reshape(5, 2)
    f = freeze(a)
    assert np.shares_memory(f, a) and is_frozen(f) and not is_frozen(a[:1])
    assert freeze(f) is f
    del a
    assert f.sum() == 45
    assert_immutable(f)
    e = freeze(np.empty((0, 2), np.int64))
    assert e.shape == (0, 2) and is_frozen(e)


def test_adopt_copies_only_what_the_caller_can_write():
    fresh = np.arange(4)
    assert np.shares_memory(adopt(fresh, [0, 1, 2, 3]), fresh)
    assert not np.shares_memory(adopt(fresh, fresh), fresh)
    frozen = freeze(np.arange(4))
    assert adopt(frozen, frozen) is frozen


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-(2**62), 2**62), min_size=1, max_size=40),
       st.integers(1, 7), st.sampled_from(["writable", "frozen", "list", "uint32"]))
def test_private_int_extremes_are_those_of_the_private_array(values, chunk, given):
    a = np.array(values, dtype=np.int64)
    if given == "uint32":
        a = np.abs(a) % 2**32
        arg = a.astype(np.uint32)
    else:
        arg = {"writable": a, "frozen": freeze(a.copy()), "list": values}[given]
    with pytest.MonkeyPatch.context() as mp:
        # chunks of a few values: many chunks, on threads
        mp.setattr(ragged, "_EXTREMES_CHUNK", chunk)
        kept, lo, hi = private_int_extremes(arg, "x", ndim=1)
    assert (lo, hi) == (int(a.min()), int(a.max()))
    assert kept.tolist() == a.tolist() and is_frozen(kept)
    if isinstance(arg, np.ndarray):
        assert (kept is arg) == (given == "frozen")
        assert given == "frozen" or not np.shares_memory(kept, arg)


def test_private_int_extremes_of_an_empty_array():
    kept, lo, hi = private_int_extremes(np.empty((0, 3), np.int64), "v", ndim=2,
                                        width=3)
    assert kept.shape == (0, 3) and (lo, hi) == (0, 0)


def test_extremes_are_checked_on_the_copy_not_the_callers_array(monkeypatch):
    """The range is that of the values copied: a write to the caller's array
    after a chunk was copied changes neither the copy nor the extremes."""
    monkeypatch.setattr(ragged, "_EXTREMES_CHUNK", 2)
    a = np.arange(6, dtype=np.int64)
    real = np.copyto

    def copy_then_write(dst, src, **kw):
        real(dst, src, **kw)
        a[:] = 2**40  # the caller writes everything, chunk by chunk too late

    monkeypatch.setattr(ragged.np, "copyto", copy_then_write)
    kept, lo, hi = private_int_extremes(a, "x", ndim=1)
    assert (lo, hi) == (int(kept.min()), int(kept.max()))
    assert lo < 2**40 == hi  # copied partly before, partly after the writes


@pytest.mark.parametrize("kind", ["SlicedModel", "LayerPaths", "Paths", "LayerParts"])
def test_pickle_and_deepcopy_keep_arrays_immutable(kind):
    obj = containers()[kind]
    for clone in (pickle.loads(pickle.dumps(obj)), copy.deepcopy(obj),
                  copy.copy(obj)):
        assert type(clone) is type(obj)
        for name, a in arrays_of(clone):
            assert_immutable(a)
            assert np.array_equal(a, getattr(obj, name))
        if isinstance(obj, vs.LayerPaths):
            assert clone.open.n_rings == obj.open.n_rings


def test_frozen_views_stored_by_a_container_are_made_contiguous():
    model = square_model()
    strided = model.coords[::2]
    assert is_frozen(strided) and not strided.flags.c_contiguous
    f = freeze(strided)
    assert f.flags.c_contiguous and is_frozen(f) and f.tolist() == strided.tolist()
