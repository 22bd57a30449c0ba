"""CuraEngine-exact simplification of rings and polylines, and ring clean-up.

:func:`simplify` is bit-for-bit CuraEngine's ``Simplify`` (``spec/SIMPLIFY.md``);
:func:`ring_perimeters` and :func:`remove_degenerate_vertices` are the
``polygonLength`` and ``removeDegenerateVerts`` steps the slicing pipeline uses
around it.
"""

from __future__ import annotations

from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._kernels.simplify import (
    remove_degenerate_vertices as _remove_degenerate_kernel,
)
from vecslice._kernels.simplify import ring_perimeters as _ring_perimeters_kernel
from vecslice._kernels.simplify import simplify_range
from vecslice._threads import chunk_bounds, run_chunks
from vecslice._validate import check_coord_range, check_int
from vecslice.errors import InputTypeError, InputValueError, LayoutError
from vecslice.interrupt import keyboard_interrupts
from vecslice.paths import Paths
from vecslice.ragged import RaggedContainer, private_int_array, value_extremes
from vecslice.units import COORD_LIMIT

__all__ = ["remove_degenerate_vertices", "ring_perimeters", "simplify"]

_THRESHOLD_MAX = 2**31 - 1  # squares must fit int64 (CuraEngine squares them)


def _trusted_paths(coords: NDArray[np.int64], offsets: NDArray[np.int64]) -> Paths:
    """Wrap kernel output (already valid) without re-validating or copying."""
    return Paths._trusted(coords, offsets)


def simplify_rings(
    coords: NDArray[np.int64],
    ring_offsets: NDArray[np.int64],
    closed: bool,
    max_resolution: int,
    max_deviation: int,
    max_area_deviation: int,
    widths: NDArray[np.int64] | None = None,
) -> tuple[NDArray[np.int64], NDArray[np.int64]] | tuple[
        NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Kernel ``simplify_rings`` (``simplify_rings_w`` given ``widths``) on threads.

    Same arguments (trusted: the caller validated them) and results, bit for
    bit: chunks of rings are simplified by :func:`simplify_range` on numba's
    thread count, each chunk writing back to back from its first input row,
    and the chunks are then moved together.
    """
    n_rings = ring_offsets.shape[0] - 1
    has_w = widths is not None
    wi = widths if widths is not None else np.empty(0, dtype=np.int64)
    buf = np.empty((coords.shape[0], 2), dtype=np.int64)
    buf_w = np.empty(coords.shape[0] if has_w else 0, dtype=np.int64)
    counts = np.empty(n_rings, dtype=np.int64)
    bounds = chunk_bounds(ring_offsets)
    run_chunks(lambda r0, r1: simplify_range(
        coords, wi, ring_offsets, has_w, bool(closed), max_resolution,
        max_deviation, max_area_deviation, r0, r1, buf, buf_w, counts), bounds)
    offsets = np.zeros(n_rings + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    out = np.empty((int(offsets[-1]), 2), dtype=np.int64)
    out_w = np.empty(out.shape[0] if has_w else 0, dtype=np.int64)

    def gather(r0: int, r1: int) -> None:
        dst0, dst1 = offsets[r0], offsets[r1]
        src0 = ring_offsets[r0]
        out[dst0:dst1] = buf[src0:src0 + dst1 - dst0]
        if has_w:
            out_w[dst0:dst1] = buf_w[src0:src0 + dst1 - dst0]

    run_chunks(gather, bounds)
    _check_moved_within_limit(out, max_deviation)
    return (out, out_w, offsets) if has_w else (out, offsets)


def _check_moved_within_limit(out: NDArray[np.int64], max_deviation: int) -> None:
    """Raise if the short-edge rule moved a vertex beyond the coordinate limit.

    The intersection that replaces a short edge lies within ``max_deviation`` of
    it, so input near the 2**30 µm limit with a large ``max_deviation`` can
    produce a vertex beyond it, which vecslice's arrays cannot hold (CuraEngine's
    result, which has no such limit, is not clamped to another one).
    """
    if out.size == 0:
        return
    lo, hi = value_extremes(out)
    if lo <= -COORD_LIMIT or hi >= COORD_LIMIT:
        far = hi if hi >= COORD_LIMIT else lo
        raise InputValueError(
            f"`max_deviation` ({max_deviation} µm) let the simplification move a "
            f"vertex to {far} µm, beyond the |value| < 2**30 µm limit; use a smaller "
            "max_deviation or keep the input further from the limit"
        )


def _drop_empty(offsets: NDArray[np.int64]) -> NDArray[np.int64]:
    """Offsets without the zero-length rings (their coords are already absent)."""
    lens = np.diff(offsets)
    kept = lens[lens > 0]
    out = np.zeros(kept.shape[0] + 1, dtype=np.int64)
    np.cumsum(kept, out=out[1:])
    return out


def _check_paths(paths: object) -> Paths:
    if not isinstance(paths, Paths):
        raise InputTypeError(
            f"`paths` must be a vecslice.Paths; got {type(paths).__name__}"
        )
    return paths


def _check_widths(widths: ArrayLike, n: int) -> NDArray[np.int64]:
    w = private_int_array(widths, "widths", ndim=1)  # checked after copying
    if w.shape[0] != n:
        raise LayoutError(
            f"`widths` must have one entry per vertex ({n}); got {w.shape[0]}"
        )
    bad = np.flatnonzero((w < 0) | (w >= COORD_LIMIT))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`widths` must satisfy 0 <= width < 2**30 µm; got {w[i]} at index {i}"
        )
    return w


@overload
def simplify(
    paths: Paths, *, max_resolution: int = ..., max_deviation: int = ...,
    max_area_deviation: int = ..., closed: bool = ..., widths: None = ...,
) -> Paths: ...
@overload
def simplify(
    paths: ArrayLike, *, max_resolution: int = ..., max_deviation: int = ...,
    max_area_deviation: int = ..., closed: bool = ..., widths: None = ...,
) -> NDArray[np.int64] | Paths: ...
@overload
def simplify(
    paths: Paths | ArrayLike, *, max_resolution: int = ..., max_deviation: int = ...,
    max_area_deviation: int = ..., closed: bool = ..., widths: ArrayLike,
) -> tuple[Paths | NDArray[np.int64], NDArray[np.int64]]: ...
@keyboard_interrupts
def simplify(
    paths: Paths | ArrayLike,
    *,
    max_resolution: int = 500,
    max_deviation: int = 25,
    max_area_deviation: int = 50000,
    closed: bool = True,
    widths: ArrayLike | None = None,
) -> Paths | NDArray[np.int64] | tuple[Paths | NDArray[np.int64], NDArray[np.int64]]:
    """Reduce the resolution of rings or polylines exactly as CuraEngine does.

    Parameters
    ----------
    paths : Paths or array_like of shape (n, 2), int
        Several rings/polylines, or one as an integer array (µm). Closed rings do
        not repeat their first vertex (an input that does loses the duplicate).
    max_resolution : int, default 500
        µm (``meshfix_maximum_resolution``): edges up to this long are candidates
        for removal.
    max_deviation : int, default 25
        µm (``meshfix_maximum_deviation``): how far the result may move from the
        input.
    max_area_deviation : int, default 50000
        µm² (``meshfix_maximum_extrusion_area_deviation``); only used with
        ``widths``.
    closed : bool, default True
        True for polygons; False for open polylines, whose end points never move.
    widths : array_like of shape (N,), int, optional
        Line width of every vertex in µm (variable-width extrusion lines).

    Returns
    -------
    Paths or ndarray of shape (m, 2), int64
        A Paths for a Paths input, without the rings that became empty; an
        (m, 2) array (possibly (0, 2)) for an array input. With ``widths``, a
        tuple ``(result, new_widths)``.

    Raises
    ------
    InputTypeError
        Float or non-numeric coordinates, or ``closed`` not a bool.
    InputValueError
        Wrong shapes, coordinates with |c| >= 2**30 µm, negative thresholds; or
        a result vertex beyond 2**30 µm (the short-edge rule moves a vertex up
        to ``max_deviation`` off its edge: input near the limit with a large
        ``max_deviation``).

    Notes
    -----
    Bit-for-bit CuraEngine 5.8 ``Simplify`` (``spec/SIMPLIFY.md``): vertices are
    removed in order of importance (squared distance to their neighbours' line;
    ties by index), passes repeat until one removes nothing, a short edge between
    two long ones is replaced by their float32 intersection when that lies within
    ``max_deviation``, and a result below 3 (polygon) or 2 (polyline) vertices, or
    of that size but with every side under 5 µm, is empty. The result never has
    more vertices than the input, and simplifying it again changes nothing.
    Where CuraEngine's int64 arithmetic overflows (parts about a kilometre
    across), it wraps here as there.

    Examples
    --------
    >>> import vecslice as vs
    >>> from vecslice.simplify import simplify  # also vs.simplify
    >>> square = [[0, 0], [500, 3], [1000, 0], [1000, 1000], [0, 1000]]
    >>> simplify(square).tolist()
    [[0, 0], [1000, 0], [1000, 1000], [0, 1000]]
    >>> line = simplify([[0, 0], [4, 0]], closed=False)
    >>> line.shape
    (0, 2)
    >>> p = vs.Paths([[0, 0], [10, 0], [0, 10], [0, 0], [2, 0], [0, 2]], [0, 3, 6])
    >>> out = simplify(p)
    >>> len(out), out.coords.tolist()
    (1, [[0, 0], [10, 0], [0, 10]])
    """
    res = check_int(max_resolution, "max_resolution", minimum=0,
                    maximum=_THRESHOLD_MAX)
    dev = check_int(max_deviation, "max_deviation", minimum=0, maximum=_THRESHOLD_MAX)
    area = check_int(max_area_deviation, "max_area_deviation", minimum=0,
                     maximum=2**63 - 1)
    if not isinstance(closed, (bool, np.bool_)):
        raise InputTypeError(f"`closed` must be a bool; got {closed!r}")
    if isinstance(paths, Paths):
        coords, offsets = paths.coords, paths.ring_offsets
    elif isinstance(paths, RaggedContainer):  # LayerPaths, SlicedModel
        raise InputTypeError(
            "`paths` must be a vecslice.Paths or an (n, 2) integer array; got "
            f"{type(paths).__name__} (the rings of a LayerPaths `loops`: "
            "`simplify(loops.paths())`; every layer of a slice, with a "
            "SliceSettings' thresholds: `vs.clean_loops(loops, settings)`)")
    else:
        # a private copy, checked after copying: the kernel reads what was checked
        coords = private_int_array(paths, "paths", ndim=2, width=2)
        check_coord_range(coords, "paths")
        offsets = np.array([0, coords.shape[0]], dtype=np.int64)
    if widths is None:
        c, o = simplify_rings(coords, offsets, bool(closed), res, dev, area)
        w = None
    else:
        wi = _check_widths(widths, coords.shape[0])
        c, w, o = simplify_rings(coords, offsets, bool(closed), res, dev, area,
                                 widths=wi)
    out: Paths | NDArray[np.int64]
    out = _trusted_paths(c, _drop_empty(o)) if isinstance(paths, Paths) else c
    return out if w is None else (out, w)


def ring_perimeters(paths: Paths) -> NDArray[np.int64]:
    """Perimeter of every closed ring in µm, as CuraEngine's ``polygonLength``.

    Parameters
    ----------
    paths : Paths
        ``R`` closed rings.

    Returns
    -------
    ndarray of shape (R,), int64
        Sum of the rounded lengths (``vsize``) of all edges, closing edge
        included; 0 for rings with fewer than 2 vertices.

    Examples
    --------
    >>> import vecslice as vs
    >>> from vecslice.simplify import ring_perimeters
    >>> ring_perimeters(vs.Paths([[0, 0], [3, 0], [3, 4]], [0, 3])).tolist()
    [12]
    """
    p = _check_paths(paths)
    return _ring_perimeters_kernel(p.coords, p.ring_offsets)


def remove_degenerate_vertices(paths: Paths) -> Paths:
    """Remove vertices where a closed ring exactly reverses direction.

    Parameters
    ----------
    paths : Paths
        Closed rings.

    Returns
    -------
    Paths
        The rings without degenerate vertices; a ring that changed and was left
        with 2 vertices or fewer is dropped, as are empty rings.

    Notes
    -----
    CuraEngine's ``removeDegenerateVerts`` for polygons: a vertex ``now`` between
    ``last`` and ``next`` is degenerate where ``dot(now - last, next - now) ==
    -vsize(now - last) * vsize(next - now)`` with rounded ``vsize``: the path turns
    back on itself, or an edge has length zero. It is one pass over the ring that
    keeps a stack of kept vertices and pops it while its top is degenerate
    towards the next vertex; the first kept vertex is not revisited at the end, so
    (like CuraEngine) the result is not always free of degenerate vertices there.
    An unchanged ring is kept even if it has fewer than 3 vertices.

    Examples
    --------
    >>> import vecslice as vs
    >>> from vecslice.simplify import remove_degenerate_vertices
    >>> spike = [[0, 0], [10, 0], [20, 0], [10, 0], [10, 10]]
    >>> remove_degenerate_vertices(vs.Paths(spike, [0, 5])).coords.tolist()
    [[0, 0], [10, 0], [10, 10]]
    """
    p = _check_paths(paths)
    c, o = _remove_degenerate_kernel(p.coords, p.ring_offsets)
    return _trusted_paths(c, _drop_empty(o))
