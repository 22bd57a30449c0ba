"""Binary PLY bodies, walked record by record through their list counts.

Records whose lists all have the first record's lengths are checked with one
vectorised comparison per list; others are walked by a kernel
(``kernels/ply.py``). (trimesh read every list with the first one's length,
which loaded faces of mixed corner counts wrong or not at all.) The header is
parsed, and the mesh assembled, by :mod:`vecslice.plyoff`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import MeshFileError
from vecslice.plyoff import (
    _PLY_ORDER,
    _PLY_SIZES,
    _PLY_TYPES,
    _PLY_UNSIGNED,
    Arrays,
    _assemble,
    _Element,
    _Header,
    _list_items,
    _the_corners,
)

__all__: list[str] = []

def read_ply_binary(path: Path, data: bytes, h: _Header) -> Arrays:
    """Vertices (x, y, z) and triangle fans of the faces of a binary PLY file.

    Every element is walked record by record through its list counts, so faces
    of mixed corner counts (Blender writes triangles and quads) load, and a
    count that is negative, runs past the end of the file or gives a face fewer
    than 3 corners is refused, as are bytes after the last element.
    """
    order = _PLY_ORDER[h.fmt]
    corners = _the_corners(path, h) if h.face is not None and h.face.count else None
    pos, records = h.end, {}
    for el in h.elements:
        least = {corners: 3} if el is h.face else {}
        records[id(el)], pos = _walk(path, data, pos, el, order, least)
    if pos != len(data):
        raise MeshFileError(
            f"'{path}' is corrupt: {len(data) - pos:,} bytes follow the elements its "
            "PLY header announces")
    return _assemble(path, h, lambda el, name: _values(data, records[id(el)], el,
                                                       order, name))


def _widths(el: _Element, least: dict[str | None, int]) -> NDArray[np.int64]:
    """Per property: count bytes (0: a scalar), value bytes, signed count, least."""
    return np.array([[_PLY_SIZES[c] if c else 0, _PLY_SIZES[v],
                      int(c is not None and c not in _PLY_UNSIGNED), least.get(n, 0)]
                     for n, c, v in el.props], dtype=np.int64).reshape(-1, 4)


def _record(path: Path, data: bytes, at: int, el: _Element, order: str,
            least: dict[str | None, int], r: int) -> int:
    """Size of record ``r`` of ``el`` at byte ``at``, or an error saying what is bad."""
    size = 0
    for name, count, value in el.props:
        if count is None:
            size += _PLY_SIZES[value]
            continue
        if at + size + _PLY_SIZES[count] > len(data):
            break
        n = int(np.frombuffer(data, order + _PLY_TYPES[count], 1, at + size)[0])
        if n < least.get(name, 0):
            raise MeshFileError(
                f"'{path}' is corrupt: PLY '{el.name}' {r} (byte {at:,}) has a list "
                f"of {n} values"
                + ("; a face needs at least 3 vertices" if name in least else ""))
        size += _PLY_SIZES[count] + n * _PLY_SIZES[value]
    else:
        if at + size <= len(data):
            return size
    raise MeshFileError(
        f"'{path}' is truncated or corrupt: PLY '{el.name}' {r} (byte {at:,}) runs "
        f"past the end of the file ({len(data):,} bytes)")


@dataclass
class _Records:
    """Where the records of an element are: all ``stride`` bytes long, or not."""

    start: int
    count: int
    stride: int = 0
    starts: NDArray[np.int64] | None = None  # (count + 1,) unless all alike


def _walk(path: Path, data: bytes, pos: int, el: _Element, order: str,
          least: dict[str | None, int]) -> tuple[_Records, int]:
    """Where the records of ``el`` (from byte ``pos``) are, and where they end.

    Records whose lists all have the lengths of the first record's are checked
    with one vectorised comparison per list; others are walked by a kernel.
    """
    if el.count == 0:
        return _Records(pos, 0), pos
    stride = _record(path, data, pos, el, order, least, 0)
    if pos + el.count * stride <= len(data):
        at, same = pos, True
        for _, count, value in el.props:
            if count is None:
                at += _PLY_SIZES[value]
                continue
            n = _strided(data, at, el.count, stride, order + _PLY_TYPES[count])
            same = bool((n == n[0]).all())
            if not same:
                break
            at += _PLY_SIZES[count] + int(n[0]) * _PLY_SIZES[value]
        if same:
            return _Records(pos, el.count, stride), pos + el.count * stride
    from vecslice._kernels.ply import record_starts

    starts, done = record_starts(np.frombuffer(data, np.uint8), pos, el.count,
                                 _widths(el, least), order == ">")
    if done < el.count:  # raises, naming the record and what is wrong with it
        _record(path, data, int(starts[done]), el, order, least, done)
    return _Records(pos, el.count, starts=starts), int(starts[-1])


def _strided(data: bytes, at: int, n: int, stride: int, dtype: str) -> NDArray[Any]:
    """``n`` values of ``dtype`` from byte ``at``, ``stride`` bytes apart (a view)."""
    return np.ndarray((n,), np.dtype(dtype), data, at, (stride,))


def _at(data: bytes, at: NDArray[np.int64], dtype: str) -> NDArray[Any]:
    """The values of ``dtype`` at the byte offsets ``at`` (gathered per alignment)."""
    dt = np.dtype(dtype)
    out = np.empty(at.shape[0], dt)
    for k in range(dt.itemsize):
        sel = np.flatnonzero(at % dt.itemsize == k)
        view = np.frombuffer(data, dt, (len(data) - k) // dt.itemsize, k)
        out[sel] = view[(at[sel] - k) // dt.itemsize]
    return out


def _values(data: bytes, rec: _Records, el: _Element, order: str,
            name: str) -> tuple[NDArray[Any], NDArray[np.int64]]:
    """Property ``name`` of every record: values (lists in a row), list counts.

    The counts are empty for a scalar property.
    """
    j = next(i for i, p in enumerate(el.props) if p[0] == name)
    _, count, value = el.props[j]
    vtype, size = order + _PLY_TYPES[value], _PLY_SIZES[value]
    if rec.starts is None:  # all records laid out as the first one
        at = rec.start
        for _, c, v in el.props[:j]:
            at += _PLY_SIZES[v] if c is None else _PLY_SIZES[c] + _PLY_SIZES[v] * int(
                np.frombuffer(data, order + _PLY_TYPES[c], 1, at)[0])
        if count is None:
            return _strided(data, at, rec.count, rec.stride, vtype), np.empty(0, int)
        n = int(np.frombuffer(data, order + _PLY_TYPES[count], 1, at)[0])
        lists = np.ndarray((rec.count, n), np.dtype(vtype), data,
                           at + _PLY_SIZES[count], (rec.stride, size))
        return lists.reshape(-1), np.full(rec.count, n, dtype=np.int64)
    ats = rec.starts[:-1].copy()
    for _, c, v in el.props[:j]:
        ats += _PLY_SIZES[v] if c is None else _PLY_SIZES[c] + _PLY_SIZES[v] * _at(
            data, ats, order + _PLY_TYPES[c]).astype(np.int64)
    if count is None:
        return _at(data, ats, vtype), np.empty(0, int)
    n = _at(data, ats, order + _PLY_TYPES[count]).astype(np.int64)
    return _at(data, _list_items(ats + _PLY_SIZES[count], n, size), vtype), n


