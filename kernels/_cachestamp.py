"""One stamp for numba's on-disk cache of all kernels, so that none goes stale.

numba checks a cached kernel against its own source file only. A kernel that
calls (and so compiles into itself) kernels of another module keeps its old
machine code when only that other module changes: a git pull, or an install that
rewrites some files, then runs stale code beside fresh code, and a stale cached
kernel was seen to change another kernel's results in the same process.

:func:`check` runs once, when the first kernel module is imported: it hashes the
sources of every kernel module (and the numba and Python versions) and, when the
hash differs from the one stored beside the cache, removes the cached kernels
(``*.nbi``, ``*.nbc``) there before any is loaded; they are compiled again.

Where numba finds no writable cache directory at all, :func:`check` says so
(a warning) and the kernels are compiled without a cache (see :mod:`._jit`).
"""

import hashlib
import os
import sys
import warnings
from pathlib import Path

STAMP = "vecslice-kernels.stamp"


def sources_digest(directory):
    """Hash of the kernel sources in ``directory`` and of the numba version."""
    import numba

    h = hashlib.sha256(f"{numba.__version__} {sys.version_info[:2]}".encode())
    for path in sorted(Path(directory).glob("*.py")):
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def sync(cache_dir, digest):
    """Empty ``cache_dir`` of cached kernels unless its stamp is ``digest``.

    Returns True when the stamp was (re)written. Never raises for the file
    system: a read-only cache is left as numba finds it.
    """
    cache_dir = Path(cache_dir)
    stamp = cache_dir / STAMP
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        for path in cache_dir.iterdir():
            if path.suffix in (".nbi", ".nbc"):
                path.unlink(missing_ok=True)
        tmp = cache_dir / f"{STAMP}.{os.getpid()}"
        tmp.write_text(digest)
        os.replace(tmp, stamp)
    except OSError:
        pass
    return True


def _probe():  # a cached function of this directory: where numba caches
    return 0


def check():
    """:func:`sync` for the cache numba uses for this directory's kernels.

    Returns whether numba can cache the kernels at all. It cannot when none of
    its cache directories is writable (``NUMBA_CACHE_DIR``, the ``__pycache__``
    beside the kernels, the user's cache directory: a read-only install run by
    a user whose home is not writable); ``cache=True`` then raises numba's
    "no locator available" error, so the kernels must be compiled without it,
    on every run. A warning says so, once.
    """
    from numba import config, njit

    if config.DISABLE_JIT:
        return True
    try:
        cache_dir = njit(cache=True)(_probe)._cache._cache_path
    except RuntimeError as exc:  # "cannot cache function ...: no locator available"
        warnings.warn(
            "vecslice: numba has no writable cache directory for its kernels "
            f"(NUMBA_CACHE_DIR, {Path(__file__).parent / '__pycache__'}, the "
            "user's cache directory), so they are compiled again on every run; "
            "set NUMBA_CACHE_DIR to a writable directory to keep them. (numba: "
            f"{exc})", RuntimeWarning, stacklevel=2)
        return False
    except AttributeError:  # another numba's internals: leave the cache alone
        return True
    try:
        os.makedirs(cache_dir, exist_ok=True)
    except OSError:
        return True
    sync(cache_dir, sources_digest(Path(__file__).parent))
    return True
