import numpy as np
import pytest
import trimesh
from hypothesis import given
from hypothesis import strategies as st

from strategies import run_reversed
from vecslice._kernels.topology import (
    edge_face_counts,
    edge_topology,
    half_edge_twins,
)


def _reference(faces):
    ids, verts, out = {}, [], []
    order = sorted(
        (min(f[j], f[(j + 1) % 3]), i, j, max(f[j], f[(j + 1) % 3]))
        for i, f in enumerate(faces.tolist()) for j in range(3)
    )
    for lo, i, j, hi in order:
        if (lo, hi) not in ids:
            ids[(lo, hi)] = len(verts)
            verts.append((lo, hi))
        out.append(((i, j), ids[(lo, hi)]))
    fe = np.zeros(faces.shape, dtype=np.int64)
    for (i, j), e in out:
        fe[i, j] = e
    return fe, np.array(verts, dtype=np.int64).reshape(-1, 2)


@given(st.lists(st.tuples(*[st.integers(0, 40)] * 3), min_size=1, max_size=80))
def test_edge_topology_matches_reference(tris):
    faces = np.array([t for t in tris if len(set(t)) == 3] or [(0, 1, 2)], np.int64)
    fe, ev, twin = edge_topology(faces, 41)
    ref_fe, ref_ev = _reference(faces)
    assert fe.tolist() == ref_fe.tolist()
    assert ev.tolist() == ref_ev.tolist()
    check_twins(faces, fe, twin)


def check_twins(faces, fe, twin):
    flat = fe.reshape(-1)
    for h in range(len(flat)):
        same = [g for g in range(len(flat)) if flat[g] == flat[h]]
        start = lambda g: faces[g // 3, g % 3]
        if len(same) == 2 and start(same[0]) != start(same[1]):
            assert twin[h] == (same[1] if h == same[0] else same[0])
        else:
            assert twin[h] == -1


def test_large_fan_uses_sorted_buckets():
    # a vertex shared by 2000 faces exercises the sorted-bucket path
    n = 2000
    faces = np.array([[0, i, i + 1] for i in range(1, n + 1)], dtype=np.int64)
    fe, ev, _ = edge_topology(faces, n + 2)
    ref_fe, ref_ev = _reference(faces)
    assert fe.tolist() == ref_fe.tolist() and ev.tolist() == ref_ev.tolist()


@pytest.mark.parametrize("mesh", [trimesh.creation.box(), trimesh.creation.icosphere()])
def test_closed_mesh_edges_have_two_faces(mesh):
    faces = np.asarray(mesh.faces, dtype=np.int64)
    fe, ev, twin = edge_topology(faces, len(mesh.vertices))
    counts = edge_face_counts(fe, len(ev))
    assert (counts == 2).all()
    assert (twin >= 0).all() and (twin[twin] == np.arange(len(twin))).all()
    assert len(ev) == len(mesh.edges_unique)  # Euler: E = 3F/2


@given(st.lists(st.tuples(*[st.integers(0, 12)] * 3), min_size=1, max_size=80))
def test_half_edge_twins_equal_edge_topology_twins(tris):
    # few vertices: many shared, non-manifold and inconsistently wound edges
    faces = np.array([t for t in tris if len(set(t)) == 3] or [(0, 1, 2)], np.int64)
    _, _, twin = edge_topology(faces, 13)
    assert half_edge_twins(faces, 13).tolist() == twin.tolist()


def test_half_edge_twins_on_large_fans():
    # 2000 faces around vertex 0, plus every edge doubled (non-manifold) on one side
    n = 2000
    fan = [[0, i, i + 1] for i in range(1, n + 1)]
    back = [[0, i + 1, i] for i in range(1, n + 1, 2)]
    faces = np.array(fan + back + back[:7], dtype=np.int64)
    _, _, twin = edge_topology(faces, n + 2)
    assert half_edge_twins(faces, n + 2).tolist() == twin.tolist()


@pytest.mark.parametrize("run", ["reversed", "threads"])
def test_half_edge_twins_in_chunks_equal_serial_and_edge_topology(run):
    # enough vertices for several chunks of bucket matching; random triangles over
    # few distinct vertex pairs give shared, non-manifold and flipped edges, and a
    # fan around vertex 5 gives a bucket that is sorted
    from vecslice._threads import run_chunks

    rng = np.random.default_rng(7)
    n = 150_000
    tris = rng.integers(0, n, size=(60_000, 3))
    near = np.sort(rng.integers(0, n, size=(20_000, 1)) + rng.integers(
        0, 3, size=(20_000, 3)), axis=1) % n
    fan = np.array([[5, i, i + 1] for i in range(6, 200)])
    faces = np.concatenate([tris, near, near[::3, ::-1], fan]).astype(np.int64)
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                  & (faces[:, 0] != faces[:, 2])]
    runner = run_reversed if run == "reversed" else run_chunks
    got = half_edge_twins(faces, n, run=runner)
    assert got.tolist() == half_edge_twins(faces, n).tolist()
    assert got.tolist() == edge_topology(faces, n)[2].tolist()
    assert (got >= 0).sum() > 5_000  # the case has matched edges to check


@given(st.lists(st.integers(-(2**63), 2**63 - 1) | st.integers(-3, 3), max_size=120),
       st.data())
def test_heapsort_sorts_the_range_and_nothing_else(values, data):
    from vecslice._kernels.topology import _heapsort

    a = np.array(values, dtype=np.int64)
    lo = data.draw(st.integers(0, len(a)))
    hi = data.draw(st.integers(lo, len(a)))
    expect = a.copy()
    expect[lo:hi] = np.sort(expect[lo:hi])
    _heapsort(a, lo, hi)
    assert a.tolist() == expect.tolist()


def test_half_edge_twins_are_int32_on_both_paths(monkeypatch):
    # the packed path, and edge_topology's (taken from 2**30 vertices; the limit
    # lowered here) give the same int32 twins
    from vecslice._kernels import topology

    mesh = trimesh.creation.icosphere()
    faces = np.asarray(mesh.faces, dtype=np.int64)
    packed = half_edge_twins(faces, len(mesh.vertices))
    monkeypatch.setattr(topology, "_PACK_LIMIT", 4)
    unpacked = topology.half_edge_twins(faces, len(mesh.vertices))
    assert packed.dtype == unpacked.dtype == np.int32
    assert packed.tolist() == unpacked.tolist() == edge_topology(
        faces, len(mesh.vertices))[2].tolist()
