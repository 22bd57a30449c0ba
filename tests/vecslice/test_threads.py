import os
import threading

import numba
import numpy as np
import pytest

from vecslice._threads import chunk_bounds, run_chunks


def test_every_chunk_runs_once_with_its_bounds():
    seen = []
    lock = threading.Lock()

    def fn(lo, hi):
        with lock:
            seen.append((lo, hi))

    bounds = [0, 3, 3, 10, 11, 40]
    run_chunks(fn, bounds, threads=2)
    assert sorted(seen) == [(0, 3), (3, 3), (3, 10), (10, 11), (11, 40)]


@pytest.mark.parametrize("bounds", [[], [5]])
def test_no_chunks_no_calls(bounds):
    run_chunks(lambda lo, hi: pytest.fail("called"), bounds, threads=2)


def test_chunks_run_at_the_same_time():
    # each chunk waits for another one to arrive: only a second thread lets the
    # first chunk finish (a serial run would time out on the barrier)
    barrier = threading.Barrier(2, timeout=30)
    names = set()

    def fn(lo, hi):
        names.add(threading.current_thread().name)
        barrier.wait()

    run_chunks(fn, [0, 1, 2], threads=2)
    assert len(names) == 2


def test_one_thread_runs_in_the_calling_thread():
    names = []
    run_chunks(lambda lo, hi: names.append(threading.current_thread().name),
               [0, 1, 2, 3], threads=1)
    assert names == [threading.current_thread().name] * 3


def test_the_first_error_is_raised_and_no_new_chunk_starts():
    started = []

    def fn(lo, hi):
        started.append(lo)
        if lo == 0:
            raise ValueError("chunk 0 failed")

    with pytest.raises(ValueError, match="chunk 0 failed"):
        run_chunks(fn, list(range(200)), threads=2)
    assert len(started) < 199  # the hand-out stopped


def test_nested_calls_do_not_wait_for_a_busy_pool():
    # a chunk that itself runs chunks (the pool's helper is busy with the outer
    # call): the inner call does its chunks itself instead of waiting
    out = []
    lock = threading.Lock()

    def inner(lo, hi):
        with lock:
            out.append(lo)

    def outer(lo, hi):
        run_chunks(inner, [10 * lo, 10 * lo + 1, 10 * lo + 2], threads=2)

    t = threading.Thread(target=run_chunks, args=(outer, [0, 1, 2, 3]),
                         kwargs={"threads": 2}, daemon=True)
    t.start()
    t.join(60)
    assert not t.is_alive(), "nested run_chunks deadlocked"
    assert sorted(out) == [0, 1, 10, 11, 20, 21]


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




_CONCURRENT = r"""
import hashlib, threading
import numba, numpy as np
import vecslice as vs

ADAPTIVE = vs.SliceSettings(adaptive_layers=True)
CURA = vs.SliceSettings(compat="cura")


def digest(arrays):
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def model(m):
    return digest([m.slice_z, m.print_z, m.thickness, m.layer_offsets,
                   m.part_offsets, m.ring_offsets, m.coords])


def job(k, wait):
    # fresh meshes: nothing cached on them (the faces' slopes, the cura topology)
    mesh = lambda: vs.demo_mesh(segments=192 + 64 * k)
    out = []
    wait()
    out.append(digest(vs.adaptive_layer_heights(mesh(), ADAPTIVE)))
    wait()
    out.append(model(vs.slice_mesh(mesh(), ADAPTIVE)))
    wait()
    out.append(model(vs.slice_mesh(mesh(), CURA)))
    return out


serial = [job(k, lambda: None) for k in range(2)]
barrier = threading.Barrier(2, timeout=120)
for _ in range(ROUNDS):
    got = [None, None]

    def work(k):
        got[k] = job(k, barrier.wait)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    assert got == serial, (got, serial)
print("ok", numba.threading_layer(), numba.get_num_threads())
"""


@pytest.mark.skipif(numba.config.DISABLE_JIT,
                    reason="NUMBA_DISABLE_JIT=1: nothing compiled, too slow as Python")
def test_two_threads_slice_at_once_on_numbas_workqueue_layer(tmp_path):
    # numba's fallback threading layer (no OpenMP, no TBB) aborts the whole
    # process (SIGABRT) when two threads run parfors at once: adaptive schedules,
    # adaptive and cura slices from two threads, started together on fresh
    # meshes, must come out as one after another, and the process must live
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue")
    p = subprocess.run([sys.executable, "-c", _CONCURRENT.replace("ROUNDS", "3")],
                       cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    assert p.stdout.split()[:2] == ["ok", "workqueue"]
