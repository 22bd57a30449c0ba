"""Run a serial, GIL-releasing kernel over chunks of rings on a few Python threads.

A serial kernel compiles several times faster than the same loop under numba's
``parallel=True``; the kernels release the GIL, so a small thread pool gives the
same parallelism. The number of threads is numba's (``numba.get_num_threads()``),
so ``NUMBA_NUM_THREADS`` and ``numba.set_num_threads`` apply here as well.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["chunk_bounds", "run_chunks"]

_MIN_CHUNK = 16_384  # vertices: smaller chunks are not worth a thread
_CHUNKS_PER_THREAD = 4  # some slack for chunks of unequal cost

_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_pool_lock = threading.Lock()


def _executor(workers: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size < workers:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = ThreadPoolExecutor(workers, thread_name_prefix="vecslice")
            _pool_size = workers
        return _pool


def chunk_bounds(ring_offsets: NDArray[np.int64], threads: int | None = None,
                 min_chunk: int = _MIN_CHUNK) -> NDArray[np.int64]:
    """Ring indices that cut rings into chunks of about equal vertex counts.

    Returns ``bounds`` (ascending, from 0 to the ring count) for chunks
    ``bounds[c] .. bounds[c + 1] - 1``: one chunk for small inputs or one
    thread, else up to ``4 * threads`` (default: numba's) chunks of at least
    ``min_chunk`` vertices each.
    """
    threads = numba.get_num_threads() if threads is None else threads
    n_rings = ring_offsets.shape[0] - 1
    total = int(ring_offsets[-1]) if n_rings > 0 else 0
    n_chunks = min(n_rings, _CHUNKS_PER_THREAD * threads, total // min_chunk)
    if threads < 2 or n_chunks < 2:
        return np.array([0, n_rings], dtype=np.int64)
    targets = total * np.arange(n_chunks + 1, dtype=np.int64) // n_chunks
    bounds = np.minimum(np.searchsorted(ring_offsets, targets), n_rings)
    bounds[0] = 0
    bounds[-1] = n_rings
    return np.unique(bounds)


def run_chunks(fn: Callable[[int, int], None], bounds: NDArray[np.int64],
               threads: int | None = None) -> None:
    """Call ``fn(r0, r1)`` for every chunk of ``bounds`` on ``threads`` threads.

    ``threads`` defaults to numba's thread count.

    The calling thread takes part; chunks are handed out in order as threads
    become free. The first exception (also ``KeyboardInterrupt`` in the calling
    thread) stops the hand-out and is raised.
    """
    chunks = list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True))
    threads = min(numba.get_num_threads() if threads is None else threads,
                  len(chunks))
    if threads < 2:
        for r0, r1 in chunks:
            fn(r0, r1)
        return
    ticket = itertools.count()  # next() is atomic under the GIL
    stop = threading.Event()

    def work() -> None:
        while not stop.is_set():
            c = next(ticket)
            if c >= len(chunks):
                return
            try:
                fn(*chunks[c])
            except BaseException:
                stop.set()
                raise

    futures = [_executor(threads - 1).submit(work) for _ in range(threads - 1)]
    try:
        work()
        for f in futures:
            # a worker that has not started (the pool is busy, e.g. with the
            # caller itself) has nothing left to do: all chunks are handed out
            if not f.cancel():
                f.result()
    except BaseException:
        stop.set()
        raise
