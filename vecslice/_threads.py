"""Chunks of work on threads: the parallelism of the kernels, without parfors.

A kernel compiled with ``parallel=True`` costs seconds to compile on a first run
(numba's parfor passes and gufunc lowering). The same parallelism comes from a plain
``nogil`` kernel that does one chunk of the work (a range ``lo:hi`` of rings,
planes, vertices...), called for every chunk from a few Python threads:
:func:`run_chunks`. The kernels release the GIL, so the threads run at the same
time; a chunk costs the thread pool a few microseconds. The number of threads is
numba's (``numba.get_num_threads()``), so ``NUMBA_NUM_THREADS`` and
``numba.set_num_threads`` apply here as well.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numpy.typing import NDArray

__all__ = ["chunk_bounds", "run_chunks"]

_MIN_CHUNK = 16_384  # vertices: smaller chunks are not worth a thread
_CHUNKS_PER_THREAD = 4  # some slack for chunks of unequal cost

_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_pool_lock = threading.Lock()


def _executor(size: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size < size:
            _pool = ThreadPoolExecutor(max_workers=size,
                                       thread_name_prefix="vecslice-chunks")
            _pool_size = size
        return _pool


def chunk_bounds(ring_offsets: NDArray[np.int64], threads: int | None = None,
                 min_chunk: int = _MIN_CHUNK) -> NDArray[np.int64]:
    """Ring indices that cut rings into chunks of about equal vertex counts.

    Returns ``bounds`` (ascending, from 0 to the ring count) for chunks
    ``bounds[c] .. bounds[c + 1] - 1``: one chunk for small inputs or one
    thread, else up to ``4 * threads`` (default: numba's) chunks of at least
    ``min_chunk`` vertices each.
    """
    if threads is None:
        import numba

        threads = numba.get_num_threads()
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


def run_chunks(fn: Callable[[int, int], object], bounds: Sequence[int],
               threads: int | None = None) -> None:
    """Call ``fn(lo, hi)`` for every chunk ``bounds[c]:bounds[c + 1]``, on threads.

    Up to ``threads`` threads (default numba's thread count) run the chunks. The
    calling thread works too, and the chunks are handed out in order, one at a
    time (the first free thread takes the next), so uneven chunks balance out.
    With one thread, or one chunk, everything runs in the calling thread. ``fn``
    must be safe to call from several threads at once (chunks write disjoint
    outputs). The caller waits only for chunks that a thread has taken, so a
    call made while the pool is busy (another call, or one nested in a chunk)
    never waits for a helper that has not started.

    Parameters
    ----------
    fn : callable
        ``fn(lo, hi)`` does one chunk; a numba kernel called in it releases the
        GIL.
    bounds : sequence of int
        Chunk boundaries, non-decreasing (an array or a list); ``len(bounds) - 1``
        chunks, none when it has fewer than two entries.
    threads : int, optional
        At most this many threads.

    Raises
    ------
    BaseException
        The first exception a chunk raised, after every started chunk has ended
        (chunks not yet started are skipped).

    Examples
    --------
    >>> done = []
    >>> run_chunks(lambda lo, hi: done.append((lo, hi)), [0, 2, 5], threads=1)
    >>> done
    [(0, 2), (2, 5)]
    """
    edges = [int(b) for b in bounds]
    chunks = list(itertools.pairwise(edges))
    if threads is None:
        import numba

        threads = numba.get_num_threads()
    workers = min(len(chunks), max(1, int(threads)))
    if workers <= 1:
        for lo, hi in chunks:
            fn(lo, hi)
        return
    errors: list[BaseException] = []
    cond = threading.Condition()
    taken = [0, 0]  # chunks handed out, chunks finished
    stop = [False]

    def work() -> None:
        while True:
            with cond:
                if stop[0] or errors or taken[0] >= len(chunks):
                    return
                lo, hi = chunks[taken[0]]
                taken[0] += 1
            try:
                fn(lo, hi)
            except BaseException as exc:  # re-raised in the caller's thread
                with cond:
                    errors.append(exc)
            finally:
                with cond:
                    taken[1] += 1
                    cond.notify_all()

    pool = _executor(workers - 1)
    for _ in range(workers - 1):
        # a helper that starts late finds no chunk left and returns at once
        pool.submit(work)
    try:
        work()
    except BaseException:
        stop[0] = True  # e.g. Ctrl-C in the calling thread: hand out no more
        raise
    with cond:
        while taken[1] < taken[0]:
            cond.wait()
    if errors:
        raise errors[0]
