"""Tests for vecslice.settings: SliceSettings validation."""

from __future__ import annotations

import numpy as np
import pytest

import vecslice as vs


@pytest.mark.parametrize("value", ["no", "False", 0, 1, None])
def test_bool_settings_refuse_truthiness(value):
    with pytest.raises(vs.InputTypeError,
                       match="`union_overlapping_volumes` must be True or False"):
        vs.SliceSettings(union_overlapping_volumes=value)


def test_numpy_bools_are_stored_as_bools():
    s = vs.SliceSettings(union_overlapping_volumes=np.False_)
    assert s.union_overlapping_volumes is False


def tall_tetra(height_um):
    """4 vertices, 1 cm wide, ``height_um`` tall, resting on z = 0."""
    v = [[0, 0, 0], [10_000, 0, 0], [0, 10_000, 0], [3000, 3000, height_um]]
    return vs.Mesh.from_arrays(v, [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])


def test_max_layers_default_and_validation():
    assert vs.SliceSettings().max_layers == 100_000 == vs.settings.MAX_LAYERS
    assert vs.SliceSettings(max_layers=np.int64(5)).max_layers == 5
    with pytest.raises(vs.SettingsError, match="`max_layers` must be >= 1; got 0"):
        vs.SliceSettings(max_layers=0)
    with pytest.raises(vs.InputTypeError, match="`max_layers` must be an integer"):
        vs.SliceSettings(max_layers=1.5)
    assert vs.SliceSettings().replace(max_layers=7).max_layers == 7


def _peak_traced(fn):
    import tracemalloc

    # a first call imports the modules on its way lazily (2.5 MB of code objects
    # when this test runs alone): not an allocation per layer, so not measured
    with pytest.raises(vs.SettingsError):
        fn()
    tracemalloc.start()
    try:
        with pytest.raises(vs.SettingsError) as info:
            fn()
        return tracemalloc.get_traced_memory()[1], str(info.value)
    finally:
        tracemalloc.stop()


def test_a_1_km_mesh_is_refused_before_any_allocation():
    """Issue 8 A5: a 4-vertex mesh 1 km tall went past 12 GB at 0.1 mm layers."""
    mesh = tall_tetra(10**9)  # 1 km, inside the coordinate range
    for fn in (lambda: vs.layer_heights(mesh), lambda: vs.slice_mesh(mesh)):
        peak, msg = _peak_traced(fn)
        assert peak < 1_000_000  # bytes: nothing per layer was allocated
        assert "must be <= `max_layers` (100000); got 9999998 layers" in msg
        assert "1000000000 µm tall at layer_height 100 µm" in msg
        assert "SliceSettings(max_layers=9999998)" in msg


def test_raising_the_limit_allows_more_layers():
    mesh = tall_tetra(6_000)  # 58 layers at 0.1 mm after a 0.3 mm first layer
    with pytest.raises(vs.SettingsError, match="got 58 layers") as info:
        vs.slice_mesh(mesh, vs.SliceSettings(max_layers=57))
    # the limit it suggests, for the command line's own hint
    assert info.value.layers_needed == 58
    model = vs.slice_mesh(mesh, vs.SliceSettings(max_layers=58))
    assert model.n_layers == 58


def test_slice_contours_has_its_own_limit():
    mesh = tall_tetra(6_000)
    z = np.arange(11, dtype=np.int64) * 500
    with pytest.raises(vs.SettingsError,
                       match=r"got 11 layers \(11 heights in `slice_z`\).*"
                       r"slice_contours\(\.\.\., max_layers=11\)"):
        vs.slice_contours(mesh, z, max_layers=10)
    assert vs.slice_contours(mesh, z, max_layers=11).n_layers == 11
    big = np.zeros(100_001, dtype=np.int64)
    with pytest.raises(vs.SettingsError, match="`max_layers` \\(100000\\)"):
        vs.slice_contours(mesh, big)
    with pytest.raises(vs.InputTypeError, match="`max_layers` must be an integer"):
        vs.slice_contours(mesh, z, max_layers="many")
