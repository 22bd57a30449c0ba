"""Reading mesh files: STL, OBJ, PLY, OFF and 3MF to float vertices and faces.

:func:`read_mesh_file` checks the path and dispatches on the suffix;
:func:`trimesh_arrays` takes the arrays out of a ``trimesh.Trimesh`` or
``trimesh.Scene``. trimesh is imported only when one of these runs, so
``import vecslice`` does not import it.
"""

from __future__ import annotations

import struct
import sys
import zipfile
import zlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from vecslice.errors import MeshFileError

if TYPE_CHECKING:
    import trimesh

__all__ = ["SUPPORTED_EXTENSIONS", "read_mesh_file", "trimesh_arrays"]

SUPPORTED_EXTENSIONS = ("3mf", "obj", "off", "ply", "stl")
"""File types :func:`load_mesh` reads (case-insensitive suffixes)."""

# What trimesh's readers raise on damaged input (found by truncating and corrupting
# STL/OBJ/PLY/3MF files): parse errors are ValueError (UnicodeDecodeError is one),
# lxml's XMLSyntaxError is a SyntaxError, a 3MF without a model raises StopIteration.
_READ_ERRORS: tuple[type[BaseException], ...] = (
    ValueError,
    KeyError,
    IndexError,
    StopIteration,
    SyntaxError,
    EOFError,
    NotImplementedError,
    OSError,
    struct.error,
    zipfile.BadZipFile,
    zlib.error,
)


def _stl_hint(path: Path, size: int) -> str:
    """Why an STL file gave no triangles, guessed from its first bytes."""
    with open(path, "rb") as fh:
        head = np.frombuffer(fh.read(512), dtype=np.uint8)
    if (((head >= 32) & (head < 127)) | np.isin(head, (9, 10, 13))).all():
        return " (ASCII STL without a complete 'solid ... endsolid' block: truncated?)"
    if size < 84:
        return f" (binary STL needs an 84-byte header; the file has {size} bytes)"
    n = int(head[80:84].view("<u4")[0])
    want = 84 + 50 * n
    return (f" (binary STL header announces {n} triangles = {want} bytes; the file "
            f"has {size} bytes: truncated or corrupt)")


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
        if np.linalg.det(t[:3, :3]) < 0:  # a mirror turns the winding inside out
            f = f[:, ::-1]
        verts.append(v)
        faces.append(f + base)
        base += v.shape[0]
    if not faces:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    return np.concatenate(verts), np.concatenate(faces)


def read_mesh_file(path: Path) -> tuple[NDArray[np.float64], NDArray[Any]]:
    """Float vertices (file units) and faces of the mesh file ``path``.

    Raises :class:`MeshFileError` for anything that is not a readable mesh file.
    """
    if not path.exists():
        raise MeshFileError(f"mesh file not found: '{path}'")
    if path.is_dir():
        raise MeshFileError(f"'{path}' is a directory, not a mesh file")
    ext = path.suffix.lower().lstrip(".")
    if ext not in SUPPORTED_EXTENSIONS:
        raise MeshFileError(
            f"'{path}': unsupported mesh file type '{path.suffix}'; expected one of "
            + ", ".join("." + e for e in SUPPORTED_EXTENSIONS)
        )
    size = path.stat().st_size
    if size == 0:
        raise MeshFileError(f"'{path}' is empty (0 bytes)")
    import trimesh

    try:
        loaded = trimesh.load(str(path), file_type=ext, process=False)
    except _READ_ERRORS as exc:
        raise MeshFileError(
            f"cannot read '{path}' as {ext.upper()}: {type(exc).__name__}: {exc}"
        ) from exc
    if isinstance(loaded, trimesh.Scene):
        v, f = _scene_arrays(loaded)
    elif isinstance(loaded, trimesh.Trimesh):
        v, f = np.asarray(loaded.vertices), np.asarray(loaded.faces)
    else:
        v, f = np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    if f.shape[0] == 0:
        hint = _stl_hint(path, size) if ext == "stl" else ""
        raise MeshFileError(f"'{path}' holds no triangles{hint}")
    flat = f.reshape(-1)
    bad = np.flatnonzero((flat < 0) | (flat >= v.shape[0]))
    if bad.size:
        i = int(bad[0])
        raise MeshFileError(
            f"'{path}' is corrupt: face {i // 3} refers to vertex {flat[i]}, but "
            f"the file has {v.shape[0]} vertices"
        )
    return v, f




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
