"""PLY and OFF files, read here: headers checked against the file, then the body.

A header's counts are checked against the file's size, and an ASCII body row by
row against them (rows, values per row, list lengths), so a truncated or lying
file is refused instead of loading as part of a mesh; the numbers those checks
parsed are then the mesh. A binary PLY body is walked record by record through
its list counts (:mod:`vecslice.plybinary`). Faces of any corner count load as
triangle fans. (trimesh read these once: it reads every binary list with the
first one's length, and splits ASCII rows at characters that are not line ends,
so some files loaded wrong.)
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
_COUNT = re.compile(r"[0-9]{1,18}")  # ASCII digits ("²" is a digit to isdigit)


def _words(line: str) -> list[str]:
    """A header line's words, split at ASCII blanks only (as the body's numbers)."""
    return [w for w in _BLANKS.split(line) if w]


_BLANKS = re.compile(r"[ \t\r\v\f]+")


def _shown(line: str) -> str:
    """A header line (read as Latin-1) for a message, quoted, cut at 80 characters.

    Its bytes are shown as UTF-8 where they are.
    """
    text = line.encode("latin-1").decode("utf-8", "backslashreplace")
    return repr(text[:80]) + ("..." if len(text) > 80 else "")


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


def _body_numbers(path: Path, body: bytes, n: int,
                  first_line: int) -> NDArray[np.float64]:
    """The ``n`` numbers of an ASCII body, or an error naming the first that is not.

    ``first_line``: the lines before the body (for the message).
    """
    vals = _mf()._numbers(body, np.float64, n)
    if vals is None:
        at, tok = _first_non_number(body)
        line = first_line + body.count(b"\n", 0, at) + 1
        raise MeshFileError(
            f"'{path}' is corrupt: {_mf()._quoted(tok[:40])} where a number "
            f"should be (line {line})")
    return vals


def _first_non_number(body: bytes) -> tuple[int, bytes]:
    """Where the first token of ``body`` that is not a number is, and it.

    Found by halving: the tokens before the middle one are parsed at once, and
    the search goes on in the half that fails; about two parses of the body in
    all, whatever its size (one parse per token took minutes).
    """
    c = np.frombuffer(body, dtype=np.uint8)
    blank = (c == 32) | ((c >= 9) & (c <= 13))
    starts = np.flatnonzero(~blank & np.concatenate([[True], blank[:-1]]))
    ends = np.flatnonzero(~blank & np.concatenate([blank[1:], [True]])) + 1
    lo, hi = 0, len(starts)  # the first bad token is in [lo, hi)
    nul = np.flatnonzero(c == 0)  # numpy's parser stops at a NUL, as at an end
    if nul.size:
        hi = int(np.searchsorted(starts, nul[0], side="right"))
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if _mf()._numbers(body[starts[lo]:ends[mid - 1]], np.float64, mid - lo) is None:
            hi = mid
        else:
            lo = mid
    return (int(starts[lo]), body[starts[lo]:ends[lo]]) if len(starts) else (0, b"")


def _num(x: float) -> str:
    """A number read from a file, for a message: as written, if it was whole."""
    if x == np.floor(x) and abs(x) < 1e18:
        return str(int(x))
    return repr(float(x))


def _check_rows(path: Path, body: bytes, first_line: int, fmt: str,
                elements: list[tuple[str, int, list[bool], list[bool]]]
                ) -> tuple[NDArray[np.float64], list[_Rows]]:
    """Check an ASCII body row by row against the elements its header announces.

    ``elements``: (name, count, per property whether it is a list, and whether
    it lists a polygon's corners). Every element is one line; a list property takes its
    length and that many values. Refuses a truncated or padded body, a row with
    too few or too many values and a polygon with fewer than 3 corners.

    Returns the body's numbers and, per element, where each property's value
    (a list's length) of each record is among them, and the records' lines.
    """
    per_row, line = _rows(body)
    announced = sum(e[1] for e in elements)
    desc = " and ".join(f"{e[1]:,} '{e[0]}'" for e in elements)
    if per_row.shape[0] != announced:
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its {fmt} header announces {desc} "
            f"elements ({announced:,} lines), but {per_row.shape[0]:,} lines of "
            "numbers follow it")
    vals = _body_numbers(path, body, int(per_row.sum()), first_line)
    begin = np.cumsum(per_row) - per_row
    row0, where = 0, []
    for name, count, props, polygon_props in elements:
        rows = slice(row0, row0 + count)
        pos, end = begin[rows].copy(), begin[rows] + per_row[rows]
        short = np.zeros(count, dtype=bool)
        where.append(_Rows([], first_line + line[rows] + 1))
        for is_list, polygons in zip(props, polygon_props, strict=True):
            where[-1].at.append(pos)
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
                        f"{_num(vals[pos[k]])} values"
                        + ("; a list's length is a whole number >= 0"
                           if n[k] != np.floor(n[k]) or n[k] < 0 else
                           "; a face needs at least 3 vertices"))
                # a list longer than its row (up to 1e308) ends past the row
                pos = pos + 1 + np.where(short, 0, np.minimum(n, end - pos)).astype(
                    np.int64)
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
class _Rows:
    """An ASCII element's records: where each property's value is, their lines."""

    at: list[NDArray[np.int64]]
    line: NDArray[np.int64]


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
    # the line that is end_header (a comment may end with the word)
    end = re.search(rb"\nend_header[ \t]*\r?\n", data[: 1 << 20])
    if not data.startswith(b"ply") or end is None:
        raise MeshFileError(f"'{path}' is not a PLY file: no 'ply ... end_header' "
                            f"header{_mf()._utf16_hint(data)}")
    # lines end at line feeds only, as in the body (not at \f, \v or \x85)
    lines = data[: end.end()].decode("latin-1").split("\n")[:-1]
    fmt, elements = _ply_lines(path, lines)
    binary = fmt in _PLY_ORDER
    face = next((e for e in elements if e.name == "face"), None)
    corners = _corners(face) if face is not None and face.count else None
    for el in elements:
        for name, count, value in el.props:
            if name == corners and el is face and not {count, value} <= _PLY_INTS:
                raise MeshFileError(
                    f"'{path}' is corrupt: PLY face list property {name!r} must "
                    f"have integer types (vertex indices); got {count!r} counts "
                    f"and {value!r} values")
            if count is not None and count not in _PLY_INTS:
                raise MeshFileError(f"'{path}' is corrupt: PLY list property {name!r} "
                                    f"must have an integer count type; got {count!r}")
    need = 0
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
        listed = [f"{e.count:,} '{e.name}'" for e in elements[:4]]
        if len(elements) > 4:
            listed.append(f"{len(elements) - 4:,} more")
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its PLY header announces "
            + " and ".join(listed) + " elements"
            + f" (at least {need:,} bytes), but {have:,} bytes follow the header"
        )
    return _Header(end.end(), len(lines), fmt, elements, face, corners)


_PLY_EXPECTED = {
    "format": "'format ascii|binary_little_endian|binary_big_endian VERSION'",
    "element": "'element NAME COUNT'",
    "property": "'property TYPE NAME' or 'property list COUNT_TYPE VALUE_TYPE NAME'",
}


def _ply_lines(path: Path, lines: list[str]) -> tuple[str, list[_Element]]:
    """The format and elements the lines of a PLY header declare (``ply`` .. end).

    Every line is ``format``, ``element``, ``property``, ``comment`` or
    ``obj_info`` (the last two hold anything), or blank; any other line, or one
    of the first three with other words than its syntax, is refused by number
    (such lines were skipped: a misspelt property left a column unread).
    """
    fmt, elements = "", []

    def bad(i: int, why: str) -> MeshFileError:
        return MeshFileError(f"'{path}' is corrupt: PLY header line "
                             f"{_shown(lines[i])} (line {i + 1}): {why}")

    if _words(lines[0]) != ["ply"]:
        raise bad(0, "the first line is 'ply'")
    for i, ln in enumerate(lines[1:-1], 1):
        w = _words(ln)
        if not w or w[0] in ("comment", "obj_info"):
            continue
        if w[0] not in _PLY_EXPECTED:
            raise bad(i, "expected 'format', 'element', 'property', 'comment' or "
                      "'obj_info'")
        if len(w) != (5 if w[0] == "property" and w[1:2] == ["list"] else 3):
            raise bad(i, f"expected {_PLY_EXPECTED[w[0]]}")
        if w[0] == "format":
            if fmt:
                raise bad(i, "a second 'format' line")
            if w[1] != "ascii" and w[1] not in _PLY_ORDER:
                raise MeshFileError(f"'{path}' is corrupt: unknown PLY format "
                                    f"{w[1]!r}; expected ascii, binary_little_endian "
                                    "or binary_big_endian")
            fmt = w[1]
        elif w[0] == "element":
            if not _COUNT.fullmatch(w[2]):
                raise MeshFileError(f"'{path}' is corrupt: PLY header line "
                                    f"{_shown(ln)}: the count must be a whole "
                                    "number below 10**18")
            elements.append(_Element(w[1], int(w[2])))
        else:
            if not elements:
                raise bad(i, "a property before any element")
            is_list = len(w) == 5
            if not set(w[2:4] if is_list else w[1:2]) <= _PLY_SIZES.keys():
                raise MeshFileError(f"'{path}' is corrupt: PLY header line "
                                    f"{_shown(ln)} has an unknown property type")
            elements[-1].props.append((w[4], w[2], w[3]) if is_list
                                      else (w[2], None, w[1]))
    if not fmt:
        raise MeshFileError(f"'{path}' is corrupt: the PLY header has no 'format' "
                            "line")
    return fmt, elements


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
    starts = {id(e): rows for e, rows in zip(kept, where, strict=True)}

    def get(el: _Element, name: str) -> tuple[NDArray[Any], NDArray[np.int64]]:
        j = next(i for i, p in enumerate(el.props) if p[0] == name)
        _, count, value = el.props[j]
        rows = starts[id(el)]
        at = rows.at[j]
        if count is None:
            x = vals[at]
            if value in _PLY_INTS:  # a whole number its type holds, as in binary
                lim = np.iinfo(_PLY_TYPES[value])
                bad = np.flatnonzero((x != np.floor(x)) | (x < lim.min) | (x > lim.max))
                if bad.size:
                    k = int(bad[0])
                    raise MeshFileError(
                        f"'{path}' is corrupt: PLY '{el.name}' {k} (line "
                        f"{int(rows.line[k])}) has {name} = {_num(x[k])}, which its "
                        f"type {value} cannot hold")
            return x.astype(_PLY_TYPES[value]), np.empty(0, np.int64)
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
    """Refuse a vertex index that is not an integer (lists of ``n`` items).

    Or one of 2**53 or more, which a double does not hold exactly (and no file
    has that many vertices).
    """
    bad = np.flatnonzero((items != np.floor(items)) | ~(np.abs(items) < 2.0**53))
    if bad.size:
        k = int(np.searchsorted(np.cumsum(n), bad[0], side="right"))
        x = items[bad[0]]
        why = "indices are integers" if x != np.floor(x) else "beyond any vertex"
        raise MeshFileError(f"'{path}' is corrupt: {what} {k} has vertex index "
                            f"{_num(x)}; {why}")


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
    rb"\s*[A-Z]*OFF\s+(\d{1,18})[ \t\r]+(\d{1,18})(?:[ \t\r]+\d+)?[ \t\r]*(?:\n|\Z)")


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
    vals = _body_numbers(path, body, int(per_row.sum()),
                         text.count(b"\n", 0, m.end()))
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
            f"and announces {_num(n[k])} corners; a face needs at least 3 corners "
            "and one index per corner")
    counts = n.astype(np.int64)
    corners = vals[_list_items(begin[nv:] + 1, counts, 1)]
    _integers(path, "OFF face", corners, counts)
    v = vals[begin[:nv, None] + np.arange(3)]
    return v.reshape(-1, 3), _fans(path, counts, corners)
