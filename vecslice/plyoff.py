"""PLY and OFF files, read here: headers checked against the file, then the body.

A header's counts are checked against the file's size, and an ASCII body row by
row against them (rows, values per row, list lengths), so a truncated or lying
file is refused instead of loading as part of a mesh; the numbers those checks
parsed are then the mesh. A binary PLY body is walked record by record through
its list counts. Faces of any corner count load as triangle fans. (trimesh read
these once: it reads every binary list with the first one's length, and splits
ASCII rows at characters that are not line ends, so some files loaded wrong.)
Used by :mod:`vecslice.meshfile`, whose limits and messages these checks share.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import MeshFileError

__all__: list[str] = []

Arrays = tuple[NDArray[np.float64], NDArray[np.int64]]


def _mf() -> ModuleType:
    """:mod:`vecslice.meshfile` (imported when called: it imports this module)."""
    from vecslice import meshfile

    return meshfile


_PLY_TYPES = {
    "char": "i1", "uchar": "u1", "int8": "i1", "uint8": "u1", "short": "i2",
    "ushort": "u2", "int16": "i2", "uint16": "u2", "int": "i4", "uint": "u4",
    "int32": "i4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
    "float64": "f8",
}
_PLY_SIZES = {name: int(code[1]) for name, code in _PLY_TYPES.items()}
_PLY_INTS = {name for name, code in _PLY_TYPES.items() if code[0] in "iu"}
_PLY_UNSIGNED = {name for name, code in _PLY_TYPES.items() if code[0] == "u"}
_PLY_ORDER = {"binary_little_endian": "<", "binary_big_endian": ">"}
_PLY_FACE_NAMES = ("vertex_indices", "vertex_index")


def _rows(body: bytes) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    r"""Tokens per non-blank line of ``body`` and those lines' 0-based numbers.

    Lines end at ``\n``; blanks are space, tab, ``\r``, ``\v`` and ``\f``.
    """
    c = np.frombuffer(body, dtype=np.uint8)
    blank = (c == 32) | ((c >= 9) & (c <= 13))
    starts = np.flatnonzero(~blank & np.concatenate([[True], blank[:-1]]))
    line = np.searchsorted(np.flatnonzero(c == 10), starts)
    lines, counts = np.unique(line, return_counts=True)
    return counts.astype(np.int64), lines.astype(np.int64)


def _body_numbers(path: Path, body: bytes, n: int) -> NDArray[np.float64]:
    """The ``n`` numbers of an ASCII body, or an error naming the first that is not."""
    vals = _mf()._numbers(body, np.float64, n)
    if vals is None:
        tok = next(t for t in body.split() if _mf()._numbers(t, np.float64, 1) is None)
        raise MeshFileError(f"'{path}' is corrupt: {tok.decode('latin-1')!r} where "
                            "a number should be")
    return vals


def _check_rows(path: Path, body: bytes, first_line: int, fmt: str,
                elements: list[tuple[str, int, list[bool], list[bool]]]
                ) -> tuple[NDArray[np.float64], list[list[NDArray[np.int64]]]]:
    """Check an ASCII body row by row against the elements its header announces.

    ``elements``: (name, count, per property whether it is a list, and whether
    it lists a polygon's corners). Every element is one line; a list property takes its
    length and that many values. Refuses a truncated or padded body, a row with
    too few or too many values and a polygon with fewer than 3 corners.

    Returns the body's numbers and, per element and property, where each
    record's value (a list's length) is among them.
    """
    per_row, line = _rows(body)
    announced = sum(e[1] for e in elements)
    desc = " and ".join(f"{e[1]:,} '{e[0]}'" for e in elements)
    if per_row.shape[0] != announced:
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its {fmt} header announces {desc} "
            f"elements ({announced:,} lines), but {per_row.shape[0]:,} lines of "
            "numbers follow it")
    vals = _body_numbers(path, body, int(per_row.sum()))
    begin = np.cumsum(per_row) - per_row
    row0, where = 0, []
    for name, count, props, polygon_props in elements:
        rows = slice(row0, row0 + count)
        pos, end = begin[rows].copy(), begin[rows] + per_row[rows]
        short = np.zeros(count, dtype=bool)
        where.append([])
        for is_list, polygons in zip(props, polygon_props, strict=True):
            where[-1].append(pos)
            if is_list:
                n = vals[np.minimum(pos, vals.shape[0] - 1)]
                short |= pos >= end
                bad = np.flatnonzero(~short & ((n != np.floor(n)) | (n < 0)
                                               | (polygons & (n < 3))))
                if bad.size:
                    k = int(bad[0])
                    raise MeshFileError(
                        f"'{path}' is corrupt: {fmt} '{name}' {k} (line "
                        f"{first_line + int(line[row0 + k]) + 1}) has a list of "
                        f"{vals[pos[k]]:g} values"
                        + ("; a face needs at least 3 vertices" if polygons else ""))
                pos = pos + 1 + np.where(short, 0, n).astype(np.int64)
            else:
                pos = pos + 1
        wrong = np.flatnonzero(short | (pos != end))
        if wrong.size:
            k = int(wrong[0])
            raise MeshFileError(
                f"'{path}' is truncated or corrupt: {fmt} '{name}' {k} (line "
                f"{first_line + int(line[row0 + k]) + 1}) has "
                f"{int(per_row[row0 + k])} values; its header's properties need "
                f"{int(pos[k] - begin[row0 + k])}")
        row0 += count
    return vals, where


@dataclass
class _Element:
    """A PLY element: its name, record count and properties in record order."""

    name: str
    count: int
    # (name, count type or None for a scalar, value type)
    props: list[tuple[str, str | None, str]] = field(default_factory=list)

    def lists(self) -> list[str]:
        return [name for name, count, _ in self.props if count is not None]


@dataclass
class _Header:
    """A PLY header, checked against the file's size."""

    end: int  # where the body starts
    lines: int
    fmt: str
    elements: list[_Element]
    face: _Element | None
    corners: str | None  # the face's list of vertex indices

    @property
    def binary(self) -> bool:
        return self.fmt in _PLY_ORDER


def _ply_parse(path: Path, data: bytes) -> _Header:
    """Parse a PLY header and check its counts against limits and the file's size."""
    end = re.search(rb"end_header[ \t]*\r?\n", data[: 1 << 20])
    if not data.startswith(b"ply") or end is None:
        raise MeshFileError(f"'{path}' is not a PLY file: no 'ply ... end_header' "
                            f"header{_mf()._utf16_hint(data)}")
    lines = data[: end.end()].decode("latin-1").splitlines()
    fmt = next((ln.split() for ln in lines if ln.startswith("format")), ["", ""])
    fmt += [""] * (2 - len(fmt))
    binary = fmt[1].startswith("binary")
    if binary and fmt[1] not in _PLY_ORDER:
        raise MeshFileError(f"'{path}' is corrupt: unknown PLY format {fmt[1]!r}; "
                            "expected ascii, binary_little_endian or "
                            "binary_big_endian")
    need, elements = 0, []
    for ln in lines:
        w = ln.split()
        if w[:1] == ["element"] and len(w) == 3:
            if not w[2].isdigit():
                raise MeshFileError(f"'{path}' is corrupt: PLY header line {ln!r}")
            elements.append(_Element(w[1], int(w[2])))
        elif w[:1] == ["property"] and elements and len(w) >= 3:
            is_list = w[1] == "list" and len(w) == 5
            if binary and not set(w[2:4] if is_list else w[1:2]) <= _PLY_SIZES.keys():
                raise MeshFileError(f"'{path}' is corrupt: PLY header line {ln!r} has "
                                    "an unknown property type")
            elements[-1].props.append((w[4], w[2], w[3]) if is_list
                                      else (w[2], None, w[1]))
    face = next((e for e in elements if e.name == "face"), None)
    corners = _corners(face) if face is not None and face.count else None
    for el in elements:
        for name, count, value in el.props:
            if name == corners and el is face and not {count, value} <= _PLY_INTS:
                raise MeshFileError(
                    f"'{path}' is corrupt: PLY face list property {name!r} must "
                    f"have integer types (vertex indices); got {count!r} counts "
                    f"and {value!r} values")
            if binary and count is not None and count not in _PLY_INTS:
                raise MeshFileError(f"'{path}' is corrupt: PLY list property {name!r} "
                                    f"must have an integer count type; got {count!r}")
    for el in elements:
        if el.name == "vertex" and el.count > 3 * _mf().MAX_TRIANGLES:
            raise _mf()._too_many(path, el.count, "vertices")
        if el.name == "face" and el.count > _mf().MAX_TRIANGLES:
            raise _mf()._too_many(path, el.count, "faces")
        # a list needs at least its count; a scalar its own size
        need += el.count * sum(_PLY_SIZES.get(c or v, 1) if binary else 2
                               for _, c, v in el.props)
    have = len(data) - end.end()
    if need > have:
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its PLY header announces "
            + " and ".join(f"{e.count:,} '{e.name}'" for e in elements)
            + " elements"
            + f" (at least {need:,} bytes), but {have:,} bytes follow the header"
        )
    return _Header(end.end(), len(lines), fmt[1], elements, face, corners)


def _corners(face: _Element) -> str | None:
    """The face element's list of vertex indices: by name, or its only list.

    None if there is no such list (refused where the faces are read, by
    :func:`_the_corners`).
    """
    named = [n for n in face.lists() if n in _PLY_FACE_NAMES]
    if not named and len(face.lists()) != 1:
        return None
    return (named or face.lists())[0]


def _the_corners(path: Path, h: _Header) -> str:
    """The face element's list of vertex indices, or an error if it has none."""
    if h.face is None or h.corners is None:
        raise MeshFileError(
            f"'{path}': the PLY face element must have one list property of vertex "
            f"indices; got list properties {h.face.lists() if h.face else []}"
        )
    return h.corners


def read_ply_ascii(path: Path, data: bytes, h: _Header) -> Arrays:
    """Vertices (x, y, z) and triangle fans of the faces of an ASCII PLY file.

    The body is checked row by row against the header (:func:`_check_rows`); a
    row is a line, whatever blanks it holds, and blank lines are skipped. An
    element without properties holds nothing (its records are empty lines).
    Values are read as their property's type (a ``float`` is rounded to
    float32, as a binary file stores it); a vertex index must be an integer.
    """
    face = h.face
    kept = [e for e in h.elements if e.props or e is face]
    vals, where = _check_rows(path, data[h.end:], h.lines, "PLY", [
        (e.name, e.count, [c is not None for _, c, _ in e.props],
         [e is face and n == h.corners for n, _, _ in e.props])  # a face's corners
        for e in kept])
    starts = {id(e): at for e, at in zip(kept, where, strict=True)}

    def get(el: _Element, name: str) -> tuple[NDArray[Any], NDArray[np.int64]]:
        j = next(i for i, p in enumerate(el.props) if p[0] == name)
        _, count, value = el.props[j]
        at = starts[id(el)][j]
        if count is None:
            return vals[at].astype(_PLY_TYPES[value]), np.empty(0, np.int64)
        n = vals[at].astype(np.int64)
        items = vals[_list_items(at + 1, n, 1)]
        _integers(path, "PLY face", items, n)
        return items.astype(np.int64), n

    return _assemble(path, h, get)


def _list_items(first: NDArray[np.int64], n: NDArray[np.int64],
                size: int) -> NDArray[np.int64]:
    """Where list items are: ``n[k]`` items from ``first[k]``, ``size`` apart."""
    start = first - (np.cumsum(n) - n) * size  # minus the earlier lists' items
    return np.repeat(start, n) + np.arange(int(n.sum()), dtype=np.int64) * size


def _integers(path: Path, what: str, items: NDArray[np.float64],
              n: NDArray[np.int64]) -> None:
    """Refuse a vertex index that is not an integer (lists of ``n`` items)."""
    bad = np.flatnonzero(items != np.floor(items))
    if bad.size:
        k = int(np.searchsorted(np.cumsum(n), bad[0], side="right"))
        raise MeshFileError(f"'{path}' is corrupt: {what} {k} has vertex index "
                            f"{items[bad[0]]:g}; indices are integers")


def _assemble(path: Path, h: _Header, get: Callable[
        [_Element, str], tuple[NDArray[Any], NDArray[np.int64]]]) -> Arrays:
    """Vertices and triangle fans of a PLY file.

    ``get(element, property)`` gives a property's values (lists in a row) and
    list lengths.
    """
    v, f = np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    for el in h.elements:
        if el.name == "vertex" and el.count and not v.shape[0]:
            names = [p[0] for p in el.props if p[1] is None]
            missing = [a for a in "xyz" if a not in names]
            if missing:
                raise MeshFileError(f"'{path}' is corrupt: the PLY vertex element "
                                    f"has no {' or '.join(missing)} property")
            v = np.stack([get(el, a)[0].astype(np.float64) for a in "xyz"], axis=1)
        elif el is h.face and el.count:
            idx, counts = get(el, _the_corners(path, h))
            f = _fans(path, counts, idx)
    return v, f


def _fans(path: Path, counts: NDArray[np.int64], corners: NDArray[Any]) -> NDArray[
        np.int64]:
    """:func:`fan_triangles`, once their number is checked against the limit."""
    n_tri = int(counts.sum()) - 2 * counts.shape[0]
    if n_tri > _mf().MAX_TRIANGLES:
        raise _mf()._too_many(path, n_tri)
    return fan_triangles(counts, corners.astype(np.int64))


# --------------------------------------------------------------------------
# binary PLY: read here (trimesh reads every list with the first one's length)
# --------------------------------------------------------------------------


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


def fan_triangles(counts: NDArray[np.int64], corners: NDArray[np.int64]) -> NDArray[
        np.int64]:
    """Triangle fans of polygons: ``counts[k]`` corners each, in a row in ``corners``.

    Polygon ``c0 .. c(n-1)`` gives ``(c0, cj, cj+1)`` for ``j = 1 .. n - 2``;
    every count is at least 3.
    """
    if counts.shape[0] and counts.min() == counts.max() == 3:
        return corners.reshape(-1, 3)  # triangles already
    first = np.cumsum(counts) - counts
    n_tri = counts - 2
    tri_face = np.repeat(np.arange(counts.shape[0]), n_tri)
    j = np.arange(tri_face.shape[0]) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)
    base = first[tri_face]
    return np.stack([corners[base], corners[base + j + 1], corners[base + j + 2]],
                    axis=1)


_OFF_COMMENT = re.compile(rb"#[^\n]*")
_OFF_COUNTS = re.compile(
    rb"\s*[A-Z]*OFF\s+(\d+)[ \t\r]+(\d+)(?:[ \t\r]+\d+)?[ \t\r]*(?:\n|\Z)")


def read_off(path: Path, data: bytes) -> Arrays:
    """Vertices and triangle fans of the faces of an OFF file.

    Comments (``#`` to the end of the line) may stand anywhere, also before the
    ``OFF`` line. Every vertex line must hold at least 3 numbers (x, y, z; more,
    such as colours, are ignored) and every face line a corner count of at
    least 3 and that many integer indices (colours may follow); the lines must
    be as many as announced. A line ends at a line feed only.
    """
    text = _OFF_COMMENT.sub(b"", data) if b"#" in data else data
    m = _OFF_COUNTS.match(text)
    if m is None:
        raise MeshFileError(f"'{path}' is not an OFF file: no 'OFF' line followed "
                            f"by the vertex and face counts{_mf()._utf16_hint(data)}")
    nv, nf = int(m.group(1)), int(m.group(2))
    if nf > _mf().MAX_TRIANGLES:
        raise _mf()._too_many(path, nf, "faces")
    need = 6 * nv + 8 * nf  # "0 0 0\n" per vertex, "3 0 1 2\n" per face
    if need > len(data):
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its OFF header announces "
            f"{nv:,} vertices and {nf:,} faces (at least {need:,} bytes), but "
            f"the file has {len(data):,} bytes"
        )
    body = text[m.end():]
    per_row, _ = _rows(body)
    if per_row.shape[0] != nv + nf:
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its OFF header announces {nv:,} "
            f"vertices and {nf:,} faces ({nv + nf:,} lines), but "
            f"{per_row.shape[0]:,} lines of numbers follow it")
    vals = _body_numbers(path, body, int(per_row.sum()))
    begin = np.cumsum(per_row) - per_row
    short = np.flatnonzero(per_row[:nv] < 3)
    if short.size:
        k = int(short[0])
        raise MeshFileError(f"'{path}' is corrupt: OFF vertex {k} has "
                            f"{int(per_row[k])} numbers; it needs 3")
    n = vals[begin[nv:]]
    bad = np.flatnonzero((n != np.floor(n)) | (n < 3) | (n + 1 > per_row[nv:]))
    if bad.size:
        k = int(bad[0])
        raise MeshFileError(
            f"'{path}' is corrupt: OFF face {k} has {int(per_row[nv + k])} numbers "
            f"and announces {n[k]:g} corners; a face needs at least 3 corners "
            "and one index per corner")
    counts = n.astype(np.int64)
    corners = vals[_list_items(begin[nv:] + 1, counts, 1)]
    _integers(path, "OFF face", corners, counts)
    v = vals[begin[:nv, None] + np.arange(3)]
    return v.reshape(-1, 3), _fans(path, counts, corners)
