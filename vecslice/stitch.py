"""Stitching open chains into closed loops, following CuraEngine's rules."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from vecslice._kernels.stitch import stitch_chains
from vecslice._validate import check_int
from vecslice.errors import InputTypeError
from vecslice.interrupt import keyboard_interrupts
from vecslice.paths import LayerPaths
from vecslice.ragged import freeze, ragged_take

__all__ = ["Stitched", "stitch"]

# any gap >= 2**32 µm behaves alike (|coords| < 2**30); keeps the kernel's int64 exact
_GAP_CLAMP = 2**32


class Stitched(NamedTuple):
    """Result of :func:`stitch`: unpack as ``loops, gaps_stitched = stitch(...)``."""

    loops: LayerPaths
    """Closed loops per layer; ``.open`` holds the chains left open."""
    gaps_stitched: NDArray[np.int64]
    """Joins plus closures made in each layer, shape (L,)."""

    def __reduce__(self) -> tuple[Any, ...]:
        # a pickled or deep-copied result keeps its counts read-only, as the
        # containers keep their arrays (a plain tuple's copy would not)
        return _stitched, tuple(self)


def _stitched(loops: LayerPaths, gaps_stitched: NDArray[np.int64]) -> Stitched:
    """A :class:`Stitched` from unpickled fields, its counts frozen again."""
    return Stitched(loops, freeze(gaps_stitched))


def _check_loops(loops: object) -> LayerPaths:
    if not isinstance(loops, LayerPaths):
        raise InputTypeError(
            f"`loops` must be a vecslice.LayerPaths (see vecslice.slice_contours); "
            f"got {type(loops).__name__}"
        )
    return loops


def _merge_layers(a: LayerPaths, b: LayerPaths) -> LayerPaths:
    """Per layer, the rings of ``a`` followed by the rings of ``b``."""
    coords = np.concatenate([a.coords, b.coords])
    ring_offsets = np.concatenate(
        [a.ring_offsets[:-1], b.ring_offsets + a.coords.shape[0]]
    )
    key = np.concatenate([2 * a.ring_layer(), 2 * b.ring_layer() + 1])
    order = np.argsort(key, kind="stable").astype(np.int64)
    new_rings, items = ragged_take(ring_offsets, order)
    layer_offsets = a.layer_offsets + b.layer_offsets
    return LayerPaths._trusted(
        np.ascontiguousarray(coords[items]), new_rings, layer_offsets.copy()
    )


@keyboard_interrupts
def stitch(
    loops: LayerPaths, *, max_gap_in_order: int = 20, max_gap: int = 10_000
) -> Stitched:
    """Join the open chains of each layer into closed loops, CuraEngine's way.

    Parameters
    ----------
    loops : LayerPaths
        Closed loops per layer, with the open chains (polylines) in ``loops.open``,
        as :func:`vecslice.slice_contours` returns them. ``loops.open = None``
        means no open chains.
    max_gap_in_order : int, default 20
        Round 1: join a chain's last vertex to a chain's first vertex (its own
        included) when they are closer than this, in µm, ``>= 0``.
    max_gap : int, default 10000
        Round 2: join chain ends closer than this, in µm, ``>= 0``, reversing a
        chain where two last or two first vertices meet.

    Returns
    -------
    Stitched
        ``(loops, gaps_stitched)``. ``loops`` holds, per layer, the input's closed
        loops followed by the newly closed ones; its ``.open`` holds the chains
        left open (same layers). ``gaps_stitched`` (L,) int64 counts joins plus
        closures per layer.

    Raises
    ------
    InputTypeError
        If ``loops`` is not a LayerPaths or a gap is not an integer.
    SettingsError
        If a gap is negative.

    Notes
    -----
    Per layer, in each round, the candidate joins are taken smallest gap first
    (exact squared distances). Round 1 only joins last vertex to first vertex;
    round 2 also joins last to last or first to first by reversing the chain with
    fewer vertices (on a tie, the one with the higher id). Equal gaps break by:
    in order before reversed, then lower chain id (in order: the chain whose last
    vertex, then the one whose first; reversed: the lower id first), then first to
    first before last to last. A chain's id is its index in ``loops.open``; a
    joined chain's id is the smallest index in it, fixed when the round lists its
    candidates. A join is used only if both ends are still free. A chain whose end
    joins its own start becomes a loop.

    Joining keeps every vertex, except that two identical joint vertices are kept
    once and a loop whose last vertex equals its first drops the last (CuraEngine
    keeps both; its simplification removes them later). Loops may have fewer than
    3 vertices; the perimeter filter and simplification drop them. New loops and
    open chains are ordered by id and start at the head of the joined chain.
    Empty chains are dropped.

    Cost: O(V + n log n) time and O(V) memory for V vertices and n chains, also
    when thousands of chain ends crowd within one gap (a triangle soup) or
    coincide. The candidate pairs are never listed: the joins a round makes are
    the greedy matching of the chain ends by the order above, found with a k-d
    tree of the ends and mutual nearest partners. All candidate keys are
    distinct, so the result, ties included, is exactly that of listing every
    candidate pair and taking them in order.

    Examples
    --------
    Three pieces of a 9 µm square, with gaps of 5, 5 and 3 µm:

    >>> import numpy as np
    >>> from vecslice import LayerPaths
    >>> pieces = LayerPaths([[0, 0], [9, 0], [9, 5], [9, 9], [5, 9],
    ...                      [0, 9], [0, 3]], [0, 2, 5, 7], [0, 3])
    >>> raw = LayerPaths(np.empty((0, 2), np.int64), [0], [0, 0], open=pieces)
    >>> loops, gaps = stitch(raw)
    >>> loops.layer(0)[0].tolist()
    [[0, 9], [0, 3], [0, 0], [9, 0], [9, 5], [9, 9], [5, 9]]
    >>> gaps.tolist(), loops.open.n_rings
    ([3], 0)
    """
    lp = _check_loops(loops)
    gap1 = min(check_int(max_gap_in_order, "max_gap_in_order", minimum=0), _GAP_CLAMP)
    gap2 = min(check_int(max_gap, "max_gap", minimum=0), _GAP_CLAMP)
    chains = lp.open if lp.open is not None else LayerPaths.empty(lp.n_layers)
    if chains.n_rings == 0:  # nothing to join (and no kernel to compile on a first run)
        out = LayerPaths._trusted(lp.coords, lp.ring_offsets, lp.layer_offsets, chains)
        return Stitched(out, freeze(np.zeros(lp.n_layers, dtype=np.int64)))
    cc, cr, cl, oc, orr, ol, n_stitched = stitch_chains(
        chains.coords, chains.ring_offsets, chains.layer_offsets, gap1, gap2
    )
    new_loops = LayerPaths._trusted(cc, cr, cl)
    still_open = LayerPaths._trusted(oc, orr, ol)
    closed = lp if new_loops.n_rings == 0 else _merge_layers(lp, new_loops)
    out = LayerPaths._trusted(
        closed.coords, closed.ring_offsets, closed.layer_offsets, still_open
    )
    return Stitched(out, freeze(n_stitched))
