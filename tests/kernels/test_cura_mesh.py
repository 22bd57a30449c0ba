"""CuraEngine's vertex melding and face adjacency (kernels/cura_mesh.py)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_cura as ref
from strategies import run_reversed
from vecslice._kernels.cura_mesh import face_neighbours, meld_corners, vertex_faces

# values around CuraEngine's hash cell boundaries: q = trunc((c + 15) / 30)
# changes between 14 and 15, 44 and 45, -46 and -45 (the cell at 0 is 59 wide)
NEAR = st.sampled_from([-76, -75, -46, -45, -44, -16, -15, 0, 1, 14, 15, 16, 29,
                        30, 31, 44, 45, 46, 74, 75, 104, 105])
COORD = st.one_of(NEAR, st.integers(-120, 120), st.integers(-(2**29), 2**29))


def _meld(corners):
    c = np.array(corners, dtype=np.int64).reshape(-1, 3)
    a = c + 15
    q = np.where(a < 0, -(-a // 30), a // 30)
    order = np.lexsort((q[:, 2], q[:, 1], q[:, 0])).astype(np.int64)
    qs = q[order]
    new = np.ones(len(c), dtype=bool)
    new[1:] = (qs[1:] != qs[:-1]).any(axis=1)
    cells = np.append(np.flatnonzero(new), len(c)).astype(np.int64)
    rep = meld_corners(c, order, cells, 30)
    created = rep == np.arange(len(c))
    ids = np.cumsum(created) - 1
    return c[created], ids[rep]


@given(st.lists(st.tuples(COORD, COORD, COORD), min_size=3, max_size=60))
def test_meld_matches_hash_buckets(corners):
    corners = corners[: len(corners) - len(corners) % 3]
    vertices, corner_vertex = _meld(corners)
    want_v, want_f = ref.meld(corners)
    assert [tuple(v) for v in vertices.tolist()] == want_v
    f = corner_vertex.reshape(-1, 3)
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    assert [tuple(x) for x in f[keep].tolist()] == want_f


def test_meld_across_a_cell_boundary():
    # 14 and 15 are 1 µm apart but in different hash cells: not melded;
    # 15 and 44 are 29 µm apart in one cell: melded (first one kept)
    corners = [[14, 0, 0], [15, 0, 0], [44, 0, 0], [15, 30, 0]]
    vertices, corner_vertex = _meld(corners)
    assert vertices.tolist() == [[14, 0, 0], [15, 0, 0], [15, 30, 0]]
    assert corner_vertex.tolist() == [0, 1, 1, 2]


def test_meld_reach_is_euclidean_and_per_axis():
    # all in the cell around 0: d.d = 588 and 108 <= 900, melded into the first
    v, cv = _meld([[0, 0, 0], [14, 14, 14], [-6, -6, -6], [0, 0, 0]])
    assert cv.tolist() == [0, 0, 0, 0] and v.tolist() == [[0, 0, 0]]
    # 20 µm on every axis (<= 30) but d.d = 1200 > 900: not melded
    v, cv = _meld([[-10, -10, -10], [10, 10, 10]])
    assert cv.tolist() == [0, 1]


@st.composite
def soups(draw):
    """Small meshes with random topology: shared, open and non-manifold edges."""
    n = draw(st.integers(4, 8))
    verts = draw(st.lists(st.tuples(*[st.integers(-5000, 5000)] * 3),
                          min_size=n, max_size=n, unique=True))
    faces = draw(st.lists(
        st.lists(st.integers(0, n - 1), min_size=3, max_size=3, unique=True),
        min_size=1, max_size=16))
    return (np.array(verts, dtype=np.int64), np.array(faces, dtype=np.int64))


@given(soups())
def test_face_neighbours_match_reference(mesh):
    vertices, faces = mesh
    offsets, items = vertex_faces(faces, len(vertices))
    got = face_neighbours(vertices, faces, offsets, items)
    assert got.tolist() == ref.face_neighbours(vertices.tolist(), faces.tolist())


def test_vertex_faces_in_face_order():
    faces = np.array([[0, 1, 2], [2, 1, 3], [3, 1, 0]], dtype=np.int64)
    offsets, items = vertex_faces(faces, 5)
    assert offsets.tolist() == [0, 2, 5, 7, 9, 9]
    assert items.tolist() == [0, 2, 0, 1, 2, 0, 1, 1, 2]


def test_non_manifold_edge_picks_smallest_angle():
    # three faces on edge 0-1 (the x axis): face 0 in the xy plane (y > 0),
    # face 1 going up (+z), face 2 going down (-z); CuraEngine picks the next
    # face counter-clockwise seen from vertex 1 towards vertex 0
    v = np.array([[0, 0, 0], [1000, 0, 0], [500, 1000, 0], [500, 0, 1000],
                  [500, 0, -1000]], dtype=np.int64)
    f = np.array([[0, 1, 2], [1, 0, 3], [1, 0, 4]], dtype=np.int64)
    offsets, items = vertex_faces(f, 5)
    got = face_neighbours(v, f, offsets, items)
    assert got.tolist() == ref.face_neighbours(v.tolist(), f.tolist())
    # from face 0 (third vertex +y): the -z face is at pi/2, the +z face at 3pi/2
    assert got[0, 0] == 2
    # duplicate faces: angle 0 for both copies, the first in face order wins
    f2 = np.array([[0, 1, 2], [1, 0, 3], [1, 0, 3]], dtype=np.int64)
    o2, i2 = vertex_faces(f2, 5)
    assert face_neighbours(v, f2, o2, i2)[0, 0] == 1


def _random_soup(seed, n_vertices, n_faces, spread):
    """Random faces over few vertices: shared, open and non-manifold edges."""
    rng = np.random.default_rng(seed)
    v = rng.integers(-spread, spread, size=(n_vertices, 3)).astype(np.int64)
    f = rng.integers(0, n_vertices, size=(n_faces, 3)).astype(np.int64)
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return v, np.ascontiguousarray(f[keep])


@pytest.mark.parametrize("run", ["reversed", "threads"])
def test_face_neighbours_in_chunks_equal_one_chunk(monkeypatch, run):
    # small chunks of faces, last to first or on threads: each chunk writes its
    # own rows, so the result is the single chunk's
    import vecslice._kernels.cura_mesh as cura_mesh
    from vecslice._threads import run_chunks

    v, f = _random_soup(11, 300, 3000, 5000)
    offsets, items = vertex_faces(f, len(v))
    want = face_neighbours(v, f, offsets, items)
    monkeypatch.setattr(cura_mesh, "_FACE_CHUNK", 37)
    got = face_neighbours(v, f, offsets, items,
                          run_reversed if run == "reversed" else run_chunks)
    assert got.tolist() == want.tolist()
    assert (want >= 0).sum() > 1000  # the case has neighbours to check


@pytest.mark.parametrize("run", ["reversed", "threads"])
def test_meld_in_chunks_equals_one_chunk(monkeypatch, run):
    # corners in a small box: many cells holding several corners each, melded in
    # small chunks of cells, last to first or on threads
    import vecslice._kernels.cura_mesh as cura_mesh
    from vecslice._threads import run_chunks

    c = np.random.default_rng(3).integers(-150, 150, size=(6000, 3))
    a = c + 15
    q = np.where(a < 0, -(-a // 30), a // 30)
    order = np.lexsort((q[:, 2], q[:, 1], q[:, 0])).astype(np.int64)
    qs = q[order]
    new = np.ones(len(c), dtype=bool)
    new[1:] = (qs[1:] != qs[:-1]).any(axis=1)
    cells = np.append(np.flatnonzero(new), len(c)).astype(np.int64)
    want = meld_corners(c, order, cells, 30)
    monkeypatch.setattr(cura_mesh, "_MELD_CHUNK", 23)
    got = meld_corners(c, order, cells, 30,
                       run_reversed if run == "reversed" else run_chunks)
    assert got.tolist() == want.tolist()
    assert (want != np.arange(len(c))).sum() > 1000  # the case melds corners
