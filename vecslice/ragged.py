"""Shared machinery of the ragged containers.

:class:`~vecslice.Paths`, :class:`~vecslice.LayerPaths`,
:class:`~vecslice.parts.LayerParts` and :class:`~vecslice.SlicedModel` all hold flat
int64 buffers with nested offsets (level ``k`` element ``i`` is
``items[offsets[i]:offsets[i + 1]]`` of the level below). This module holds what they
share: validating nested offsets, holding arrays read-only, checking indices,
building a container from arrays known to be valid, and whole-array ragged helpers.

The order of the checks on a caller's array is: coerce it (dtype and shape, which
no write can change), take the private frozen copy (:func:`private_int_array`),
then check its values on that copy and pass only the copy on. Values checked on
the caller's memory and copied afterwards could differ from what was checked
(another thread writing the array in between), and kernels index without bounds
checks.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._validate import as_int_array, check_coord_range, check_offsets
from vecslice.errors import InputIndexError, InputTypeError
from vecslice.units import COORD_LIMIT

__all__ = [
    "RaggedContainer",
    "adopt",
    "check_index",
    "freeze",
    "is_frozen",
    "nested_offsets",
    "offsets_from_lengths",
    "private_coords",
    "private_int_array",
    "private_int_extremes",
    "ragged_take",
    "reduce_frozen",
    "value_extremes",
]

C = TypeVar("C", bound="RaggedContainer")


class _ReadOnlyBase:
    """The private base of a frozen array: exports its data read-only, nothing else.

    numpy lets ``flags.writeable`` be set back to True on an array that owns its
    data or whose base exports a writeable buffer. A frozen array is a view whose
    base is this object: it exports the data through ``__array_interface__``
    marked read-only and has no buffer protocol, so neither the array, nor any
    view of it, nor ``a.base`` can be made writeable again. The array that owns
    the memory is held only here, privately, so that it lives as long as its views.
    """

    __slots__ = ("__array_interface__", "_owner")

    def __init__(self, owner: NDArray[Any]) -> None:
        self._owner = owner
        self.__array_interface__ = {
            "version": 3,
            "shape": owner.shape,
            "typestr": owner.dtype.str,
            "data": (owner.__array_interface__["data"][0], True),  # read-only
            "strides": None,  # C-contiguous
        }


def is_frozen(a: NDArray[Any]) -> bool:
    """True if ``a`` is a view of data frozen by :func:`freeze` (immutable)."""
    x = a
    while isinstance(x, np.ndarray):
        if x.flags.writeable or x.flags.owndata:
            return False
        x = x.base
    return isinstance(x, _ReadOnlyBase)


def freeze(a: NDArray[Any]) -> NDArray[Any]:
    """``a`` as an immutable array, without copying its data.

    The caller hands ``a`` over: nothing else may write it afterwards. The result
    is a read-only view (of the C-contiguous ``a``; made contiguous first if
    needed) whose ``flags.writeable`` cannot be set back to True, nor that of any
    view of it. Frozen C-contiguous arrays are returned as they are.

    Examples
    --------
    >>> f = freeze(np.arange(3))
    >>> f.flags.writeable = True
    Traceback (most recent call last):
    ...
    ValueError: cannot set WRITEABLE flag to True of this array
    """
    if is_frozen(a) and a.flags.c_contiguous:
        return a
    owner = np.ascontiguousarray(a)
    owner.flags.writeable = False  # catches a write through a forgotten reference
    return np.asarray(_ReadOnlyBase(owner))


def adopt(new: NDArray[Any], given: object) -> NDArray[Any]:
    """``new`` (coerced from the caller's ``given``) frozen, copied if shared.

    A container must not share memory that its caller can still write: ``new`` is
    copied unless it is frozen already (immutable, so it is shared) or numpy made
    it afresh from ``given`` (a list, or an array of another dtype or order).
    """
    return freeze(new.copy() if _needs_copy(new, given) else new)


def _needs_copy(new: NDArray[Any], given: object) -> bool:
    """Whether :func:`adopt` copies ``new``: not frozen, not numpy's fresh array."""
    if is_frozen(new):
        return False
    fresh = isinstance(given, (list, tuple)) or (
        isinstance(given, np.ndarray) and not np.may_share_memory(new, given)
    )
    return not (fresh and new.flags.owndata)


def private_int_array(
    value: ArrayLike, name: str, *, ndim: int, width: int | None = None
) -> NDArray[np.int64]:
    """``value`` as a frozen C-contiguous int64 array that its caller cannot write.

    Dtype and shape are checked (:func:`vecslice._validate.as_int_array`), then
    the array is adopted (:func:`adopt`: copied unless numpy made it afresh or it
    is frozen already). Values are not checked: check them on the result, which
    is what the caller stores or passes to kernels.

    Examples
    --------
    >>> given = np.array([0, 2, 3])
    >>> a = private_int_array(given, "ring_offsets", ndim=1)
    >>> given[1] = 9
    >>> a.tolist(), a.flags.writeable
    ([0, 2, 3], False)
    """
    return adopt(as_int_array(value, name, ndim=ndim, width=width), value)


def private_int_extremes(
    value: ArrayLike, name: str, *, ndim: int, width: int | None = None
) -> tuple[NDArray[np.int64], int, int]:
    """:func:`private_int_array` and the smallest and largest value of the result.

    The copy (where one is taken) and the extremes are made in chunks on threads,
    each chunk measured right after it was copied, while it is in cache: the
    extremes are those of the values kept. For an empty result they are
    ``(0, 0)``.
    """
    new = as_int_array(value, name, ndim=ndim, width=width)
    if new.size == 0:
        return adopt(new, value), 0, 0
    if _needs_copy(new, value):
        own = np.empty_like(new)
        lo, hi = _copy_extremes(new.reshape(-1), own.reshape(-1))
        return freeze(own), lo, hi
    kept = freeze(new)  # frozen already, or numpy's fresh array: no copy
    lo, hi = _copy_extremes(kept.reshape(-1), None)
    return kept, lo, hi


def value_extremes(a: NDArray[np.int64]) -> tuple[int, int]:
    """(min, max) of the non-empty C-contiguous int64 ``a``, in chunks on threads."""
    return _copy_extremes(a.reshape(-1), None)


def private_coords(value: ArrayLike, name: str, *, width: int) -> NDArray[np.int64]:
    """:func:`private_int_extremes` of (N, ``width``) coordinates, range-checked.

    Raises ``InputValueError`` naming the first row with a value at or beyond
    ``COORD_LIMIT`` (2**30 µm), checked on the private copy.
    """
    a, lo, hi = private_int_extremes(value, name, ndim=2, width=width)
    if not -COORD_LIMIT < lo <= hi < COORD_LIMIT:
        check_coord_range(a, name)  # raises, naming the row
    return a


_EXTREMES_CHUNK = 1 << 18  # values (2 MiB) per chunk of _copy_extremes


def _copy_extremes(
    src: NDArray[np.int64], dst: NDArray[np.int64] | None
) -> tuple[int, int]:
    """(min, max) of the flat non-empty ``src``, copied first to ``dst`` if given.

    In chunks on threads (numpy releases the GIL to copy and reduce); with
    ``dst``, each chunk is measured in ``dst`` after it was copied.
    """
    from vecslice._kernels._jit import even_chunks
    from vecslice._threads import run_chunks

    bounds = even_chunks(src.shape[0], _EXTREMES_CHUNK)
    found = np.empty((bounds.shape[0] - 1, 2), dtype=np.int64)
    chunk_of = {int(b): c for c, b in enumerate(bounds[:-1])}

    def measure(lo: int, hi: int) -> None:
        part = src[lo:hi]
        if dst is not None:
            np.copyto(dst[lo:hi], part)
            part = dst[lo:hi]
        row = found[chunk_of[lo]]
        row[0] = part.min()
        row[1] = part.max()

    run_chunks(measure, bounds)
    return int(found[:, 0].min()), int(found[:, 1].max())


def nested_offsets(
    coords: ArrayLike, levels: Sequence[tuple[str, ArrayLike]], name: str = "coords"
) -> list[NDArray[np.int64]]:
    """Private copies of ``coords`` and a chain of offsets, validated.

    ``levels`` is ``[(name, offsets), ...]``, innermost level first: the first
    offsets index ``coords``, each next one the elements of the previous;
    ``name`` is how messages call ``coords``. Returns the frozen arrays
    ``[coords, offsets_0, offsets_1, ...]`` (:func:`private_int_array`); each is
    validated after it was copied, so what was checked is what is returned.

    Examples
    --------
    >>> c, r, lo = nested_offsets([[0, 0], [1, 0], [0, 1]],
    ...                           [("ring_offsets", [0, 3]), ("layer_offsets", [0, 1])])
    >>> r.tolist(), lo.tolist()
    ([0, 3], [0, 1])
    """
    out = [private_coords(coords, name, width=2)]
    below = out[0].shape[0]
    for level, offsets in levels:
        o = private_int_array(offsets, level, ndim=1)
        check_offsets(o, below, level)
        out.append(o)
        below = o.shape[0] - 1
    return out


def check_index(value: object, n: int, name: str, what: str) -> int:
    """Return ``value`` as an index in ``range(n)``.

    Negative indices count from the end, as for Python sequences: ``-1`` is the
    last element; ``-n <= value < n`` is valid. ``what`` names the index in
    messages (e.g. ``"layer index"``).

    Raises
    ------
    InputTypeError
        If ``value`` is not an integer (floats, strings and bools are refused).
    InputIndexError
        If ``value`` is out of range (also an ``IndexError``).

    Examples
    --------
    >>> check_index(-1, 3, "k", "layer index")
    2
    >>> check_index(3, 3, "k", "layer index")
    Traceback (most recent call last):
    ...
    vecslice.errors.InputIndexError: `k` must be a layer index in [-3, 3); got 3
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, np.integer)
    ):
        raise InputTypeError(
            f"`{name}` must be an integer {what}; got {type(value).__name__} "
            f"{value!r}"
        )
    if not -n <= value < n:
        raise InputIndexError(
            f"`{name}` must be a {what} in [{-n}, {n}); got {int(value)}"
        )
    return int(value) % n


def offsets_from_lengths(lens: NDArray[np.int64]) -> NDArray[np.int64]:
    """Offsets ``[0, cumsum(lens)...]`` of a level whose elements have ``lens`` items.

    Examples
    --------
    >>> offsets_from_lengths(np.array([2, 0, 3])).tolist()
    [0, 2, 2, 5]
    """
    out = np.zeros(lens.shape[0] + 1, dtype=np.int64)
    np.cumsum(lens, out=out[1:])
    return out


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
    new_offsets = offsets_from_lengths(lens)
    items = np.arange(new_offsets[-1], dtype=np.int64)
    items += np.repeat(starts - new_offsets[:-1], lens)
    return new_offsets, items


class RaggedContainer:
    """Base of the frozen dataclasses of read-only arrays.

    Subclasses are ``@dataclass(frozen=True, slots=True, eq=False)``; their fields
    are arrays or nested containers (or ``None``).
    """

    __slots__ = ()

    def _set_fields(self, values: dict[str, Any]) -> None:
        """Store ``values`` (arrays already validated, frozen or adoptable)."""
        for name, value in values.items():
            object.__setattr__(self, name, value)

    @classmethod
    def _trusted(cls: type[C], *values: Any, **named: Any) -> C:
        """Wrap arrays that vecslice just computed and knows to be valid.

        No checks and no copies; the arrays are handed over and frozen. Fields not
        given are ``None``.
        """
        self = object.__new__(cls)
        names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
        given = dict(zip(names, values, strict=False)) | named
        self._set_fields({
            n: freeze(v) if isinstance(v, np.ndarray) else v
            for n, v in ((n, given.get(n)) for n in names)
        })
        return self

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle and copy by fields; the copy's arrays are frozen again."""
        names = [f.name for f in dataclasses.fields(self)]  # type: ignore[arg-type]
        return (_rebuild, (type(self), {n: getattr(self, n) for n in names}))

    @property
    def nbytes(self) -> int:
        """Bytes held by the arrays, nested containers included."""
        total = 0
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            if isinstance(value, (np.ndarray, RaggedContainer)):
                total += value.nbytes
        return int(total)


def _rebuild(cls: type[C], values: dict[str, Any]) -> C:
    """Unpickle a container: its (fresh) arrays are frozen, nothing re-validated."""
    return cls._trusted(**values)


def reduce_frozen(obj: Any) -> tuple[Any, ...]:
    """``__reduce__`` of a frozen dataclass holding read-only arrays.

    Unpickling and ``copy.deepcopy`` go through a dataclass's own ``__setstate__``,
    which stores the (fresh, writeable) arrays as they come; with this, they come
    back through :func:`_rebuild_frozen`, which freezes them as the constructor did.
    """
    names = [f.name for f in dataclasses.fields(obj)]
    return (_rebuild_frozen, (type(obj), {n: getattr(obj, n) for n in names}))


def _rebuild_frozen(cls: type[Any], values: dict[str, Any]) -> Any:
    """Unpickle or copy a dataclass of :func:`reduce_frozen`: its arrays frozen."""
    self = object.__new__(cls)
    for name, value in values.items():
        object.__setattr__(
            self, name, freeze(value) if isinstance(value, np.ndarray) else value)
    return self
