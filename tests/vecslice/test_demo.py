import math

import numpy as np
import pytest

import vecslice as vs
from vecslice.demo import demo_mesh


def test_demo_mesh_is_two_clean_bodies():
    m = demo_mesh()
    assert isinstance(m, vs.Mesh)
    r = m.report()
    assert (r.n_faces, r.n_bodies) == (768, 2) and r.n_faces < 20_000
    assert r.is_watertight and r.boundary_edges == r.nonmanifold_edges == 0
    assert r.duplicate_faces == r.zero_area_faces == 0
    li = m.load_info
    assert li.vertices_merged == li.vertices_unused == li.faces_degenerate == 0
    assert m.bounds.tolist() == [[-15000, -10000, 0], [15000, 10000, 15000]]


def test_demo_mesh_is_outward_and_repair_changes_nothing():
    m = demo_mesh()
    r = m.repaired()
    assert r.load_info.faces_flipped == 0 and r.load_info.faces_duplicate == 0
    assert np.array_equal(r.faces, m.faces) and np.array_equal(r.vertices, m.vertices)
    # plate minus a 64-gon hole plus a 64-gon boss: polygon areas, not circles
    poly = 0.5 * 64 * math.sin(2 * math.pi / 64)
    want = 30 * 20 * 5 - poly * 3.5**2 * 5 + poly * 4**2 * 10
    assert m.volume * 1e-9 == pytest.approx(want, rel=1e-3)


def test_each_body_is_watertight_and_positive():
    m = demo_mesh()
    plate = vs.Mesh.from_arrays(m.vertices, m.faces[: 8 * 64])
    boss = vs.Mesh.from_arrays(m.vertices, m.faces[8 * 64:])
    for body in (plate, boss):
        assert body.is_watertight and body.n_bodies == 1 and body.volume > 0
    assert plate.zrange == (0, 5000) and boss.zrange == (5000, 15000)
    assert plate.volume + boss.volume == pytest.approx(m.volume)


@pytest.mark.parametrize("segments", [8, 12, 100])
def test_segments(segments):
    m = demo_mesh(segments=segments)
    assert m.n_faces == 12 * segments and m.is_watertight and m.n_bodies == 2


@pytest.mark.parametrize(("segments", "err", "match"), [
    (6, vs.SettingsError, r"`segments` must be >= 8; got 6"),
    (10, vs.InputValueError, r"`segments` must be a multiple of 4; got 10"),
    ("64", vs.InputTypeError, r"`segments` must be an integer"),
    (10**9, vs.SettingsError, r"`segments` must be <= 1048576; got 1000000000"),
])
def test_bad_segments(segments, err, match):
    with pytest.raises(err, match=match):
        demo_mesh(segments=segments)


def test_demo_mesh_is_deterministic():
    a, b = demo_mesh(), demo_mesh()
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
