"""The decorator every kernel uses: cached, nogil, no fastmath, one declared signature.

A kernel declares its signature (types from :mod:`._types`) but is compiled only
when it is first called — from Python or from another kernel — and then for exactly
that signature, loaded from numba's on-disk cache when a previous run left it there.
Importing a kernel module therefore costs nothing, and a run compiles only the
kernels it uses. After the first call a kernel behaves as an eagerly compiled one:
no further specialisations, and arguments that do not fit the signature raise
numba's ``TypeError``.
"""

import threading
import time

import numpy as np
from numba import njit

from . import _cachestamp

__all__ = [
    "CACHED", "compile_listeners", "cost_chunks", "even_chunks", "kernel", "run_serial",
]

CACHED = _cachestamp.check()  # before any kernel is loaded from numba's cache
"""Whether kernels are cached on disk (False: numba has no writable cache directory)."""

_lock = threading.RLock()

compile_listeners = []
"""Callables ``f(event, name, seconds)`` told when a kernel is first made ready.

``event`` is ``"start"`` (seconds 0.0) or ``"end"`` (seconds spent compiling or
loading it from the cache). Used by the command line to say that a first run is
compiling; nothing in the kernels depends on it.
"""


def _notify(event, name, seconds):
    for listener in list(compile_listeners):
        listener(event, name, seconds)


def kernel(signature=None, **options):
    """Decorate a kernel: ``njit(cache=True, nogil=True, **options)``, compiled lazily.

    ``cache=False`` where numba has no writable cache directory (:data:`CACHED`).

    Parameters
    ----------
    signature : numba signature, optional
        The one signature the kernel is compiled for. Only helpers inlined into
        their callers (``inline="always"``) may omit it.
    **options
        Further numba options (``inline``, ``_nrt``). ``fastmath`` is refused:
        results must be exact. No kernel is a parfor (``parallel=True``): the
        parallelism comes from chunks (see :func:`run_serial`), and
        ``tests/test_conventions.py`` checks it. ``_nrt=False`` compiles a kernel
        that allocates nothing without reference counting; every other kernel sets
        ``_nrt=True`` explicitly, because numba lets a kernel first compiled
        while typing a caller inherit the caller's ``_nrt`` when it sets none (so
        whether an allocating kernel compiled would depend on which caller was
        compiled first).
    """
    if options.get("fastmath"):
        raise ValueError("kernels must not use fastmath")
    options.setdefault("_nrt", True)

    def decorate(fn):
        disp = njit(cache=CACHED, nogil=True, **options)(fn)
        if signature is None or not hasattr(disp, "get_call_template"):
            # inline helpers; or NUMBA_DISABLE_JIT=1, where njit returns the plain
            # Python function (coverage runs measure kernel bodies as Python lines)
            return disp
        disp.declared_signature = signature
        plain_call_template = disp.get_call_template

        def ready():
            with _lock:
                if disp._can_compile:
                    _notify("start", fn.__qualname__, 0.0)
                    t = time.perf_counter()
                    disp.compile(signature)
                    disp.disable_compile()
                    _notify("end", fn.__qualname__, time.perf_counter() - t)

        def compile_for_args(*args, **kws):
            # called by numba's dispatcher when no compiled version matches: make
            # the declared one, then let the dispatcher call (or reject) it
            ready()
            return disp

        def get_call_template(args, kws):
            # called when another kernel being compiled calls this one
            ready()
            return plain_call_template(args, kws)

        disp._compile_for_args = compile_for_args
        disp.get_call_template = get_call_template
        return disp

    return decorate


def run_serial(fn, bounds):
    """Call ``fn(lo, hi)`` for every chunk ``bounds[c]:bounds[c + 1]``, in order.

    The default ``run`` of the kernel drivers that split their work into chunks
    (a chunk is one call of a plain ``nogil`` kernel over a range of items); the
    library passes a thread pool instead (``vecslice._threads.run_chunks``, same
    call), which gives the parallelism of ``parallel=True`` without its compile
    time.
    """
    for c in range(len(bounds) - 1):
        fn(int(bounds[c]), int(bounds[c + 1]))


def even_chunks(n, size):
    """Chunk bounds for ``run`` over ``n`` items of about equal cost: ``size`` each.

    ``[0, size, 2 * size, ..., n]``; one chunk when ``n <= size``, none when
    ``n == 0``.
    """
    return np.append(np.arange(0, n, size, dtype=np.int64), np.int64(n))


def cost_chunks(offsets, cost):
    """Chunk bounds for ``run`` over items of unequal cost: about ``cost`` each.

    Item ``i`` costs ``1 + offsets[i + 1] - offsets[i]`` (``offsets``:
    non-decreasing, from 0: e.g. a ragged array's, where an empty element still
    costs a visit). Returns ascending item indices from 0 to ``len(offsets) - 1``,
    each chunk (but the last) ending at the first item boundary at or after the
    next multiple of ``cost``; no empty chunks, and none at all for no items.
    """
    n = offsets.shape[0] - 1
    if n <= 0:
        return np.zeros(1, dtype=np.int64)
    total = offsets + np.arange(n + 1, dtype=np.int64)
    cuts = np.searchsorted(total, np.arange(cost, total[-1], cost, dtype=np.int64))
    return np.unique(np.concatenate(([0], cuts, [n]))).astype(np.int64)
