"""Coercion and validation shared by every public function.

Checks run in the order type, ndim, shape, values; every message names the argument,
what was expected, what was received and (for arrays) the first bad index.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice.errors import InputTypeError, InputValueError, LayoutError, SettingsError
from vecslice.units import COORD_LIMIT

__all__ = [
    "as_coords",
    "as_int_array",
    "as_offsets",
    "check_bool",
    "check_coord_range",
    "check_int",
    "check_layer_count",
    "check_offsets",
    "check_option",
]


def _describe(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"array of dtype {value.dtype} and shape {value.shape}"
    return f"{type(value).__name__} {value!r}"


def as_int_array(
    value: ArrayLike, name: str, *, ndim: int, width: int | None = None
) -> NDArray[np.int64]:
    """Return ``value`` as a C-contiguous int64 array, checking dtype and shape.

    Integer dtypes (any width, signed or unsigned) are accepted and widened to int64;
    floats, bools and objects are rejected with an :class:`InputTypeError`. The
    result may be the caller's own array: for arrays that are stored or read by
    kernels, take :func:`vecslice.ragged.private_int_array` and check its values.
    """
    if isinstance(value, (str, bytes)) or value is None:
        raise InputTypeError(
            f"`{name}` must be an integer array; got {_describe(value)}"
        )
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nested lists
        raise InputTypeError(
            f"`{name}` must be an integer array; got {type(value).__name__} "
            f"that numpy cannot convert ({exc})"
        ) from None
    if a.dtype.kind not in "iu" and not (a.size == 0 and a.dtype.kind == "f"):
        hint = ""
        if a.dtype.kind == "f":
            hint = ". Convert millimetres with vecslice.to_microns()"
        raise InputTypeError(
            f"`{name}` must be integer microns; got dtype {a.dtype}{hint}"
        )
    if a.ndim != ndim or (width is not None and a.shape[-1] != width):
        want = f"({'N, ' + str(width) if width is not None else 'N'})"
        raise InputValueError(f"`{name}` must have shape {want}; got shape {a.shape}")
    if a.dtype == np.uint64 and a.size and int(a.max()) > np.iinfo(np.int64).max:
        raise InputValueError(f"`{name}` has values beyond int64; got max {a.max()}")
    return np.ascontiguousarray(a, dtype=np.int64)


def check_coord_range(a: NDArray[np.int64], name: str) -> None:
    """Raise unless every |value| in ``a`` is below ``COORD_LIMIT`` (2**30 µm)."""
    if a.size == 0:
        return
    flat = a.reshape(-1)
    if flat.min() > -COORD_LIMIT and flat.max() < COORD_LIMIT:
        return  # two reductions, no temporaries: the common case
    bad = np.flatnonzero((flat >= COORD_LIMIT) | (flat <= -COORD_LIMIT))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`{name}` must satisfy |value| < 2**30 µm (about 1 km); got {flat[i]} "
            f"at row {i // (a.shape[1] if a.ndim == 2 else 1)}"
        )


def as_coords(
    value: ArrayLike, name: str = "coords", *, dim: int = 2
) -> NDArray[np.int64]:
    """Coerce ``value`` to (N, dim) int64 µm coordinates within ``COORD_LIMIT``."""
    a = as_int_array(value, name, ndim=2, width=dim)
    check_coord_range(a, name)
    return a


def as_offsets(value: ArrayLike, n_below: int, name: str) -> NDArray[np.int64]:
    """Coerce ``value`` to offsets into a level of ``n_below`` elements.

    Offsets are 1-D int64 with length >= 1, start at 0, end at ``n_below`` and never
    decrease.
    """
    a = as_int_array(value, name, ndim=1)
    check_offsets(a, n_below, name)
    return a


def check_offsets(a: NDArray[np.int64], n_below: int, name: str) -> None:
    """Raise unless the int64 array ``a`` is valid offsets (see :func:`as_offsets`)."""
    if a.shape[0] < 1:
        raise LayoutError(f"`{name}` must have length >= 1; got an empty array")
    if a[0] != 0:
        raise LayoutError(f"`{name}` must start at 0; got {a[0]} at index 0")
    if a[-1] != n_below:
        raise LayoutError(
            f"`{name}` must end at {n_below} (the length of the level below); "
            f"got {a[-1]} at index {a.shape[0] - 1}"
        )
    bad = np.flatnonzero(np.diff(a) < 0)
    if bad.size:
        i = int(bad[0])
        raise LayoutError(f"`{name}` decreases at index {i}: {a[i]} > {a[i + 1]}")


def check_schedule_limits(z: NDArray[np.int64], print_z: NDArray[np.int64],
                          lo: int, hi: int, *, adaptive: bool) -> None:
    """Raise unless a layer schedule stays within ``COORD_LIMIT`` (2**30 µm).

    ``z`` are the slice heights in the mesh's frame, ``print_z`` the heights
    above the bed, and ``lo``/``hi`` the mesh's z range (for the message).
    """
    if z.size and int(z.max()) >= COORD_LIMIT:
        k = int(np.argmax(z >= COORD_LIMIT))
        raise InputValueError(
            f"the layer schedule must stay below z = 2**30 µm (the coordinate "
            f"limit); got layer {k} at z = {int(z[k])} µm, above a mesh whose top is "
            f"at {hi} µm"
            + (" (the last adaptive layer ends above the model)" if adaptive else "")
            + ": move the mesh down"
        )
    if print_z.size and int(print_z.max()) >= COORD_LIMIT:
        # heights above the bed: a model more than 2**30 µm tall (SlicedModel
        # would refuse them only once everything was sliced)
        k = int(np.argmax(print_z >= COORD_LIMIT))
        raise InputValueError(
            f"the layers must print below 2**30 µm (about 1 km) above the bed; got "
            f"layer {k} at {int(print_z[k])} µm, for a mesh {hi - lo} µm tall "
            f"(from z = {lo} to {hi} µm)"
        )


def check_int(
    value: object,
    name: str,
    *,
    minimum: int | None = None,
    maximum: int | None = None,
    what: str = "an integer number of µm",
    setting: bool = True,
) -> int:
    """Return ``value`` as a Python int, checking its type and range.

    ``what`` describes the expected value in the type error. Errors are
    :class:`SettingsError` (and its type counterpart) if ``setting``, else
    :class:`InputValueError` / :class:`InputTypeError`.
    """
    type_error = SettingsTypeError if setting else InputTypeError
    value_error = SettingsError if setting else InputValueError
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        if isinstance(value, float) and np.isfinite(value) and value == int(value):
            value = int(value)
        else:
            raise type_error(f"`{name}` must be {what}; got {_describe(value)}")
    v = int(value)
    if minimum is not None and v < minimum:
        raise value_error(f"`{name}` must be >= {minimum}; got {v}")
    if maximum is not None and v > maximum:
        raise value_error(f"`{name}` must be <= {maximum}; got {v}")
    return v


def check_bool(value: object, name: str, *, setting: bool = False) -> bool:
    """Return ``value`` if it is a bool (or numpy bool); raise InputTypeError.

    Options are never taken by truthiness: ``"no"`` is not False. ``setting``: a
    :class:`SliceSettings` field, whose errors are also SettingsErrors.

    Examples
    --------
    >>> check_bool(False, "compress")
    False
    >>> check_bool("no", "compress")
    Traceback (most recent call last):
    ...
    vecslice.errors.InputTypeError: `compress` must be True or False; got str 'no'
    """
    if not isinstance(value, (bool, np.bool_)):
        error = SettingsTypeError if setting else InputTypeError
        raise error(f"`{name}` must be True or False; got {_describe(value)}")
    return bool(value)


def check_layer_count(n: int, max_layers: int, why: str, fix: str,
                      needed: int | None = None) -> None:
    """Raise a SettingsError if ``n`` layers exceed ``max_layers``.

    Called before any per-layer allocation. ``why`` says where ``n`` comes from
    (e.g. "a mesh 1000000000 µm tall at layer_height 100 µm") and ``fix`` how to
    raise the limit, with ``{n}`` for the limit to suggest (e.g.
    "SliceSettings(max_layers={n})"): ``needed``, by default ``n``. The error's
    ``layers_needed`` attribute is that limit.

    Examples
    --------
    >>> check_layer_count(7, 5, "7 heights", "f(max_layers={n})")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    vecslice.errors.SettingsError: the layer count must be <= `max_layers` (5); ...
    """
    if n > max_layers:
        need = n if needed is None else needed
        error = SettingsError(
            f"the layer count must be <= `max_layers` ({max_layers}); got {n} layers "
            f"({why}). Memory and time grow with the layers; if this is intended, "
            f"raise the limit: {fix.replace('{n}', str(need))} or more"
        )
        error.layers_needed = need
        raise error


def check_option(value: object, options: Sequence[str], name: str) -> str:
    """Return ``value`` if it is one of ``options``; raise a SettingsError otherwise."""
    if not isinstance(value, str) or value not in options:
        raise SettingsError(
            f"`{name}` must be one of {', '.join(repr(o) for o in options)}; "
            f"got {value!r}"
        )
    return value


class SettingsTypeError(SettingsError, InputTypeError):
    """A setting of the wrong type, or an unknown one: a SettingsError and a TypeError.

    Kept private: callers catch it as either.
    """
