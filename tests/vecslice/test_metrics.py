import numpy as np
import pytest
import trimesh

import vecslice as vs
from vecslice.metrics import model_loops, resolution_stats


@pytest.fixture(scope="module")
def cylinder():
    return vs.load_mesh(trimesh.creation.cylinder(radius=10, height=3, sections=720))


def test_coarser_resolution_fewer_vertices_more_error(cylinder):
    raw = None
    stats = []
    for res in (100, 500, 2000):
        model = vs.slice_mesh(cylinder, vs.SliceSettings(max_resolution=res,
                                                          max_deviation=50))
        raw = raw or vs.slice_contours(cylinder, model.slice_z)
        stats.append(resolution_stats(model, raw, speed_mm_s=60))
    verts = [s.vertices for s in stats]
    err = [s.relative_error for s in stats]
    assert verts[0] >= verts[1] >= verts[2]
    assert err[0] <= err[1] <= err[2]
    for s in stats:  # moves/s = speed / mean edge
        assert s.moves_per_s == pytest.approx(60_000 / s.mean_edge_um)
        assert s.mean_edge_um == pytest.approx(s.perimeter_um / s.vertices)


def test_model_loops_and_identity(cylinder):
    model = vs.slice_mesh(cylinder)
    loops = model_loops(model)
    assert loops.n_layers == model.n_layers
    assert np.allclose(loops.layer_area2() / 2, model.layer_areas())
    assert resolution_stats(model, model).error_um2 == 0.0


def test_bad_arguments(cylinder):
    model = vs.slice_mesh(cylinder)
    with pytest.raises(vs.SettingsError, match="`speed_mm_s` must be >= 1"):
        resolution_stats(model, model, speed_mm_s=0)
    with pytest.raises(vs.InputTypeError, match="`reference` must be"):
        resolution_stats(model, [1, 2])
    with pytest.raises(vs.InputTypeError, match="`model` must be"):
        model_loops("model")
