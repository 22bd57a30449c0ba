"""Ctrl-C that works while a kernel runs: the call runs in a worker thread.

Python handles a signal only in the main thread, between bytecodes; a numba kernel
(or a numba compilation) that runs for 30 s in the main thread therefore holds
Ctrl-C back for 30 s. :func:`run_interruptible` runs the call in a worker thread and
lets the main thread wait in short, interruptible steps: ``KeyboardInterrupt``
reaches the caller at once. The kernels release the GIL (``nogil``), so the worker
costs nothing while it computes.

Without the helper, a Ctrl-C that arrives while a kernel runs in the main thread
is handled when Python code next runs. That can be inside numba's dispatcher (it
calls a Python function when it converts some arguments or results), which then
reports a ``SystemError`` caused by the ``KeyboardInterrupt``.
:func:`keyboard_interrupts` decorates the public calls so that their callers see
the ``KeyboardInterrupt`` itself.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["keyboard_interrupts", "run_interruptible"]

T = TypeVar("T")
F = TypeVar("F", bound=Callable[..., Any])

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
    only when the kernel returns.

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


def _interrupted(exc: BaseException) -> bool:
    """Whether a ``KeyboardInterrupt`` is among the causes of ``exc``."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


def keyboard_interrupts(fn: F) -> F:
    """Decorate a public call so that Ctrl-C always reaches its caller as such.

    A ``SystemError`` that numba raised for a ``KeyboardInterrupt`` (see the
    module's docstring) is raised as ``KeyboardInterrupt``; other
    ``SystemError`` s pass unchanged.
    """

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except SystemError as exc:
            if not _interrupted(exc):
                raise
            raise KeyboardInterrupt from exc

    return call  # type: ignore[return-value]
