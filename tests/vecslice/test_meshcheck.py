"""meshcheck: face_volumes against exact integer determinants; MeshReport."""

import copy
import pickle

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import vecslice as vs
from vecslice.meshcheck import face_volumes


@settings(max_examples=60)
@given(st.integers(1, 40), st.integers(0, 2**32 - 1),
       st.sampled_from([10, 10**4, 2**29]))
def test_face_volumes_match_exact_determinants(n_faces, seed, span):
    rng = np.random.default_rng(seed)
    v = rng.integers(-span, span, (12, 3)).astype(np.int64)
    f = rng.integers(0, 12, (n_faces, 3)).astype(np.int64)
    got = face_volumes(v, f)
    c = [(int(v[:, j].min()) + int(v[:, j].max())) // 2 for j in range(3)]
    for i, (a, b, q) in enumerate(f.tolist()):
        pa, pb, pq = ([int(v[k, j]) - c[j] for j in range(3)] for k in (a, b, q))
        cross = (pb[1] * pq[2] - pb[2] * pq[1], pb[2] * pq[0] - pb[0] * pq[2],
                 pb[0] * pq[1] - pb[1] * pq[0])
        exact = sum(pa[j] * cross[j] for j in range(3))  # 6 x the volume, exact
        # float64 products and sums: a few roundings of terms at most this large
        size = sum(abs(pa[j]) * (abs(pb[(j + 1) % 3] * pq[(j + 2) % 3])
                                 + abs(pb[(j + 2) % 3] * pq[(j + 1) % 3]))
                   for j in range(3))
        assert abs(got[i] * 6 - exact) <= 1e-15 * 8 * size


def test_tetrahedron_faces_and_the_closed_sum():
    v = np.array([[0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6]], np.int64)
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]], np.int64)
    assert face_volumes(v, f).sum() == 36.0
    assert face_volumes(v, f[:, ::-1]).sum() == -36.0
    assert face_volumes(v, f[:0]).shape == (0,)


def test_mesh_report_copies_keep_bounds_read_only():
    """Audit s26 state D3: MeshReport.bounds was frozen only when the report was
    built; pickled and deep-copied reports had writeable bounds."""
    report = vs.load_mesh(trimesh.creation.box((10, 20, 30))).report()
    given = np.array([[0, 0, 0], [1, 1, 1]])
    direct = vs.MeshReport(1, 1, 3, 1, 3, 0, 0, 0, 0, 0.0, given)
    given[1, 1] = 7  # the caller's array: the report keeps its own copy
    assert direct.bounds.tolist() == [[0, 0, 0], [1, 1, 1]]
    for r in (report, direct):
        for clone in (pickle.loads(pickle.dumps(r)), copy.deepcopy(r), copy.copy(r)):
            assert clone.bounds.tolist() == r.bounds.tolist()
            assert clone.n_faces == r.n_faces and clone.load_info == r.load_info
            assert not clone.bounds.flags.writeable
            with pytest.raises(ValueError):
                clone.bounds.flags.writeable = True
