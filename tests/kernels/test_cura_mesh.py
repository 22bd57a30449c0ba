"""CuraEngine's vertex melding and face adjacency (kernels/cura_mesh.py)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_cura as ref
from strategies import run_reversed
from vecslice._kernels._jit import run_serial
from vecslice._kernels.cura_mesh import (
    face_neighbours,
    group_cells,
    meld_corners,
    vertex_faces,
)

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


# ---------------------------------------------------------------------------
# group_cells: the corners by hash cell without a sort (audit D19: np.lexsort of
# 3 million corners took 2.6 s and held Ctrl-C back)
# ---------------------------------------------------------------------------


def _cells(c):
    a = np.asarray(c, dtype=np.int64) + 15
    return np.where(a < 0, -(-a // 30), a // 30)


def _check_groups(c, order, cell_offsets):
    """Every cell is one group, its corners in file order; the groups tile order."""
    q = _cells(c)
    assert sorted(order.tolist()) == list(range(len(c)))
    assert cell_offsets[0] == 0 and cell_offsets[-1] == len(c)
    assert (np.diff(cell_offsets) > 0).all()
    seen = set()
    for k in range(len(cell_offsets) - 1):
        g = order[cell_offsets[k]:cell_offsets[k + 1]]
        assert (np.diff(g) > 0).all()  # file order
        cells = {tuple(x) for x in q[g].tolist()}
        assert len(cells) == 1 and not cells & seen  # one cell, not seen before
        seen |= cells
    return seen


@given(st.lists(st.tuples(COORD, COORD, COORD), max_size=60))
def test_group_cells_groups_each_cell_once_in_file_order(corners):
    c = np.array(corners, dtype=np.int64).reshape(-1, 3)
    order, cell_offsets = group_cells(c, 30)
    cells = _check_groups(c, order, cell_offsets)
    assert cells == {tuple(x) for x in _cells(c).tolist()}


@pytest.mark.parametrize("run", ["serial", "reversed", "threads"])
def test_group_cells_in_many_partitions_and_chunks(monkeypatch, run):
    # small partitions and chunks: many of each, taken last to first or on
    # threads; the grouping is the same, and melding over it too
    import vecslice._kernels.cura_mesh as cura_mesh
    from vecslice._threads import run_chunks

    c = np.random.default_rng(5).integers(-600, 600, size=(20_000, 3))
    want = group_cells(c, 30)
    monkeypatch.setattr(cura_mesh, "_HASH_CHUNK", 997)
    monkeypatch.setattr(cura_mesh, "_PART_CHUNK", 301)
    runner = {"serial": run_serial, "reversed": run_reversed, "threads": run_chunks}
    got = group_cells(c, 30, runner[run])
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    _check_groups(c, *got)
    monkeypatch.setattr(cura_mesh, "_PART_SIZE", 7)  # 4096 partitions
    order, cells = group_cells(c, 30, runner[run])
    _check_groups(c, order, cells)
    rep = meld_corners(c, order, cells, 30)
    vertices, corner_vertex = _meld(c)
    created = rep == np.arange(len(c))
    assert np.array_equal(c[created], vertices)
    assert np.array_equal((np.cumsum(created) - 1)[rep], corner_vertex)
    assert len(vertices) < len(c) - 1000  # the case melds corners


def test_group_cells_of_nothing():
    order, cells = group_cells(np.empty((0, 3), dtype=np.int64), 30)
    assert order.tolist() == [] and cells.tolist() == [0]


def test_group_cells_works_in_short_chunks(monkeypatch):
    # Ctrl-C is seen between chunks: every call handles a bounded number of
    # corners (one chunk of corners, or partitions adding up to about one chunk
    # plus the last partition), never all of them at once
    import vecslice._kernels.cura_mesh as cura_mesh

    c = np.random.default_rng(8).integers(-3000, 3000, size=(40_000, 3))
    monkeypatch.setattr(cura_mesh, "_HASH_CHUNK", 4000)
    monkeypatch.setattr(cura_mesh, "_PART_CHUNK", 4000)
    calls = []

    def record(fn, bounds):
        calls.append(np.asarray(bounds).tolist())
        run_serial(fn, bounds)

    order, cells = group_cells(c, 30, record)
    _check_groups(c, order, cells)
    hash_pass, scatter_pass, group_pass = calls
    assert hash_pass == scatter_pass == list(range(0, 40_001, 4000))
    assert len(group_pass) > 10  # partitions of about 2048 corners, ~4000 a chunk
