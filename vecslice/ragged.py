"""Vectorised helpers for ragged (offsets, items) arrays."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["ragged_take"]


def ragged_take(
    offsets: NDArray[np.int64], idx: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Select elements ``idx`` of a ragged level.

    Returns ``(new_offsets, items)``: element ``i`` of the result holds the items
    ``offsets[idx[i]]:offsets[idx[i] + 1]`` of the input, and ``items`` indexes the
    level below.

    Examples
    --------
    >>> o, items = ragged_take(np.array([0, 2, 2, 5]), np.array([2, 0]))
    >>> o.tolist(), items.tolist()
    ([0, 3, 5], [2, 3, 4, 0, 1])
    """
    starts = offsets[idx]
    lens = offsets[idx + 1] - starts
    new_offsets = np.zeros(idx.shape[0] + 1, dtype=np.int64)
    np.cumsum(lens, out=new_offsets[1:])
    items = np.arange(new_offsets[-1], dtype=np.int64)
    items += np.repeat(starts - new_offsets[:-1], lens)
    return new_offsets, items
