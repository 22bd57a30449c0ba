"""Reading mesh files: STL, OBJ, PLY, OFF and 3MF to float vertices and faces.

:func:`read_mesh_file` checks the path, dispatches on the suffix and turns every
failure into a :class:`~vecslice.errors.MeshFileError` that names the file.
STL and OBJ are parsed here (bytes and regular expressions, so no text encoding
is guessed), 3MF by :mod:`vecslice.threemf`, PLY and OFF by :mod:`vecslice.plyoff`
(no side files such as textures are opened). Counts a file
announces are checked against its size and :data:`MAX_TRIANGLES` before memory is
spent on them. :func:`trimesh_arrays` takes the arrays out of a
``trimesh.Trimesh`` or ``trimesh.Scene``. trimesh is imported only when it is
used, so ``import vecslice`` does not import it.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import re
import stat
import struct
import sys
import threading
from collections.abc import Callable, Iterator
from itertools import islice
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import InputValueError, MeshFileError, VecsliceError
from vecslice.plybinary import read_ply_binary
from vecslice.plyoff import (
    _ply_parse,
    fan_triangles,
    read_off,
    read_ply_ascii,
)

if TYPE_CHECKING:
    import trimesh

__all__ = ["MAX_TRIANGLES", "SUPPORTED_EXTENSIONS", "read_mesh_file", "trimesh_arrays"]

SUPPORTED_EXTENSIONS = ("3mf", "obj", "off", "ply", "stl")
"""File types :func:`read_mesh_file` reads (case-insensitive suffixes)."""

MAX_TRIANGLES = 100_000_000
"""Most triangles a file may hold or announce (3MF: after expanding components).

A file above it is refused before its arrays are made (they would take more than
5 GB); the largest real print jobs are around a tenth of it.
"""

Arrays = tuple[NDArray[np.float64], NDArray[np.int64]]


# --------------------------------------------------------------------------
# dispatch
# --------------------------------------------------------------------------


def _check_path(path: Path) -> int:
    """Size of the regular file ``path``; a clear error for anything else."""
    try:
        st = os.stat(path)  # follows symbolic links
    except FileNotFoundError:
        if os.path.islink(path):
            raise MeshFileError(
                f"'{path}' is a broken symbolic link: its target "
                f"'{os.readlink(path)}' does not exist"
            ) from None
        raise MeshFileError(f"mesh file not found: '{path}'") from None
    except ValueError as exc:  # an embedded NUL byte
        raise MeshFileError(f"cannot open {str(path)!r}: {exc}") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise MeshFileError(
                f"'{path}' is a symbolic link loop (too many levels of symbolic "
                "links)"
            ) from None
        raise MeshFileError(f"cannot open '{path}': {exc.strerror}") from None
    if stat.S_ISDIR(st.st_mode):
        raise MeshFileError(f"'{path}' is a directory, not a mesh file")
    if not stat.S_ISREG(st.st_mode):
        raise MeshFileError(f"'{path}' is not a regular file (a device or pipe?)")
    return int(st.st_size)


class _ThreadFilter(logging.Filter):
    """Drops the records one thread logs (the one reading a file)."""

    def __init__(self) -> None:
        super().__init__()
        self.thread = threading.get_ident()

    def filter(self, record: logging.LogRecord) -> bool:
        return record.thread != self.thread


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Silence trimesh's logger and numpy's floating-point warnings while reading.

    Only records logged by this thread are dropped, and numpy's error state is
    local to the thread: a file that loads prints nothing, and nothing outside
    the read is changed. The warning filters are left alone: they are global to
    the process, and ``warnings.catch_warnings`` swapping them is not thread-safe
    (a load on one thread changed what another thread's warnings did, and
    concurrent loads could leave the swapped filters behind).
    """
    logger = logging.getLogger("trimesh")
    quiet = _ThreadFilter()
    logger.addFilter(quiet)
    try:
        with np.errstate(all="ignore"):
            yield
    finally:
        logger.removeFilter(quiet)


def read_mesh_file(path: Path) -> Arrays:
    """Float vertices and int64 faces of the mesh file ``path``.

    Vertices are in file units, except for 3MF, whose ``unit`` attribute is
    applied (millimetres). Faces index the vertices (checked here).

    Raises :class:`MeshFileError` for anything that is not a readable mesh file:
    a missing path, a symbolic link loop, a directory, an unsupported suffix, an
    empty, truncated, corrupt or oversized file, or one without triangles.
    """
    size = _check_path(path)
    ext = path.suffix.lower().lstrip(".")
    if ext not in SUPPORTED_EXTENSIONS:
        raise MeshFileError(
            f"'{path}': unsupported mesh file type '{path.suffix}'; expected one of "
            + ", ".join("." + e for e in SUPPORTED_EXTENSIONS)
        )
    if size == 0:
        raise MeshFileError(f"'{path}' is empty (0 bytes)")
    reader = _READERS[ext]
    try:
        with _quiet():
            v, f = reader(path, size)
    except VecsliceError:
        raise
    except MemoryError:
        raise MeshFileError(
            f"cannot read '{path}' as {ext.upper()}: ran out of memory (the file "
            "announces more data than fits)"
        ) from None
    except Exception as exc:  # a parser's failure on a damaged file, whatever it is
        raise MeshFileError(
            f"cannot read '{path}' as {ext.upper()}: {type(exc).__name__}: {exc}"
        ) from exc
    if f.shape[0] == 0:
        with open(path, "rb") as fh:
            hint = _utf16_hint(fh.read(512))
        raise MeshFileError(f"'{path}' holds no triangles{hint}")
    if f.shape[0] > MAX_TRIANGLES:
        raise _too_many(path, f.shape[0])
    bad = np.flatnonzero(((f < 0) | (f >= v.shape[0])).any(axis=1))
    if bad.size:
        i = int(bad[0])
        j = int(np.flatnonzero((f[i] < 0) | (f[i] >= v.shape[0]))[0])
        raise MeshFileError(
            f"'{path}' is corrupt: face {i} refers to vertex {int(f[i, j])}, but "
            f"the file has {v.shape[0]} vertices"
        )
    return v, f


def _too_many(path: Path, n: int, what: str = "triangles") -> MeshFileError:
    if what == "vertices":
        limit = f"{3 * MAX_TRIANGLES:,} vertices (3 x vecslice.meshfile.MAX_TRIANGLES)"
    else:
        limit = f"{MAX_TRIANGLES:,} triangles (vecslice.meshfile.MAX_TRIANGLES)"
    return MeshFileError(f"'{path}' announces {n:,} {what}; vecslice reads at most "
                         f"{limit}")


# --------------------------------------------------------------------------
# STL
# --------------------------------------------------------------------------

_STL_RECORD = np.dtype(
    [("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]
)
_STL_VERTEX = re.compile(rb"vertex[ \t\r\n]+(\S+)[ \t\r\n]+(\S+)[ \t\r\n]+(\S+)")
_STL_LOOP = re.compile(rb"outer[ \t]+loop")
_STL_SOLID = re.compile(rb"^[ \t]*solid(?![^ \t\r\n])", re.M)
_TEXT = re.compile(rb"[^\t\n\r\x20-\x7e]")
_BOM = b"\xef\xbb\xbf"  # UTF-8 byte order mark: Windows tools begin text with it


def _utf16_hint(data: bytes) -> str:
    """A hint for text saved as UTF-16 (a BOM or NUL in every other byte)."""
    head = data[: len(data[:512]) & ~1]
    for text, nul in ((head[0::2], head[1::2]), (head[1::2], head[0::2])):
        # ASCII text in UTF-16: every other byte NUL, the others printable
        if (head[:2] in (b"\xff\xfe", b"\xfe\xff") or (len(head) >= 8
                and not nul.strip(b"\0") and not _TEXT.search(text))):
            return " (it looks like UTF-16 text; save it as ASCII or UTF-8)"
    return ""


def _no_stl(path: Path, data: bytes) -> MeshFileError:
    """Why ``data`` (the whole file) is no STL.

    UTF-16 text, text without a complete ``solid ... endsolid`` block, fewer
    bytes than a binary STL's header, or a binary STL whose triangle count does
    not match its size (named as such: it was reported as holding no triangles).
    """
    size = len(data)
    hint = _utf16_hint(data)
    if not hint and not _TEXT.search(data[:512]):
        hint = " (ASCII STL without a complete 'solid ... endsolid' block: truncated?)"
    elif not hint and size < 84:
        hint = f" (binary STL needs an 84-byte header; the file has {size} bytes)"
    if hint:
        return MeshFileError(f"'{path}' holds no triangles{hint}")
    n = struct.unpack_from("<I", data, 80)[0]
    return MeshFileError(
        f"'{path}' is truncated or corrupt: its binary STL header announces {n:,} "
        f"triangles, which take {84 + 50 * n:,} bytes (84 + 50 each), but the file "
        f"has {size:,} bytes")


def _read_stl(path: Path, size: int) -> Arrays:
    """Binary STL if the size matches the header's count, else ASCII ``solid``."""
    with open(path, "rb") as fh:
        head = fh.read(84)
        n = struct.unpack_from("<I", head, 80)[0] if len(head) == 84 else -1
        if n >= 0 and size == 84 + 50 * n:
            if n > MAX_TRIANGLES:
                raise _too_many(path, n)
            rec = np.frombuffer(fh.read(), dtype=_STL_RECORD, count=n)
            v = rec["v"].reshape(-1, 3).astype(np.float64)
            return v, np.arange(3 * n, dtype=np.int64).reshape(-1, 3)
        fh.seek(0)
        data = fh.read()
    text = data.removeprefix(_BOM)
    if text.lstrip()[:5].lower() != b"solid":
        raise _no_stl(path, data)
    return _read_stl_ascii(path, text)


def _read_stl_ascii(path: Path, data: bytes) -> Arrays:
    text = data
    if b"\n" not in text:  # old Mac line ends (CR only); CR LF reads as LF does
        text = text.replace(b"\r", b"\n")
    # keywords in any case (some CAD writes SOLID ... ENDSOLID); skip the name
    body = text[text.find(b"\n") + 1:].lower() if b"\n" in text else b""
    # text between vertices, x, y, z, text between vertices, ..., text after them
    parts = _STL_VERTEX.split(body)
    gaps = parts[0::4]
    del parts[0::4]  # the numbers are left
    if not parts or body.rfind(b"endsolid") < body.rfind(b"vertex"):
        raise _no_stl(path, data)
    # a solid begun after the last endsolid: cut before its first vertex
    cut = _STL_SOLID.search(body, body.rfind(b"endsolid"))
    if cut is not None:
        raise MeshFileError(
            f"'{path}' is truncated or corrupt: its ASCII STL solid on line "
            f"{_line_of(body, cut.start()) + 1} has no 'endsolid'")
    per_facet = _stl_facet_sizes(gaps)
    n_loops = per_facet.shape[0] - 1
    if len(gaps) - 1 != 3 * n_loops:
        raise MeshFileError(
            f"'{path}' is corrupt: ASCII STL facets must have 3 vertices each; got "
            f"{len(gaps) - 1} vertices in {n_loops} facets"
        )
    bad = np.flatnonzero(per_facet != np.r_[0, np.full(n_loops, 3)])
    if bad.size:  # as many vertices as 3 per facet, grouped otherwise
        k = int(bad[0])
        at = next(islice(_STL_LOOP.finditer(body), max(k - 1, 0), None)).start()
        raise MeshFileError(
            f"'{path}' is corrupt: ASCII STL facets must have 3 vertices each; "
            + (f"facet {k} (line {_line_of(body, at) + 1}) has {per_facet[k]}" if k
               else f"{per_facet[0]} vertices come before the first facet (line "
               f"{_line_of(body, at) + 1})"))
    v = _floats(path, parts, "vertex")
    return v, np.arange(v.shape[0], dtype=np.int64).reshape(-1, 3)


def _stl_facet_sizes(gaps: list[bytes]) -> NDArray[np.int64]:
    """Vertices before the first ``outer loop``, then in each loop: shape (loops + 1,).

    ``gaps`` is the text between an ASCII STL's vertices (``gaps[i]`` precedes
    vertex ``i``).
    """
    text = b"\n".join(gaps)  # no keyword runs across a line end
    ends = np.cumsum(np.fromiter(map(len, gaps), np.int64, len(gaps)) + 1)
    at = np.fromiter((m.start() for m in _STL_LOOP.finditer(text)), np.int64)
    loops_before = np.cumsum(np.bincount(np.searchsorted(ends, at, side="right"),
                                         minlength=len(gaps)))
    return np.bincount(loops_before[:-1], minlength=at.shape[0] + 1)


def _quoted(token: bytes) -> str:
    r"""A token of a file, quoted for a message: as text if it is UTF-8, else as bytes.

    ``'é'`` for UTF-8 ``\xc3\xa9``, ``b'\xe9'`` for a byte that is not UTF-8
    (decoding it as Latin-1 showed another character than the file holds).
    """
    try:
        return repr(token.decode("utf-8"))
    except UnicodeDecodeError:
        return repr(token)


def _floats(path: Path, tokens: list[bytes], what: str) -> NDArray[np.float64]:
    """(N, 3) float64 from 3N byte strings; names the first bad number.

    Python's float syntax allows ``1_0`` (10); a mesh file's numbers do not.
    """
    try:
        a = np.array(tokens, dtype=np.bytes_)
        if b"_" in a.tobytes():
            raise ValueError("an underscore")
        return a.reshape(-1, 3).astype(np.float64)
    except ValueError:
        for k in range(len(tokens) // 3):
            for tok in tokens[3 * k : 3 * k + 3]:
                try:
                    if b"_" in tok:
                        raise ValueError(tok)
                    float(tok)
                except ValueError:
                    raise MeshFileError(
                        f"'{path}' is corrupt: {what} {k + 1} has "
                        f"{_quoted(tok)} where a number should be"
                    ) from None
        raise


# --------------------------------------------------------------------------
# OBJ
# --------------------------------------------------------------------------

_OBJ_V = re.compile(rb"^[ \t]*v[ \t]+([^\s#]+[ \t]+[^\s#]+[ \t]+[^\s#]+)", re.M)
_OBJ_V_LINE = re.compile(rb"^[ \t]*v[ \t]", re.M)
_OBJ_F = re.compile(rb"^[ \t]*f[ \t]+([^\r\n#]*)", re.M)
_OBJ_SLASH = re.compile(rb"/\S*")  # to the next C whitespace, as tokens split
_OBJ_LEADING_SLASH = re.compile(rb"(?<!\S)/\S*")  # a corner without its vertex
_INT = re.compile(rb"[+-]?\d{1,18}")


def _numbers(text: bytes | str, dtype: type, n: int) -> NDArray[Any] | None:
    """The whitespace-separated numbers of ``text``; None unless exactly ``n``.

    numpy stops at the first token that is not a number, so a sentinel number
    appended shows whether it read everything: ``n + 1`` numbers, or fewer.
    (It then warns, DeprecationWarning, hidden by Python's default filters;
    the filters are not touched here: they are global to the process.)
    """
    sentinel = b" 0" if isinstance(text, bytes) else " 0"
    try:
        a = np.fromstring(text + sentinel, dtype=dtype, sep=" ")
    except (ValueError, DeprecationWarning):  # the latter under -W error
        return None
    return a[:n] if a.shape[0] == n + 1 else None


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _obj_line(data: bytes, joins: NDArray[np.int64], offset: int) -> int:
    """The line of the file (1-based) that ``data[offset]`` is on.

    ``data`` is the file with its continuations joined; ``joins`` are where in
    ``data`` each joined two lines of the file (sorted), so the lines before
    ``offset`` are its line ends plus the joins before it.
    """
    return _line_of(data, offset) + int(np.searchsorted(joins, offset))


def _obj_face(data: bytes, joins: NDArray[np.int64], k: int) -> str:
    """'face k+1 (line L)' for the k-th face line of an OBJ file (see _obj_line)."""
    m = next(islice(_OBJ_F.finditer(data), k, None))
    return f"face {k + 1} (line {_obj_line(data, joins, m.start())})"


def _obj_defined_before(data: bytes) -> NDArray[np.int64]:
    """How many vertices an OBJ file defines before each of its face lines."""
    v_at = np.array([m.start() for m in _OBJ_V_LINE.finditer(data)], np.int64)
    f_at = np.array([m.start() for m in _OBJ_F.finditer(data)], np.int64)
    return np.searchsorted(v_at, f_at).astype(np.int64)


def _read_obj(path: Path, size: int) -> Arrays:
    """Wavefront OBJ: ``v`` and ``f`` lines; polygons become triangle fans.

    Vertex indices are 1-based; negative ones count back from the last vertex
    defined before the face. Everything else (normals, texture coordinates,
    groups, materials) is ignored. Whole-file regular expressions and numpy
    parsing: no loop over lines in Python.
    """
    data = path.read_bytes().removeprefix(_BOM)  # it hid a first 'v' line
    if b"\r" in data:  # lines end at CR LF, CR (old Mac) or LF alike
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    joins = np.empty(0, dtype=np.int64)
    if b"\\\n" in data:  # line continuations: each joins two lines into one
        c = np.frombuffer(data, dtype=np.uint8)
        at = np.flatnonzero(c[:-1] == 0x5C)  # backslashes (they never overlap)
        at = at[c[at + 1] == 0x0A]
        joins = at - np.arange(at.shape[0])  # where each is once joined
        data = data.replace(b"\\\n", b" ")
    rows = _OBJ_V.findall(data)
    if len(rows) != len(_OBJ_V_LINE.findall(data)):
        good = {m.start() for m in _OBJ_V.finditer(data)}
        at = next(m.start() for m in _OBJ_V_LINE.finditer(data)
                  if m.start() not in good)
        raise MeshFileError(
            f"'{path}' is corrupt: line {_obj_line(data, joins, at)} defines a vertex "
            "without three coordinates"
        )
    n_v = len(rows)
    v = _numbers(b" ".join(rows), np.float64, 3 * n_v)
    if v is None:  # slow path: names the bad number
        v = _floats(path, [t for r in rows for t in r.split()], "vertex")
    v = v.reshape(-1, 3)
    bodies = _OBJ_F.findall(data)
    if not bodies:
        return v, np.empty((0, 3), dtype=np.int64)
    if len(bodies) > MAX_TRIANGLES:
        raise _too_many(path, len(bodies), "faces")
    body = b"\n".join(bodies)
    if b"/" in body:
        lone = _OBJ_LEADING_SLASH.search(body)
        if lone is not None:  # numpy would not see it, once the suffixes are gone
            k = body.count(b"\n", 0, lone.start())
            raise MeshFileError(
                f"'{path}' is corrupt: {_obj_face(data, joins, k)} has corner "
                f"{_quoted(lone.group())}; a corner starts with its vertex index (v, "
                "v/vt, v//vn or v/vt/vn)")
        body = _OBJ_SLASH.sub(b"", body)
    # tokens per face line: a token starts where a non-blank follows a blank
    c = np.frombuffer(body, dtype=np.uint8)
    blank = (c == 32) | ((c >= 9) & (c <= 13))  # C isspace(), as numpy parses
    start = ~blank & np.concatenate([[True], blank[:-1]])
    counts = np.bincount(np.cumsum(c == 10)[start], minlength=len(bodies))
    short = np.flatnonzero(counts < 3)
    if short.size:
        k = int(short[0])
        raise MeshFileError(f"'{path}' is corrupt: {_obj_face(data, joins, k)} has "
                            f"{counts[k]} vertices; a face needs at least 3")
    n_tri = int(counts.sum()) - 2 * counts.shape[0]  # fans, before they are made
    if n_tri > MAX_TRIANGLES:
        raise _too_many(path, n_tri)
    idx = _numbers(body, np.int64, int(counts.sum()))
    face_of = np.repeat(np.arange(len(bodies)), counts)
    if idx is None:
        toks = body.split()
        k = next((i for i, t in enumerate(toks) if not _INT.fullmatch(t)), 0)
        raise MeshFileError(
            f"'{path}' is corrupt: {_obj_face(data, joins, int(face_of[k]))} has "
            f"vertex index {_quoted(toks[k])}; expected an integer")
    res = idx - 1
    neg = idx < 0
    if neg.any():  # relative: vertices defined before the face line
        res[neg] = _obj_defined_before(data)[face_of[neg]] + idx[neg]
    bad = np.flatnonzero((idx == 0) | (res < 0) | (res >= n_v))
    if bad.size:
        k = int(bad[0])
        i, face = int(idx[k]), int(face_of[k])
        text = str(i)
        if i == np.iinfo(np.int64).max:  # numpy's parse of anything beyond int64
            text = body.split()[k].decode("latin-1")
        if i == 0:
            why = "OBJ vertex indices start at 1 (negative ones count back)"
        elif text.startswith("-"):
            why = (f"only {_obj_defined_before(data)[face]} vertices are defined "
                   "before it")
        else:
            why = f"the file has {n_v} vertices"
        raise MeshFileError(f"'{path}' is corrupt: {_obj_face(data, joins, face)} "
                            f"refers to vertex {text}; {why}")
    return v, fan_triangles(counts, res)


def _read_off(path: Path, size: int) -> Arrays:
    return read_off(path, path.read_bytes().removeprefix(_BOM))


def _read_ply(path: Path, size: int) -> Arrays:
    data = path.read_bytes().removeprefix(_BOM)
    header = _ply_parse(path, data)
    if header.binary:
        return read_ply_binary(path, data, header)
    return read_ply_ascii(path, data, header)


def _read_3mf(path: Path, size: int) -> Arrays:
    from vecslice.threemf import read_3mf

    return read_3mf(path, size)


_READERS: dict[str, Callable[[Path, int], Arrays]] = {
    "stl": _read_stl,
    "obj": _read_obj,
    "ply": _read_ply,
    "off": _read_off,
    "3mf": _read_3mf,
}


# --------------------------------------------------------------------------
# trimesh objects
# --------------------------------------------------------------------------


def _scene_arrays(scene: trimesh.Scene) -> tuple[NDArray[np.float64], NDArray[Any]]:
    """Vertices and faces of every Trimesh instance of ``scene``, transforms applied."""
    import trimesh

    verts: list[NDArray[np.float64]] = []
    faces: list[NDArray[Any]] = []
    base = 0
    for node in scene.graph.nodes_geometry:  # one per placed instance, not per face
        transform, name = scene.graph[node]
        geom = scene.geometry.get(name)
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        v = np.asarray(geom.vertices, dtype=np.float64)
        t = np.asarray(transform, dtype=np.float64)
        v = v @ t[:3, :3].T + t[:3, 3]
        f = np.asarray(geom.faces, dtype=np.int64)
        bad = np.flatnonzero((f < 0) | (f >= v.shape[0]))
        if bad.size:  # would index another geometry's vertices once offset
            i = int(bad[0])
            raise InputValueError(
                f"`faces` of scene geometry {name!r} must index its vertices in "
                f"[0, {v.shape[0]}); got {int(f.reshape(-1)[i])} at face {i // 3}")
        if np.linalg.det(t[:3, :3]) < 0:  # a mirror turns the winding inside out
            f = f[:, ::-1]
        verts.append(v)
        faces.append(f + base)
        base += v.shape[0]
    if not faces:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    return np.concatenate(verts), np.concatenate(faces)


def trimesh_arrays(obj: object) -> tuple[NDArray[np.float64], NDArray[Any], str] | None:
    """Vertices, faces and a source name of a trimesh object; None for other types.

    A trimesh object exists only if trimesh was imported already, so this never
    imports it.
    """
    trimesh = sys.modules.get("trimesh")
    if trimesh is None:
        return None
    if isinstance(obj, trimesh.Trimesh):
        v = np.asarray(obj.vertices, dtype=np.float64)
        return v, np.asarray(obj.faces), "trimesh.Trimesh"
    if isinstance(obj, trimesh.Scene):
        v, f = _scene_arrays(obj)
        return v, f, "trimesh.Scene"
    return None
