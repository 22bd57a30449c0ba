"""Unit conversion at the edge of the library: millimetres in, int64 microns out."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice.errors import InputValueError

__all__ = ["COORD_LIMIT", "to_microns"]

COORD_LIMIT = 2**30
"""Exclusive bound on |coordinate| in µm (products of differences fit int64)."""


def to_microns(mm: ArrayLike, *, name: str = "mm") -> NDArray[np.int64]:
    """Convert millimetres to int64 microns, rounding half away from zero.

    Parameters
    ----------
    mm : array_like of float
        Lengths or coordinates in millimetres.
    name : str, default 'mm'
        Argument name used in error messages.

    Returns
    -------
    ndarray of int64
        The same shape, in µm.

    Raises
    ------
    InputValueError
        If a value is NaN or infinite, or its magnitude reaches ``COORD_LIMIT`` µm.

    Examples
    --------
    >>> to_microns([0.0005, -0.0005, 1.25]).tolist()
    [1, -1, 1250]
    """
    a = np.asarray(mm, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(a.ravel()))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`{name}` must be finite; got {a.ravel()[i]} at flat index {i}"
        )
    um = a * 1000.0
    # round half away from zero (np.rint would round half to even)
    um = np.trunc(um + np.copysign(0.5, um))
    big = np.flatnonzero(np.abs(um.ravel()) >= COORD_LIMIT)
    if big.size:
        i = int(big[0])
        raise InputValueError(
            f"`{name}` must be below {COORD_LIMIT / 1000:g} mm in magnitude "
            f"(2**30 µm); got {a.ravel()[i]!r} mm at flat index {i}"
        )
    return um.astype(np.int64)
