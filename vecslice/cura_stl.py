r"""CuraEngine's STL reading and vertex melding: ``load_mesh(..., compat="cura")``.

Follows ``spec/CURA_COMPAT.md`` section 2 (CuraEngine 07475e3, its ``loadMeshSTL``,
``Mesh::addFace`` and ``Mesh::finish``), written from that description:

* **Detection.** Leading whitespace is skipped; if the next 5 bytes are "solid"
  (any case) the file is read as ASCII, and if that gives no triangle, as binary.
* **ASCII.** Lines end at ``\n`` or ``\r``; a line is a vertex if it matches
  ``sscanf(" vertex %f %f %f")``: optional whitespace, the word ``vertex`` and three
  C floating-point numbers (decimal, hexadecimal, ``inf``, ``nan``), each read as
  glibc's ``%f`` reads it and rounded once to the nearest **float32** (see
  :mod:`vecslice._cfloat`: ``1.5e`` is 1.5, ``1-2`` is two numbers, ``123`` is
  never two). Every 3 vertices form a triangle; text after the third number is
  ignored.
* **Binary.** 80-byte header, a uint32 count, 50-byte records (normal, 9 float32,
  2 bytes). The number of records comes from the file size; a count that differs
  is warned about (:class:`vecslice.VecsliceWarning`).
* **Conversion.** ``MM2INT(v * scale)`` in double: ``trunc(x * 1000 + 0.5 *
  sign(x))``, i.e. round half away from zero after the double products.
* **Melding.** A corner reuses the first earlier vertex (in creation order) of its
  30 µm hash cell within 30 µm (``|d| <= 30`` per axis and ``d.d <= 900``); two
  vertices 1 µm apart across a cell boundary stay apart. Otherwise it creates a
  vertex. See :func:`vecslice._kernels.cura_mesh.meld_corners`.
* **Faces.** A triangle with two equal vertex indices is dropped (its vertices stay,
  as in CuraEngine, and count for the bounding box). Nothing else is repaired:
  winding, duplicates, holes and non-manifold edges are kept as in the file.

Interpretations: numbers are read as glibc 2.36's ``sscanf`` and ``strtof`` read
them (x86-64 Linux, the "C" locale), which the tests check against the C library.
The mesh is not moved: CuraEngine's ``MeshGroup::finalize`` (bed centring,
``center_object``) is outside the slicer, and vecslice measures layers from the
mesh's lowest point anyway.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from vecslice._cfloat import SCANF_FLOAT, strtof
from vecslice._kernels.cura_mesh import group_cells, meld_corners
from vecslice._threads import run_chunks
from vecslice.errors import (
    InputTypeError,
    InputValueError,
    MeshFileError,
    VecsliceWarning,
)
from vecslice.units import COORD_LIMIT

__all__ = ["MELD_DISTANCE", "cura_mesh_from_corners", "load_mesh_cura", "mm2int"]

MELD_DISTANCE = 30
"""CuraEngine's ``vertex_meld_distance`` = MM2INT(0.03) µm."""

_WS = rb"[ \t\v\f]*"  # isspace() within one line (lines end at \n and \r)
# each number as an atomic group (a lookahead's match, taken whole): it is never
# split to make the line match
_VERTEX = re.compile(
    rb"^" + _WS + rb"vertex" + b"".join(
        _WS + rb"(?=(?P<n%d>" % i + SCANF_FLOAT + rb"))(?P=n%d)" % i
        for i in range(3)),
    re.MULTILINE,
)
_SPACE = b" \t\n\v\f\r"
_RECORD = np.dtype([("normal", "<f4", 3), ("v", "<f4", 9), ("attr", "<u2")])

_to_float32 = strtof  # C float tokens to float32, as strtof rounds them


def _parse_ascii(path: Path, data: bytes) -> NDArray[np.float32]:
    """The ``vertex`` values of an ASCII STL, (N, 3) float32 in file order."""
    text = data.replace(b"\r", b"\n")
    rows = _VERTEX.findall(text)  # (x, y, z) per line
    _check_count(path, len(rows) // 3)
    return _to_float32([t for m in rows for t in m]).reshape(-1, 3)


def _check_count(path: Path, n: int) -> None:
    """Refuse more than :data:`vecslice.meshfile.MAX_TRIANGLES` triangles."""
    from vecslice import meshfile

    if n > meshfile.MAX_TRIANGLES:
        raise meshfile._too_many(path, n)


def _parse_binary(path: Path, data: bytes) -> tuple[NDArray[np.float32], str]:
    """The corners of a binary STL, (3F, 3) float32 (F from the file size).

    Also returns a warning to give if the header's count differs (else empty).
    """
    if len(data) < 84:
        raise MeshFileError(
            f"'{path}' is not an STL file: {_short_binary(data)}")
    n = (len(data) - 84) // 50
    _check_count(path, n)
    announced = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    warning = ""
    if announced != n:
        warning = (f"'{path}': the binary STL header announces {announced} "
                   f"triangles; the file size gives {n} (reading {n}, as CuraEngine "
                   "does)")
    rec = np.frombuffer(data, dtype=_RECORD, count=n, offset=84)
    return np.ascontiguousarray(rec["v"]).reshape(-1, 3), warning


def _short_binary(data: bytes) -> str:
    return f"a binary STL needs an 84-byte header; the file has {len(data)} bytes"


_LINE_BREAK = re.compile(rb"\r\n|\r|\n")
_VERTEX_WORD = re.compile(rb"^" + _WS + rb"vertex", re.MULTILINE | re.IGNORECASE)


def _line_number(data: bytes, at: int) -> int:
    """The line (from 1) of byte ``at``; lines end at CR LF, CR or LF."""
    return len(_LINE_BREAK.findall(data, 0, at)) + 1


def _vertex_line(data: bytes, k: int) -> int:
    """The line of an ASCII STL's vertex ``k`` (0-based, in file order)."""
    for i, m in enumerate(_VERTEX.finditer(data.replace(b"\r", b"\n"))):
        if i == k:
            return _line_number(data, m.start())
    return 0


def _why_not_ascii(data: bytes, n_vertices: int) -> str:
    """Why a file beginning with ``solid`` gave CuraEngine no ASCII triangle."""
    why = []
    if n_vertices:
        why.append(f"it has {n_vertices} vertex line{'s' if n_vertices > 1 else ''}, "
                   "fewer than a triangle's 3")
    text = data.replace(b"\r", b"\n")
    for m in _VERTEX_WORD.finditer(text):
        if _VERTEX.match(text, m.start()):
            continue
        end = text.find(b"\n", m.start())
        line = text[m.start():end if end >= 0 else len(text)].strip()
        shown = line[:60].decode("latin-1") + ("..." if len(line) > 60 else "")
        at = _line_number(data, m.start())
        if line.startswith(b"vertex"):
            why.append(f"line {at} ({shown!r}) is not 'vertex' and three numbers as "
                       "CuraEngine reads them (sscanf \" vertex %f %f %f\")")
        else:
            why.append(f"its vertex lines are not in lower case (line {at}: "
                       f"{shown!r}); CuraEngine reads only 'vertex' (compat='vecslice' "
                       "any case)")
        break
    return "; ".join(why) or "no line starts with 'vertex'"


class StlCorners(NamedTuple):
    """What :func:`read_stl_corners` read."""

    corners: NDArray[np.float32]
    """(3F, 3): the triangle corners in file order."""
    data: bytes
    """The file's bytes."""
    ascii: bool
    """Read as an ASCII STL."""
    not_ascii: str
    """Why a file that begins with ``solid`` gave no ASCII triangle (then it was
    read as binary, as CuraEngine does); empty for other files."""
    warning: str
    """A binary STL's count that differs from its size, to warn about; or empty."""


def read_stl_corners(path: Path) -> StlCorners:
    """Triangle corners of an STL file as CuraEngine reads them, (3F, 3) float32.

    Raises
    ------
    MeshFileError
        If the file is missing, a symbolic link loop, a directory, not a regular
        file (a pipe or a device such as /dev/zero, which would never end),
        unreadable, too short for its type (a file beginning with ``solid``
        whose ASCII gives no triangle: for both types, with the reason for each),
        or holds more than :data:`vecslice.meshfile.MAX_TRIANGLES` triangles.
    """
    from vecslice.meshfile import _check_path

    _check_path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MeshFileError(f"cannot read '{path}': {exc}") from exc
    body = data.lstrip(_SPACE)
    if len(body) < 5:
        raise MeshFileError(
            f"'{path}' is not an STL file: fewer than 5 bytes after leading "
            f"whitespace (got {len(body)})"
        )
    if body[:5].lower() != b"solid":
        corners, warning = _parse_binary(path, data)
        return StlCorners(corners, data, False, "", warning)
    v = _parse_ascii(path, data)
    n = v.shape[0] - v.shape[0] % 3
    if n:
        return StlCorners(v[:n], data, True, "", "")
    why = _why_not_ascii(data, v.shape[0])
    if len(data) < 84:
        raise _no_triangles(path, why, _short_binary(data))
    corners, warning = _parse_binary(path, data)
    return StlCorners(corners, data, False, why, warning)


def _no_triangles(path: Path, why: str, binary: str) -> MeshFileError:
    """A file beginning with ``solid`` that neither type reads: both reasons."""
    return MeshFileError(
        f"'{path}' holds no triangles. As ASCII (it begins with 'solid'): {why}. "
        f"As binary (CuraEngine's fallback): {binary}")


def mm2int(
    mm: NDArray[Any], name: str = "vertices",
    where: Callable[[int], str] = lambda c: f"corner {c} (triangle {c // 3})",
) -> NDArray[np.int64]:
    """CuraEngine's ``MM2INT`` in double: ``trunc(x * 1000 + 0.5 * sign(x))``.

    ``mm`` holds the corners (3F, 3); ``where(c)`` describes corner ``c`` in a
    message (e.g. naming the file and the line).

    Raises
    ------
    InputValueError
        If a value is NaN or infinite or reaches 2**30 µm in magnitude.

    Examples
    --------
    >>> mm2int(np.array([0.0005, -0.0005, 1.25])).tolist()
    [1, -1, 1250]
    """
    x = np.asarray(mm, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(x.ravel()))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`{name}` must be finite; got {float(x.ravel()[i])} at {where(i // 3)}")
    um = np.trunc(x * 1000.0 + 0.5 * np.sign(x))
    big = np.flatnonzero(np.abs(um.ravel()) >= COORD_LIMIT)
    if big.size:
        i = int(big[0])
        raise InputValueError(
            f"`{name}` must be below {COORD_LIMIT / 1000:g} mm in magnitude (2**30 "
            f"µm); got {float(x.ravel()[i])!r} mm at {where(i // 3)}")
    return um.astype(np.int64)


def meld(corners_um: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Meld corners (3F, 3) µm into ``(vertices, corner_vertex)``, CuraEngine's way.

    Vertices come in creation order (the file order of the corner that created
    each); ``corner_vertex[i]`` is the vertex corner ``i`` uses.

    Examples
    --------
    14 and 15 µm are 1 µm apart across a cell boundary (not melded); 15 and 44 µm
    share a cell and are 29 µm apart (melded):

    >>> v, cv = meld(np.array([[14, 0, 0], [15, 0, 0], [44, 0, 0]]))
    >>> v.tolist(), cv.tolist()
    ([[14, 0, 0], [15, 0, 0]], [0, 1, 1])
    """
    c = np.ascontiguousarray(corners_um, dtype=np.int64)
    n = c.shape[0]
    # in short chunks of linear work (a lexsort of 3 million corners took 2.6 s,
    # during which Ctrl-C waited)
    order, cell_offsets = group_cells(c, MELD_DISTANCE, run=run_chunks)
    rep = meld_corners(c, order, cell_offsets, MELD_DISTANCE, run=run_chunks)
    created = rep == np.arange(n, dtype=np.int64)
    new_id = np.cumsum(created, dtype=np.int64) - 1
    return np.ascontiguousarray(c[created]), new_id[rep]


def cura_mesh_from_corners(corners_um: NDArray[np.int64], source: str) -> Any:
    """A :class:`vecslice.Mesh` from triangle corners (3F, 3) µm in file order.

    Melds the corners (:func:`meld`) and drops triangles with two equal vertex
    indices; vertices, faces and their order are CuraEngine's.

    Raises
    ------
    InputValueError
        If no triangle is left.

    Examples
    --------
    The second triangle's corners 0 and 10 µm meld, so it is dropped; its third
    vertex stays:

    >>> m = cura_mesh_from_corners(np.array(
    ...     [[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 0], [10, 0, 0],
    ...      [0, 0, 1000]]), "example")
    >>> m.faces.tolist(), m.n_vertices, m.load_info.faces_degenerate
    ([[0, 1, 2]], 4, 1)
    """
    from vecslice.mesh import LoadInfo, Mesh

    vertices, corner_vertex = meld(corners_um)
    f = corner_vertex.reshape(-1, 3)
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    faces = np.ascontiguousarray(f[keep])
    n_in = int(f.shape[0])
    if faces.shape[0] == 0:
        raise InputValueError(
            f"`faces` must hold at least one non-degenerate triangle after "
            f"CuraEngine's 30 µm melding; all {n_in} triangles of {source} collapse"
        )
    info = LoadInfo(
        source, n_in, 3 * n_in,
        vertices_merged=3 * n_in - int(vertices.shape[0]),
        faces_degenerate=n_in - int(faces.shape[0]),
    )
    mesh = Mesh._trusted(vertices, faces, info)
    # CuraEngine's bounding box: every vertex came with a face, dropped or not
    # (the schedules measure the model from it: Mesh._corner_zrange)
    object.__setattr__(mesh, "_zcorners", mesh.zrange)
    return mesh


def load_mesh_cura(source: Any, scale: float) -> Any:
    """``load_mesh(source, scale=scale, compat="cura")``; see :func:`load_mesh`.

    STL files are read as CuraEngine reads them (float32 values). A trimesh
    object's triangles are taken corner by corner in face order (float64 values,
    what CuraEngine would see if the file held them exactly). Other file types
    raise :class:`MeshFileError`: CuraEngine itself reads only STL.
    """
    import trimesh

    from vecslice.mesh import _as_faces
    from vecslice.meshfile import _check_path, _scene_arrays

    if isinstance(source, trimesh.Trimesh):
        name = "trimesh.Trimesh"
        v = np.asarray(source.vertices, dtype=np.float64)
        f = np.asarray(source.faces, dtype=np.int64).reshape(-1, 3)
        if f.shape[0]:  # trimesh(process=False) keeps any index: check as
            f = _as_faces(f, v.shape[0])  # compat='vecslice' does
        corners = v[f.reshape(-1)]
    elif isinstance(source, trimesh.Scene):
        name = "trimesh.Scene"
        v, f = _scene_arrays(source)
        corners = np.asarray(v, dtype=np.float64)[f.reshape(-1)]
    elif isinstance(source, (str, Path)) or hasattr(source, "__fspath__"):
        path = Path(source)
        name = str(path)
        _check_path(path)  # missing, a link loop, a directory, a pipe or device
        if path.suffix.lower() != ".stl":
            raise MeshFileError(
                f"'{path}': compat='cura' reads STL files only (CuraEngine's own "
                f"reader); got suffix '{path.suffix}'. Load it with "
                "compat='vecslice', or pass a trimesh object"
            )
        read = read_stl_corners(path)
        if not read.not_ascii:
            if read.warning:
                warnings.warn(read.warning, VecsliceWarning, stacklevel=4)
            return _mesh_from_file(read, scale, name)
        try:  # a 'solid' file read as binary: its errors are the file's
            mesh = _mesh_from_binary(read, scale, name)
        except InputValueError as exc:
            raise _no_triangles(path, read.not_ascii, str(exc)) from exc
        if read.warning:
            warnings.warn(read.warning, VecsliceWarning, stacklevel=4)
        return mesh
    else:
        raise InputTypeError(
            "`path_or_trimesh` must be a file path, trimesh.Trimesh or "
            f"trimesh.Scene; got {type(source).__name__}"
        )
    if corners.shape[0] == 0:
        raise MeshFileError(f"'{name}' holds no triangles")
    um = mm2int(corners * scale if scale != 1.0 else corners,
                where=lambda c: f"corner {c} (triangle {c // 3}) of {name}")
    return cura_mesh_from_corners(um, name)


def _scaled(read: StlCorners, scale: float) -> NDArray[np.float64]:
    corners = read.corners.astype(np.float64)
    return corners * scale if scale != 1.0 else corners


def _mesh_from_binary(read: StlCorners, scale: float, name: str) -> Any:
    """The mesh of a file beginning with 'solid' that CuraEngine reads as binary.

    Raises InputValueError with the binary reading's problem (the caller names
    the file and adds why its ASCII gave no triangle).
    """
    n = read.corners.shape[0] // 3
    if n == 0:
        raise InputValueError(
            f"it has no 50-byte triangle record after the 84-byte header (the file "
            f"has {len(read.data)} bytes)")
    um = mm2int(_scaled(read, scale),
                where=lambda c: f"corner {c} (triangle {c // 3} of {n})")
    return cura_mesh_from_corners(um, name)


def _mesh_from_file(read: StlCorners, scale: float, name: str) -> Any:
    """The mesh of an STL file: values named with the file (and line, if ASCII).

    Raises
    ------
    InputValueError
        If a value is not finite or too large (naming the file and the place).
    MeshFileError
        If there is no triangle, or every triangle collapses.
    """
    if read.corners.shape[0] == 0:
        raise MeshFileError(f"'{name}' holds no triangles")

    def where(c: int) -> str:
        line = f", line {_vertex_line(read.data, c)}" if read.ascii else ""
        return f"corner {c} (triangle {c // 3}{line}) of '{name}'"

    um = mm2int(_scaled(read, scale), where=where)
    try:
        return cura_mesh_from_corners(um, name)
    except InputValueError as exc:
        raise MeshFileError(f"'{name}': {exc}") from exc
