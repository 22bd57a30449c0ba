import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import reference_mesh
from strategies import run_reversed
from vecslice._kernels.vertices import clean_mesh, merge_vertices

coord = st.integers(-(2**30) + 1, 2**30 - 1)


@st.composite
def meshes_with_duplicates(draw):
    """Few distinct positions (so many repeat), faces over all vertex records."""
    pool = draw(st.lists(st.tuples(coord, coord, coord), min_size=1, max_size=8))
    n = draw(st.integers(1, 40))
    pick = draw(st.lists(st.integers(0, len(pool) - 1), min_size=n, max_size=n))
    v = np.array([pool[i] for i in pick], dtype=np.int64).reshape(-1, 3)
    n_f = draw(st.integers(1, 30))
    f = draw(st.lists(st.tuples(*[st.integers(0, n - 1)] * 3), min_size=n_f,
                      max_size=n_f))
    return v, np.array(f, dtype=np.int64).reshape(-1, 3)


@given(meshes_with_duplicates(), st.booleans())
def test_clean_mesh_matches_the_sorting_merge(case, merge):
    v, f = case
    got = clean_mesh(v, f, merge)
    ref = reference_mesh.clean_arrays(v, f, merge=merge)
    assert got[0].tolist() == ref[0].tolist()
    assert got[1].tolist() == ref[1].tolist()
    assert list(got[2:]) == list(ref[2:])


@given(st.lists(st.tuples(*[st.integers(-3, 3)] * 3), min_size=1, max_size=200))
def test_merge_vertices_groups_equal_positions_in_first_occurrence_order(pts):
    v = np.array(pts, dtype=np.int64)
    group, first = merge_vertices(v)
    seen = {}
    for i, p in enumerate(pts):
        seen.setdefault(p, len(seen))
        assert group[i] == seen[p]
    assert first.tolist() == [pts.index(p) for p in seen]


def test_merge_survives_colliding_slots():
    # many positions, a table at its fullest (n a power of two): probing wraps
    rng = np.random.default_rng(1)
    v = rng.integers(-5, 5, size=(4096, 3)).astype(np.int64)
    group, first = merge_vertices(v)
    _, ref_first, ref_inv = np.unique(v, axis=0, return_index=True,
                                      return_inverse=True)
    assert sorted(first.tolist()) == sorted(ref_first.tolist())
    assert (first[group] == ref_first[ref_inv.reshape(-1)]).all()
    assert (v[first[group]] == v).all()


@pytest.mark.parametrize("run", ["reversed", "threads"])
@pytest.mark.parametrize("merge", [True, False])
def test_clean_mesh_in_chunks_matches_the_sorting_merge(run, merge):
    # enough vertices for several chunks of partitions, enough faces for several
    # chunks of faces; few distinct positions, so many merge and faces degenerate
    from vecslice._threads import run_chunks

    rng = np.random.default_rng(3)
    v = rng.integers(-20, 20, size=(300_000, 3)).astype(np.int64)
    f = rng.integers(0, 300_000, size=(200_000, 3)).astype(np.int64)
    f[::7, 1] = f[::7, 0]  # repeated indices
    runner = run_reversed if run == "reversed" else run_chunks
    got = clean_mesh(v, f, merge, run=runner)
    ref = reference_mesh.clean_arrays(v, f, merge=merge)
    assert got[0].tolist() == ref[0].tolist()
    assert got[1].tolist() == ref[1].tolist()
    assert list(got[2:]) == list(ref[2:])
    assert got[4] > 28_000 and (got[2] > 100_000) == merge


@pytest.mark.parametrize("merge", [True, False])
def test_clean_mesh_returns_a_clean_mesh_itself(merge):
    # nothing merged, dropped or unused: the arrays given come back, not copies
    # (no new arrays to allocate and fault in); any change gives new arrays
    v = np.array([[0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]], dtype=np.int64)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    got = clean_mesh(v, f, merge)
    assert got[0] is v and got[1] is f and list(got[2:]) == [0, 0, 0]
    v_dup = np.vstack([v, v[:1]])  # an unused vertex (a repeated one with merge)
    got = clean_mesh(v_dup, f, merge)
    assert got[0] is not v_dup and got[0].tolist() == v.tolist()
    assert got[1] is not f and got[1].tolist() == f.tolist()
    f_deg = np.vstack([f, [[0, 0, 1]]])  # a degenerate face
    got = clean_mesh(v, f_deg, merge)
    assert got[1].tolist() == f.tolist() and got[4] == 1


@given(st.lists(st.tuples(*[st.integers(-3, 3)] * 3), min_size=1, max_size=300),
       st.integers(1, 40), st.integers(1, 500))
def test_partition_in_chunks_is_a_stable_counting_sort(pts, chunk, limit):
    # chunks run last to first: each still writes after the chunks before it, so
    # every partition lists its vertices in index order, hashes beside them; the
    # count limit makes chunks fewer (and larger) than the chunk size asks
    from unittest import mock

    from vecslice._kernels import vertices
    from vecslice._kernels.sorting import mix_hash

    v = np.array(pts, dtype=np.int64)
    calls = []

    def run(fn, bounds):
        calls.append(len(bounds) - 1)
        run_reversed(fn, bounds)

    with (mock.patch.object(vertices, "_CHUNK_VERTICES", chunk),
          mock.patch.object(vertices, "_COUNTS_LIMIT", limit)):
        order, hashes, offsets, pbits = vertices._partition(v, run)
    assert calls[0] == max(1, min(-(-len(pts) // chunk), limit))
    h = np.array([mix_hash(*map(np.int64, p)) for p in pts], dtype=np.uint64)
    part = (h >> np.uint64(64 - pbits)).astype(np.int64) if pbits else np.zeros(
        len(pts), dtype=np.int64)
    assert order.tolist() == np.argsort(part, kind="stable").tolist()
    assert hashes.tolist() == h[order].tolist()
    assert offsets.tolist() == [0, *np.cumsum(np.bincount(part, minlength=2**pbits))]


def test_partition_of_many_vertices_uses_several_partitions():
    # 2**pbits partitions of about 2048 vertices: the top hash bits pick them
    from vecslice._kernels import vertices

    rng = np.random.default_rng(5)
    v = rng.integers(-1000, 1000, size=(20_000, 3)).astype(np.int64)
    order, hashes, offsets, pbits = vertices._partition(v, run_reversed)
    assert pbits == 4 and offsets.shape == (17,) and offsets[-1] == 20_000
    assert sorted(order.tolist()) == list(range(20_000))
    part = (hashes >> np.uint64(60)).astype(np.int64)
    assert (np.diff(part) >= 0).all()  # grouped by partition
    for p in range(16):
        seg = order[offsets[p]:offsets[p + 1]]
        assert (np.diff(seg) > 0).all() and (part[offsets[p]:offsets[p + 1]] == p).all()
