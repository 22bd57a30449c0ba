"""ASCII PLY and OFF files: their headers and bodies checked before trimesh parses them.

A header's counts are checked against the file's size, and an ASCII body row by
row against them (rows, values per row, list lengths), so a truncated or lying
file is refused instead of loading as part of a mesh. Used by
:mod:`vecslice.meshfile`, whose limits and messages these checks share.
"""

from __future__ import annotations

import re
from pathlib import Path
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import MeshFileError

__all__: list[str] = []


def _mf() -> ModuleType:
    """:mod:`vecslice.meshfile` (imported when called: it imports this module)."""
    from vecslice import meshfile

    return meshfile


_PLY_SIZES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2,
    "int16": 2, "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4,
    "float": 4, "float32": 4, "double": 8, "float64": 8,
}
_PLY_FACE_NAMES = ("vertex_indices", "vertex_index")


_PLY_INTS = {"char", "uchar", "int8", "uint8", "short", "ushort", "int16", "uint16",
             "int", "uint", "int32", "uint32"}


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
                elements: list[tuple[str, int, list[bool], list[bool]]]) -> None:
    """Check an ASCII body row by row against the elements its header announces.

    ``elements``: (name, count, per property whether it is a list, and whether
    it lists a polygon's corners). Every element is one line; a list property takes its
    length and that many values. Refuses a truncated or padded body, a row with
    too few or too many values and a polygon with fewer than 3 corners.
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
    row0 = 0
    for name, count, props, polygon_props in elements:
        rows = slice(row0, row0 + count)
        pos, end = begin[rows].copy(), begin[rows] + per_row[rows]
        short = np.zeros(count, dtype=bool)
        for is_list, polygons in zip(props, polygon_props, strict=True):
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


def _ply_header(path: Path, data: bytes) -> bytes:
    """Check a PLY header against the file's size; returns the bytes to parse.

    An ASCII body is checked row by row against the header (:func:`_check_rows`);
    face vertex indices must have an integer type. A face element with one list
    property under another name than ``vertex_indices``/``vertex_index`` gets
    that name, so it loads.
    """
    end = re.search(rb"end_header[ \t]*\r?\n", data[: 1 << 20])
    if not data.startswith(b"ply") or end is None:
        raise MeshFileError(f"'{path}' is not a PLY file: no 'ply ... end_header' "
                            f"header{_mf()._utf16_hint(data)}")
    lines = data[: end.end()].decode("latin-1").splitlines()
    fmt = next((ln.split() for ln in lines if ln.startswith("format")), ["", ""])
    binary = fmt[1].startswith("binary")
    need, elements = 0, []
    for ln in lines:
        w = ln.split()
        if w[:1] == ["element"] and len(w) == 3:
            if not w[2].isdigit():
                raise MeshFileError(f"'{path}' is corrupt: PLY header line {ln!r}")
            elements.append([w[1], int(w[2]), 0, [], []])
        elif w[:1] == ["property"] and elements and len(w) >= 3:
            el = elements[-1]
            is_list = w[1] == "list" and len(w) == 5
            # a list needs at least its count; a scalar its own size
            size = _PLY_SIZES.get(w[2] if is_list else w[1], 1)
            el[2] += size if binary else 2
            el[4].append(w[4] if is_list else None)
            if is_list:
                el[3].append(w[4])
                if el[0] == "face" and not {w[2], w[3]} <= _PLY_INTS:
                    raise MeshFileError(
                        f"'{path}' is corrupt: PLY face list property {w[4]!r} must "
                        f"have integer types (vertex indices); got {w[2]!r} counts "
                        f"and {w[3]!r} values")
    for name, count, per_item, _, _ in elements:
        if name == "vertex" and count > 3 * _mf().MAX_TRIANGLES:
            raise _mf()._too_many(path, count, "vertices")
        if name == "face" and count > _mf().MAX_TRIANGLES:
            raise _mf()._too_many(path, count, "faces")
        need += count * per_item
    have = len(data) - end.end()
    if need > have:
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its PLY header announces "
            + " and ".join(f"{e[1]:,} '{e[0]}'" for e in elements)
            + " elements"
            + f" (at least {need:,} bytes), but {have:,} bytes follow the header"
        )
    face = next((e for e in elements if e[0] == "face"), None)
    named = face is not None and any(n in face[3] for n in _PLY_FACE_NAMES)
    if not binary:  # the list of vertex indices: a face's corners
        _check_rows(path, data[end.end():], len(lines), "PLY", [
            (e[0], e[1], [p is not None for p in e[4]],
             [e is face and (p in _PLY_FACE_NAMES if named else
                             p is not None and len(e[3]) == 1)
              for p in e[4]]) for e in elements])
    if face is None or face[1] == 0 or named:
        return data
    if len(face[3]) != 1:
        raise MeshFileError(
            f"'{path}': the PLY face element must have one list property of vertex "
            f"indices; got list properties {face[3]}"
        )
    old = face[3][0].encode()
    header = re.sub(rb"(property[ \t]+list[ \t]+\S+[ \t]+\S+[ \t]+)" + re.escape(old)
                    + rb"([ \t]*\r?\n)", rb"\1vertex_indices\2", data[: end.end()])
    return header + data[end.end():]


_OFF_COMMENT = re.compile(rb"#[^\n]*")
_OFF_COUNTS = re.compile(
    rb"\s*[A-Z]*OFF\s+(\d+)[ \t\r]+(\d+)(?:[ \t\r]+\d+)?[ \t\r]*(?:\n|\Z)")


def _off_header(path: Path, data: bytes) -> bytes:
    """Refuse an OFF file whose body does not hold what its header announces.

    Comments (``#`` to the end of the line) may stand anywhere, also before the
    ``OFF`` line. Every vertex line must hold at least 3 numbers and every face
    line a corner count of at least 3 and that many indices (colours may
    follow); the lines must be as many as announced.
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
    return data
