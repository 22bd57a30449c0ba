import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import reference
from strategies import closed_meshes
from vecslice._kernels.crossings import crossing_points, face_segments
from vecslice._kernels.topology import edge_topology

coord = st.integers(-(2**30) + 1, 2**30 - 1)


def _prepare(v, f, z):
    z = np.sort(np.asarray(z, dtype=np.int64))
    fe, ev, twin = edge_topology(f, len(v))
    vl = np.searchsorted(z, v[:, 2], side="left").astype(np.int64)
    el = vl[ev]
    eo = np.concatenate([[0], np.cumsum(np.abs(el[:, 0] - el[:, 1]))]).astype(np.int64)
    fl = vl[f]
    fo = np.concatenate([[0], np.cumsum(fl.max(1) - fl.min(1))]).astype(np.int64)
    eb = eo[:-1] - el.min(axis=1)
    return z, fe, ev, twin, vl, eo, fo, eb


@given(st.lists(st.tuples(coord, coord, coord), min_size=2, max_size=2),
       st.lists(coord, min_size=1, max_size=6))
def test_crossing_points_match_exact_rounding(edge, planes):
    v = np.array(edge, dtype=np.int64)
    f = np.array([[0, 1, 0]], dtype=np.int64)[:, :2]
    z = np.sort(np.array(planes, dtype=np.int64))
    ev = np.array([[0, 1]], dtype=np.int64)
    del f
    vl = np.searchsorted(z, v[:, 2], side="left").astype(np.int64)
    eo = np.array([0, abs(vl[0] - vl[1])], dtype=np.int64)
    pts = crossing_points(v, ev, vl, eo, z)
    lo, hi = sorted((v[0], v[1]), key=lambda p: p[2])
    expect = [reference.crossing(lo.tolist(), hi.tolist(), int(zk))
              for zk in z if lo[2] <= zk < hi[2]]
    assert [tuple(p) for p in pts.tolist()] == expect


def test_rounding_is_half_away_from_zero():
    v = np.array([[0, 0, 0], [1, -1, 2], [3, -3, 2]], dtype=np.int64)
    ev = np.array([[0, 1], [0, 2]], dtype=np.int64)
    z = np.array([1], dtype=np.int64)
    vl = np.searchsorted(z, v[:, 2]).astype(np.int64)
    pts = crossing_points(v, ev, vl, np.array([0, 1, 2], np.int64), z)
    assert pts.tolist() == [[1, -1], [2, -2]]  # 0.5 -> 1, -0.5 -> -1, 1.5 -> 2


@given(closed_meshes(), st.integers(0, 2**32 - 1))
def test_face_successors_match_crossing_id_linking(case, seed):
    v, f, planes = case
    rng = np.random.default_rng(seed)
    # break the mesh: flip some faces, delete some, duplicate some
    f = f.copy()
    flip = rng.random(len(f)) < 0.1
    f[flip] = f[flip][:, ::-1]
    keep = rng.random(len(f)) > 0.1
    dup = rng.random(len(f)) < 0.05
    f = np.concatenate([f[keep], f[dup]])
    if len(f) == 0:
        return
    z, fe, ev, twin, vl, eo, fo, eb = _prepare(v, f, planes)
    sf, st_, _, nxt, has_prev = face_segments(f, fe, vl, eb, fo, twin)
    ref_nxt, ref_prev = reference.successors(sf, st_, int(eo[-1]))
    assert nxt.tolist() == ref_nxt
    assert has_prev.tolist() == ref_prev
