"""Triangle meshes in int64 µm: :class:`Mesh` and :func:`load_mesh`.

This is the only vecslice module that imports trimesh. Files are read by trimesh
without processing (``process=False``); vecslice converts the vertices to µm once,
then does its own exact merging, cleaning and orientation repair on integers.
"""

from __future__ import annotations

import numbers
import os
import struct
import sys
import zipfile
import zlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._validate import (
    as_int_array,
    check_coord_range,
    check_int,
    check_option,
)
from vecslice.errors import InputTypeError, InputValueError, MeshFileError
from vecslice.meshcheck import (
    LoadInfo,
    MeshReport,
    _edges,
    build_report,
    clean_arrays,
    dedupe_faces,
    face_volumes,
    orient_faces,
    shells,
)

if TYPE_CHECKING:  # imported where used: `import vecslice` stays light
    import trimesh

from vecslice.units import to_microns

__all__ = ["LoadInfo", "Mesh", "MeshReport", "check_mesh", "load_mesh"]

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


def _freeze(a: NDArray[np.int64]) -> NDArray[np.int64]:
    """``a`` immutable (no copy): one rule for every container, see ragged.freeze."""
    from vecslice.ragged import freeze

    return freeze(a)


def _as_vertices(value: ArrayLike) -> NDArray[np.int64]:
    a = value if isinstance(value, np.ndarray) else None
    if a is not None and a.dtype.kind == "f" and a.size:
        raise InputTypeError(
            f"`vertices` must be integer microns; got dtype {a.dtype}. Read files "
            "with vecslice.load_mesh() or convert millimetres with "
            "vecslice.to_microns()"
        )
    v = as_int_array(value, "vertices", ndim=2, width=3)
    check_coord_range(v, "vertices")
    return v


def _as_faces(value: ArrayLike, n_vertices: int) -> NDArray[np.int64]:
    f = as_int_array(value, "faces", ndim=2, width=3)
    if f.shape[0] == 0:
        raise InputValueError(
            "`faces` must hold at least one triangle; got an empty mesh "
            f"(faces of shape {f.shape})"
        )
    flat = f.reshape(-1)
    bad = np.flatnonzero((flat < 0) | (flat >= n_vertices))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`faces` must index vertices in [0, {n_vertices}); got {flat[i]} "
            f"at face {i // 3}"
        )
    return f


@dataclass(frozen=True, slots=True, eq=False)
class Mesh:
    """A triangle mesh in int64 microns.

    ``Mesh(vertices, faces)`` validates and stores the arrays as given;
    :meth:`from_arrays` (the usual constructor) also merges equal positions and
    drops degenerate faces and unused vertices; :func:`load_mesh` reads files.

    Attributes
    ----------
    vertices : ndarray of shape (V, 3), int64
        Positions in µm, ``|value| < 2**30``; read-only.
    faces : ndarray of shape (F, 3), int64
        Vertex indices of each triangle, ``0 <= index < V``; read-only. The winding
        (counter-clockwise seen from outside) gives the outward side.
    load_info : LoadInfo or None
        Counts of what loading and repair changed (not compared, not sliced).

    Examples
    --------
    >>> tet = Mesh.from_arrays([[0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6]],
    ...                        [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    >>> tet
    Mesh(4 vertices, 4 faces, 0.006 x 0.006 x 0.006 mm)
    >>> tet.faces[1].tolist(), tet.vertices[tet.faces[1]].tolist()
    ([0, 1, 3], [[0, 0, 0], [6, 0, 0], [0, 0, 6]])
    >>> tet.is_watertight, tet.n_bodies, tet.volume
    (True, 1, 36.0)
    """

    vertices: NDArray[np.int64]
    faces: NDArray[np.int64]
    load_info: LoadInfo | None

    def __init__(
        self,
        vertices: ArrayLike,
        faces: ArrayLike,
        *,
        load_info: LoadInfo | None = None,
    ) -> None:
        v = _as_vertices(vertices)
        f = _as_faces(faces, v.shape[0])
        if v is vertices or not v.flags.owndata:
            v = v.copy()
        if f is faces or not f.flags.owndata:
            f = f.copy()
        self._set(v, f, load_info)

    def _set(
        self, v: NDArray[np.int64], f: NDArray[np.int64], info: LoadInfo | None
    ) -> None:
        object.__setattr__(self, "vertices", _freeze(np.ascontiguousarray(v)))
        object.__setattr__(self, "faces", _freeze(np.ascontiguousarray(f)))
        object.__setattr__(self, "load_info", info)

    @classmethod
    def _trusted(
        cls, v: NDArray[np.int64], f: NDArray[np.int64], info: LoadInfo | None
    ) -> Mesh:
        m = object.__new__(cls)
        m._set(v, f, info)
        return m

    @classmethod
    def from_arrays(
        cls,
        vertices_um: ArrayLike,
        faces: ArrayLike,
        *,
        merge: bool = True,
        load_info: LoadInfo | None = None,
    ) -> Mesh:
        """Build a mesh from integer µm vertices and triangle indices.

        Parameters
        ----------
        vertices_um : array_like of shape (V, 3), integer
            Positions in µm, ``|value| < 2**30``. Floats are rejected: convert
            millimetres with :func:`vecslice.to_microns` (or read files with
            :func:`load_mesh`).
        faces : array_like of shape (F, 3), integer
            Vertex indices, ``0 <= index < V``; at least one face.
        merge : bool, default True
            Merge vertices with exactly equal positions (first occurrence kept,
            order kept), then drop faces with two equal corners and vertices no
            face uses. ``False`` stores the arrays as given.
        load_info : LoadInfo, optional
            Counts from an earlier stage to add to (used by :func:`load_mesh`).

        Returns
        -------
        Mesh

        Raises
        ------
        InputTypeError
            If an array is not integer (float vertices get a hint).
        InputValueError
            On a wrong shape, a coordinate beyond 2**30 µm, a face index out of
            range, no faces, or only degenerate faces.

        Notes
        -----
        Faces with three distinct but collinear corners (zero area) are kept, as
        CuraEngine keeps them: they cut no plane in a way that changes a loop.
        :func:`check_mesh` counts them.

        Examples
        --------
        >>> m = Mesh.from_arrays([[0, 0, 0], [9, 0, 0], [0, 9, 0], [9, 0, 0]],
        ...                      [[0, 1, 2], [0, 3, 2], [0, 1, 3]])
        >>> m.faces.tolist(), m.load_info.vertices_merged, m.load_info.faces_degenerate
        ([[0, 1, 2], [0, 1, 2]], 1, 1)
        """
        v = _as_vertices(vertices_um)
        f = _as_faces(faces, v.shape[0])
        base = load_info if load_info is not None else LoadInfo(
            "arrays", int(f.shape[0]), int(v.shape[0]))
        if not merge:
            return cls(v, f, load_info=base)
        v2, f2, n_merged, n_unused, n_deg = clean_arrays(v, f)
        if f2.shape[0] == 0:
            raise InputValueError(
                f"`faces` must hold at least one non-degenerate triangle; all "
                f"{f.shape[0]} faces have two corners at the same position"
            )
        info = replace(
            base,
            vertices_merged=base.vertices_merged + n_merged,
            vertices_unused=base.vertices_unused + n_unused,
            faces_degenerate=base.faces_degenerate + n_deg,
        )
        return cls._trusted(v2, f2, info)

    @property
    def n_faces(self) -> int:
        """Number of triangles ``F``."""
        return int(self.faces.shape[0])

    @property
    def n_vertices(self) -> int:
        """Number of vertices ``V``."""
        return int(self.vertices.shape[0])

    @property
    def bounds(self) -> NDArray[np.int64]:
        """Lower and upper corner, shape (2, 3), int64 µm."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def zrange(self) -> tuple[int, int]:
        """Lowest and highest vertex z in µm."""
        z = self.vertices[:, 2]
        return int(z.min()), int(z.max())

    @property
    def is_watertight(self) -> bool:
        """Every edge is used by exactly two faces, in opposite directions."""
        e = _edges(self.faces, self.n_vertices)
        return bool(((e.counts == 2) & (e.n_forward == 1)).all())

    @property
    def n_bodies(self) -> int:
        """Number of shells: faces joined through edges shared by exactly 2 faces.

        This is trimesh's ``len(mesh.split(only_watertight=False))``. Shells that
        touch only at a vertex or along a non-manifold edge count separately.
        """
        return shells(self.faces, self.n_vertices)[1]

    @property
    def volume(self) -> float:
        """Signed volume in µm³ (float64; positive when closed and outward)."""
        return float(face_volumes(self.vertices, self.faces).sum())

    def report(self) -> MeshReport:
        """Defect counts, shells and volume; see :func:`check_mesh`."""
        return check_mesh(self)

    def translated(self, dx: int, dy: int, dz: int) -> Mesh:
        """A copy moved by integer µm offsets (faces shared, read-only).

        Examples
        --------
        >>> m = Mesh.from_arrays([[0, 0, 0], [5, 0, 0], [0, 5, 0]], [[0, 1, 2]])
        >>> m.translated(10, 0, -3).bounds.tolist()
        [[10, 0, -3], [15, 5, -3]]
        """
        d = [check_int(dx, "dx"), check_int(dy, "dy"), check_int(dz, "dz")]
        b = self.bounds
        lo = min(int(b[0, k]) + d[k] for k in range(3))  # Python ints: no wrap
        hi = max(int(b[1, k]) + d[k] for k in range(3))
        if lo <= -(2**30) or hi >= 2**30:
            raise InputValueError(
                f"`vertices` must satisfy |value| < 2**30 µm after translation by "
                f"({dx}, {dy}, {dz}); got range [{lo}, {hi}]"
            )
        moved = self.vertices + np.array(d, dtype=np.int64)
        return Mesh._trusted(moved, self.faces, self.load_info)

    def repaired(self) -> Mesh:
        """Remove duplicate faces and orient every shell consistently and outward.

        1. **Duplicate faces**: faces with the same three vertices are grouped and
           their windings summed (+1 / -1). A non-zero sum keeps one face with the
           majority winding; a zero sum — a face and its reversed twin, i.e. a
           zero-thickness wall such as the shared face of two touching boxes —
           keeps none.
        2. **Winding**: faces joined across edges used by exactly two faces form a
           shell; each orientable shell is made consistent (neighbours traverse
           their shared edge in opposite directions).
        3. **Outward**: a closed shell (its edge uses cancel) with negative signed
           volume is reversed; an open shell keeps the orientation most of its
           faces had. Non-orientable shells are left as they are.

        Vertices no face uses any more are dropped. Non-manifold edges, holes and
        self-intersections are not changed (:func:`check_mesh` reports them). The
        result's ``load_info`` counts removed and flipped faces.

        Returns
        -------
        Mesh

        Raises
        ------
        InputValueError
            If every face cancels against a reversed twin.

        Examples
        --------
        >>> inside_out = Mesh.from_arrays(
        ...     [[0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6]],
        ...     [[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]])
        >>> inside_out.volume, inside_out.repaired().volume
        (-36.0, 36.0)
        """
        f = self.faces
        keep = dedupe_faces(f)
        f = f[keep]
        if f.shape[0] == 0:
            raise InputValueError(
                "`mesh` has no faces left after repair: every face cancels "
                "against a reversed copy of itself"
            )
        flip = orient_faces(self.vertices, f)
        f = np.where(flip[:, None], f[:, [0, 2, 1]], f)
        v, f, _, n_unused, _ = clean_arrays(self.vertices, f, merge=False)
        info = self.load_info if self.load_info is not None else LoadInfo(
            "arrays", self.n_faces, self.n_vertices)
        info = replace(
            info,
            vertices_unused=info.vertices_unused + n_unused,
            faces_duplicate=info.faces_duplicate + int((~keep).sum()),
            faces_flipped=info.faces_flipped + int(flip.sum()),
        )
        return Mesh._trusted(v, f, info)

    def to_trimesh(self) -> trimesh.Trimesh:
        """A ``trimesh.Trimesh`` in float64 millimetres (not processed)."""
        import trimesh

        return trimesh.Trimesh(vertices=self.vertices / 1000.0,
                               faces=self.faces.copy(), process=False)

    @property
    def nbytes(self) -> int:
        """Bytes held by the arrays."""
        return int(self.vertices.nbytes + self.faces.nbytes)

    def __repr__(self) -> str:
        if self.n_vertices:
            size = (self.bounds[1] - self.bounds[0]) / 1000.0
            dims = f", {size[0]:.3f} x {size[1]:.3f} x {size[2]:.3f} mm"
        else:
            dims = ""
        return f"Mesh({self.n_vertices} vertices, {self.n_faces} faces{dims})"


def check_mesh(mesh: Any) -> MeshReport:
    """Count the defects of a mesh that matter for slicing.

    Parameters
    ----------
    mesh : Mesh
        A vecslice mesh.

    Returns
    -------
    MeshReport
        Edge, face and shell counts, signed volume and bounds; ``str()`` of it is a
        readable summary.

    Raises
    ------
    InputTypeError
        If ``mesh`` is not a :class:`vecslice.Mesh`.

    Notes
    -----
    Edges are undirected vertex pairs. A boundary edge has one face, a non-manifold
    edge more than two, an inconsistent edge two faces that run along it in the
    same direction (one of them is inside out). Duplicate faces share all three
    vertices. Counts are after the vertex merge of :meth:`Mesh.from_arrays`.

    Examples
    --------
    >>> tet = Mesh.from_arrays([[0, 0, 0], [6, 0, 0], [0, 6, 0], [0, 0, 6]],
    ...                        [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    >>> r = check_mesh(tet)
    >>> r.is_watertight, r.n_bodies, r.boundary_edges, r.volume
    (True, 1, 0, 36.0)
    """
    if not isinstance(mesh, Mesh):
        raise InputTypeError(
            f"`mesh` must be a vecslice.Mesh (see vecslice.load_mesh); "
            f"got {type(mesh).__name__}"
        )
    return build_report(mesh.vertices, mesh.faces, mesh.load_info)


def _check_scale(scale: object) -> float:
    if isinstance(scale, (bool, np.bool_)) or not isinstance(scale, numbers.Real):
        raise InputTypeError(
            "`scale` must be a real number (file units to mm); got "
            f"{type(scale).__name__} {scale!r}"
        )
    s = float(scale)
    if not (np.isfinite(s) and s > 0):
        raise InputValueError(
            f"`scale` must be a positive finite number (file units to mm); got {s!r}"
        )
    return s


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


def _read_file(path: Path) -> tuple[NDArray[np.float64], NDArray[Any]]:
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


def load_mesh(
    path_or_trimesh: str | os.PathLike[str] | trimesh.Trimesh | trimesh.Scene,
    *,
    scale: float = 1.0,
    repair: bool = True,
    compat: str = "vecslice",
) -> Mesh:
    """Read a mesh file (or take a trimesh object) as an int64-µm :class:`Mesh`.

    Parameters
    ----------
    path_or_trimesh : str, path-like, trimesh.Trimesh or trimesh.Scene
        An STL (binary or ASCII), OBJ, PLY, OFF or 3MF file, or a trimesh object.
        3MF build items and components, and every scene node, are placed with
        their transforms and concatenated.
    scale : float, default 1.0
        File units to millimetres (25.4 for inches, 1000 for metres).
    repair : bool, default True
        Remove duplicate faces and orient every shell consistently and outward
        (see :meth:`Mesh.repaired`). Ignored with ``compat="cura"``.
    compat : {'vecslice', 'cura'}, default 'vecslice'
        ``'cura'`` reads the mesh as CuraEngine does (STL only, or a trimesh
        object): float32 values, ``MM2INT``, 30 µm melding through CuraEngine's hash
        cells in file order, degenerate triangles dropped and nothing repaired;
        vertices and faces come in CuraEngine's order (see
        :mod:`vecslice.cura_stl`). Slice it with ``SliceSettings(compat="cura")``.

    Returns
    -------
    Mesh
        Vertices ``round(value * scale * 1000)`` µm, rounding half away from zero,
        merged by exact position (:meth:`Mesh.from_arrays`); ``load_info`` says
        what was merged, dropped and repaired.

    Raises
    ------
    MeshFileError
        (an ``OSError``) for a missing file, a directory, an unsupported suffix, an
        empty, unreadable, truncated or corrupt file, or one without triangles.
    InputTypeError
        If ``path_or_trimesh`` or ``scale`` has the wrong type.
    InputValueError
        If ``scale`` is not positive and finite, a vertex is NaN or infinite, or a
        coordinate reaches 2**30 µm.
    SettingsError
        If ``compat`` is not 'vecslice' or 'cura'.

    Examples
    --------
    >>> import trimesh
    >>> box = load_mesh(trimesh.creation.box((10, 20, 30)))
    >>> box.bounds.tolist(), box.n_faces, box.is_watertight
    ([[-5000, -10000, -15000], [5000, 10000, 15000]], 12, True)
    >>> load_mesh(trimesh.creation.box((10, 20, 30)), compat="cura").faces[:2].tolist()
    [[0, 1, 2], [3, 0, 2]]
    """
    s = _check_scale(scale)
    if check_option(compat, ("vecslice", "cura"), "compat") == "cura":
        from vecslice.cura_stl import load_mesh_cura

        return load_mesh_cura(path_or_trimesh, s)  # type: ignore[no-any-return]
    if isinstance(path_or_trimesh, (str, os.PathLike)):
        path = Path(path_or_trimesh)
        source = str(path)
        v, f = _read_file(path)
    elif "trimesh" not in sys.modules:  # then it cannot be a trimesh object
        raise InputTypeError(
            "`path_or_trimesh` must be a file path, trimesh.Trimesh or "
            f"trimesh.Scene; got {type(path_or_trimesh).__name__}"
        )
    elif isinstance(path_or_trimesh, sys.modules["trimesh"].Trimesh):
        source = "trimesh.Trimesh"
        v = np.asarray(path_or_trimesh.vertices, dtype=np.float64)
        f = np.asarray(path_or_trimesh.faces)
    elif isinstance(path_or_trimesh, sys.modules["trimesh"].Scene):
        source = "trimesh.Scene"
        v, f = _scene_arrays(path_or_trimesh)
    else:
        raise InputTypeError(
            "`path_or_trimesh` must be a file path, trimesh.Trimesh or "
            f"trimesh.Scene; got {type(path_or_trimesh).__name__}"
        )
    if f.shape[0] == 0 and source.startswith("trimesh"):
        raise InputValueError(f"`path_or_trimesh` ({source}) holds no triangles")
    v = np.asarray(v, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`vertices` must be finite; got {v[i].tolist()} at vertex {i} "
            f"of {source}"
        )
    um = to_microns(v * s if s != 1.0 else v, name="vertices")
    info = LoadInfo(source, int(f.shape[0]), int(v.shape[0]))
    try:
        mesh = Mesh.from_arrays(um, f, load_info=info)
    except InputValueError as exc:
        if source.startswith("trimesh"):
            raise
        raise MeshFileError(f"'{source}': {exc}") from exc
    return mesh.repaired() if repair else mesh
