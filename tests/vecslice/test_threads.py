import threading

import numpy as np
import pytest

from vecslice._threads import chunk_bounds, run_chunks


def _offsets(lengths):
    return np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)


def test_one_chunk_for_one_thread_or_small_inputs():
    offs = _offsets([100_000] * 10)
    assert chunk_bounds(offs, threads=1).tolist() == [0, 10]
    assert chunk_bounds(_offsets([10] * 10), threads=2).tolist() == [0, 10]
    assert chunk_bounds(_offsets([]), threads=2).tolist() == [0, 0]


def test_chunks_cover_all_rings_with_about_equal_vertex_counts():
    rng = np.random.default_rng(3)
    lengths = rng.integers(0, 200, 5000)
    offs = _offsets(lengths)
    b = chunk_bounds(offs, threads=2, min_chunk=100)
    assert b[0] == 0 and b[-1] == len(lengths)
    assert (np.diff(b) > 0).all()
    assert len(b) - 1 == 8  # 4 chunks per thread
    per_chunk = np.diff(offs[b])
    assert per_chunk.max() - per_chunk.min() <= 2 * 200


def test_every_chunk_runs_exactly_once_on_several_threads():
    bounds = np.arange(0, 101, 5, dtype=np.int64)
    seen, names = [], set()

    def fn(r0, r1):
        seen.append((r0, r1))
        names.add(threading.current_thread().name)

    run_chunks(fn, bounds, threads=2)
    assert sorted(seen) == [(r, r + 5) for r in range(0, 100, 5)]
    run_chunks(fn, bounds, threads=1)
    assert len(seen) == 40


def test_an_error_in_a_chunk_is_raised_and_stops_the_rest():
    bounds = np.arange(0, 1001, dtype=np.int64)
    done = []

    def fn(r0, r1):
        if r0 == 3:
            raise ValueError("chunk 3")
        done.append(r0)

    with pytest.raises(ValueError, match="chunk 3"):
        run_chunks(fn, bounds, threads=2)
    assert len(done) < 999


def test_nested_calls_from_a_pool_thread_do_not_wait_for_themselves():
    # run_chunks inside a chunk: the pool's workers may all be busy (here with
    # the outer call); queued workers that never started are not waited for
    bounds = np.arange(0, 9, dtype=np.int64)
    inner = []

    def outer(r0, r1):
        run_chunks(lambda a, b: inner.append(a), bounds, threads=2)

    run_chunks(outer, np.arange(0, 4, dtype=np.int64), threads=2)
    assert len(inner) == 3 * 8
