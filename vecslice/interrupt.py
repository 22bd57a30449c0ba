"""Ctrl-C that works while a kernel runs: the call runs in a worker thread.

Python handles a signal only in the main thread, between bytecodes; a numba kernel
(or a numba compilation) that runs for 30 s in the main thread therefore holds
Ctrl-C back for 30 s. :func:`run_interruptible` runs the call in a worker thread and
lets the main thread wait in short, interruptible steps: ``KeyboardInterrupt``
reaches the caller at once. The kernels release the GIL (``nogil``), so the worker
costs nothing while it computes.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["run_interruptible"]

T = TypeVar("T")

_POLL_S = 0.05


def run_interruptible(fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> T:
    """Call ``fn(*args, **kwargs)`` so that Ctrl-C interrupts it within ~0.1 s.

    Use it around long calls in a notebook or a script, e.g.
    ``vs.run_interruptible(vs.slice_mesh, mesh, settings)``.

    Parameters
    ----------
    fn : callable
        The function to call.
    *args, **kwargs
        Its arguments.

    Returns
    -------
    object
        What ``fn`` returns. Exceptions ``fn`` raises are re-raised unchanged.

    Raises
    ------
    KeyboardInterrupt
        On Ctrl-C (the kernel's interrupt button in Jupyter), within about 0.1 s.

    Notes
    -----
    A numba kernel cannot be stopped half-way. On Ctrl-C the abandoned call goes on
    in its (daemon) thread until it returns, using CPU meanwhile, and its result is
    dropped; a command-line program should exit at once instead (``vecslice`` does,
    with status 130). Without this helper, Ctrl-C during a long kernel takes effect
    only when the kernel returns, and during a first-run compilation it can surface
    as a ``SystemError`` from inside numba.

    Examples
    --------
    >>> run_interruptible(sum, [1, 2, 3])
    6
    """
    box: dict[str, Any] = {}
    done = threading.Event()

    def work() -> None:
        try:
            box["value"] = fn(*args, **kwargs)
        except BaseException as exc:  # re-raised in the caller's thread
            box["error"] = exc
        finally:
            done.set()

    worker = threading.Thread(target=work, name="vecslice-worker", daemon=True)
    worker.start()
    while not done.wait(_POLL_S):
        pass
    if "error" in box:
        raise box["error"]
    return box["value"]
