"""Chunks of work on threads: the parallelism of the kernels, without parfors.

A kernel compiled with ``parallel=True`` costs seconds to compile on a first run
(numba's parfor passes and gufunc lowering). The same parallelism comes from a plain
``nogil`` kernel that does one chunk of the work, called for every chunk from a few
Python threads: :func:`run_chunks`. The kernels release the GIL, so the threads
run at the same time; a chunk costs the thread pool a few microseconds.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

__all__ = ["run_chunks", "worker_count"]

T = TypeVar("T")

_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_pool_lock = threading.Lock()


def worker_count() -> int:
    """Threads that :func:`run_chunks` uses: numba's thread count (at least 1).

    ``NUMBA_NUM_THREADS`` and ``numba.set_num_threads`` limit it as they limit
    numba's own parallel kernels.
    """
    import numba

    return max(1, int(numba.get_num_threads()))


def _executor(size: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size < size:
            _pool = ThreadPoolExecutor(max_workers=size,
                                       thread_name_prefix="vecslice-chunks")
            _pool_size = size
        return _pool


def run_chunks(fn: Callable[[int], T], n_chunks: int) -> list[T]:
    """Call ``fn(c)`` for every chunk ``c``, on threads; return the results in order.

    Up to :func:`worker_count` threads run the chunks ``range(n_chunks)``.
    The calling thread works too, and the chunks are handed out one at a time
    (the first free thread takes the next), so uneven chunks balance out. With one
    worker, or one chunk, everything runs in the calling thread. ``fn`` must be
    safe to call from several threads at once (chunks write disjoint outputs).

    Parameters
    ----------
    fn : callable
        ``fn(c)`` does chunk ``c``; a numba kernel called in it releases the GIL.
    n_chunks : int
        Number of chunks (0 or more).

    Returns
    -------
    list
        ``[fn(0), fn(1), ...]``.

    Raises
    ------
    BaseException
        The first exception a chunk raised, after every started chunk has ended
        (chunks not yet started are skipped).

    Examples
    --------
    >>> run_chunks(lambda c: c * c, 4)
    [0, 1, 4, 9]
    """
    n_chunks = int(n_chunks)
    workers = min(n_chunks, worker_count())
    if workers <= 1:
        return [fn(c) for c in range(n_chunks)]
    results: list[T | None] = [None] * n_chunks
    errors: list[BaseException] = []
    cond = threading.Condition()
    taken = [0, 0]  # chunks handed out, chunks finished

    def work() -> None:
        while True:
            with cond:
                if errors or taken[0] >= n_chunks:
                    return
                c = taken[0]
                taken[0] += 1
            try:
                results[c] = fn(c)
            except BaseException as exc:  # re-raised in the caller's thread
                with cond:
                    errors.append(exc)
            finally:
                with cond:
                    taken[1] += 1
                    cond.notify_all()

    pool = _executor(workers - 1)
    for _ in range(workers - 1):
        # a helper that starts late (pool busy, or a nested call) finds no chunk
        # left and returns at once: the caller waits only for chunks handed out
        pool.submit(work)
    work()
    with cond:
        while taken[1] < taken[0]:
            cond.wait()
    if errors:
        raise errors[0]
    return results  # type: ignore[return-value]
