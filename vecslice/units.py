"""Unit conversion at the edge of the library: millimetres in, int64 microns out."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice.errors import InputTypeError, InputValueError

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
    InputTypeError
        If ``mm`` is not numeric (None, strings, objects, ragged lists).
    InputValueError
        If a value is NaN or infinite, or its magnitude reaches ``COORD_LIMIT`` µm.

    Examples
    --------
    >>> to_microns([0.0005, -0.0005, 1.25]).tolist()
    [1, -1, 1250]
    """
    a = _as_float(mm, name)
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
            f"(2**30 µm); got {float(a.ravel()[i])!r} mm at flat index {i}"
        )
    return um.astype(np.int64)


def power_of_ten(value: object) -> str:
    """A number beyond float range for a message: ``about 10**400`` (or ``-10**400``).

    Its digits are not written out: a Python int may have millions of them.
    """
    n = int(value)  # type: ignore[call-overload]
    return f"about {'-' if n < 0 else ''}10**{int(abs(n).bit_length() * 0.30103)}"


def _overflows(value: object) -> bool:
    try:
        float(value)  # type: ignore[arg-type]
    except OverflowError:
        return True
    except (TypeError, ValueError):
        pass
    return False


def _as_float(mm: ArrayLike, name: str) -> NDArray[np.float64]:
    """``mm`` as float64, refusing what is not a number (bools, strings, None)."""
    want = f"`{name}` must be a number or an array of numbers (millimetres)"
    if mm is None or isinstance(mm, (str, bytes)):
        raise InputTypeError(f"{want}; got {type(mm).__name__} {mm!r}")
    try:
        a = np.asarray(mm)
    except (TypeError, ValueError) as exc:  # ragged nested lists
        raise InputTypeError(
            f"{want}; got {type(mm).__name__} that numpy cannot convert ({exc})"
        ) from None
    if a.dtype.kind == "O":
        # numpy would read None as NaN and "2.5" as 2.5: refuse them by type
        for i, v in enumerate(a.ravel().tolist()):
            if v is None or isinstance(v, (str, bytes, bool, np.bool_)):
                raise InputTypeError(
                    f"{want}; got {type(mm).__name__} with {type(v).__name__} "
                    f"{v!r} at flat index {i}"
                )
        try:
            return a.astype(np.float64)
        except OverflowError:  # a Python int beyond float range (10**400)
            flat = a.ravel()
            i = next(k for k, v in enumerate(flat) if _overflows(v))
            raise InputValueError(
                f"`{name}` must be below {COORD_LIMIT / 1000:g} mm in magnitude "
                f"(2**30 µm); got {power_of_ten(flat[i])} at flat index {i}"
            ) from None
        except (TypeError, ValueError) as exc:
            raise InputTypeError(
                f"{want}; got {type(mm).__name__} with a non-number ({exc})"
            ) from None
    if a.dtype.kind in "US":
        raise InputTypeError(f"{want}; got {type(mm).__name__} holding strings")
    if a.dtype.kind not in "iuf":
        raise InputTypeError(f"{want}; got {type(mm).__name__} of dtype {a.dtype}")
    return a.astype(np.float64, copy=False)
