"""meshcheck.face_volumes against exact integer determinants."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

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
