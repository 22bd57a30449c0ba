"""Triangle meshes in int64 µm: :class:`Mesh` and :func:`load_mesh`.

Files are read by :mod:`vecslice.meshfile` to float vertices and faces; vecslice
converts the vertices to µm once, then does its own exact merging, cleaning and
orientation repair on integers. trimesh is imported only where a trimesh object
is made (:meth:`Mesh.to_trimesh`) or read.
"""

from __future__ import annotations

import numbers
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vecslice._validate import (
    check_bool,
    check_int,
    check_option,
)
from vecslice.errors import InputTypeError, InputValueError, MeshFileError
from vecslice.interrupt import keyboard_interrupts
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
from vecslice.meshfile import read_mesh_file, trimesh_arrays
from vecslice.ragged import private_coords, private_int_extremes
from vecslice.units import COORD_LIMIT, to_microns

if TYPE_CHECKING:
    import trimesh

__all__ = ["LoadInfo", "Mesh", "MeshReport", "check_mesh", "load_mesh"]

def _freeze(a: NDArray[np.int64]) -> NDArray[np.int64]:
    """``a`` immutable (no copy): one rule for every container, see ragged.freeze."""
    from vecslice.ragged import freeze

    return freeze(a)


def _check_load_info(value: object) -> None:
    if value is not None and not isinstance(value, LoadInfo):
        raise InputTypeError(
            f"`load_info` must be a vecslice.mesh.LoadInfo or None; got "
            f"{type(value).__name__} {value!r}")


def _as_vertices(value: ArrayLike) -> NDArray[np.int64]:
    """The mesh's own copy of ``value`` (frozen), checked after it was copied.

    Checks on the caller's memory and a copy taken afterwards could differ (a
    write by another thread in between); kernels index without bounds checks.
    """
    a = value if isinstance(value, np.ndarray) else None
    if a is not None and a.dtype.kind == "f" and a.size:
        raise InputTypeError(
            f"`vertices` must be integer microns; got dtype {a.dtype}. Read files "
            "with vecslice.load_mesh() or convert millimetres with "
            "vecslice.to_microns()"
        )
    return private_coords(value, "vertices", width=3)


def _as_faces(value: ArrayLike, n_vertices: int) -> NDArray[np.int64]:
    """The mesh's own copy of ``value`` (frozen), checked as :func:`_as_vertices`."""
    f, lo, hi = private_int_extremes(value, "faces", ndim=2, width=3)
    if f.shape[0] == 0:
        raise InputValueError(
            "`faces` must hold at least one triangle; got an empty mesh "
            f"(faces of shape {f.shape})"
        )
    if lo >= 0 and hi < n_vertices:
        return f
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
    # half-edge twins of ``faces``, built by the first slice and reused by every
    # later one (the arrays are immutable); see _half_edge_twins
    _twins: NDArray[np.int64] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    # whether every half-edge has its twin (no open or non-manifold edge); with
    # the twins, see _twins_closed
    _closed: bool | None = field(
        default=None, init=False, repr=False, compare=False
    )
    # ``faces`` as int32, for the contour kernels (half the bytes to read where a
    # loop jumps from face to face); built by the first slice, see _narrow_faces
    _faces32: NDArray[np.int32] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    # CuraEngine's vertex -> faces lists and face neighbours (compat="cura"),
    # likewise built once; see _cura_topology
    _cura: tuple[NDArray[np.int64], ...] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    # the lowest and highest face corner; see _corner_zrange
    _zcorners: tuple[int, int] | None = field(
        default=None, init=False, repr=False, compare=False
    )
    # the faces in zmin order for adaptive layers: one (frame shift, arrays...)
    # entry per frame, newest first; see vecslice.adaptive._sorted_faces
    _adaptive: tuple[Any, ...] | None = field(
        default=None, init=False, repr=False, compare=False
    )

    def __init__(
        self,
        vertices: ArrayLike,
        faces: ArrayLike,
        *,
        load_info: LoadInfo | None = None,
    ) -> None:
        _check_load_info(load_info)
        # copied unless numpy made them afresh: never the caller's memory (an
        # object's __array__ may hand out its own array), never frozen in place;
        # checked after copying
        v = _as_vertices(vertices)
        self._set(v, _as_faces(faces, v.shape[0]), load_info)

    def _set(
        self, v: NDArray[np.int64], f: NDArray[np.int64], info: LoadInfo | None
    ) -> None:
        object.__setattr__(self, "vertices", _freeze(np.ascontiguousarray(v)))
        object.__setattr__(self, "faces", _freeze(np.ascontiguousarray(f)))
        object.__setattr__(self, "load_info", info)
        object.__setattr__(self, "_twins", None)
        object.__setattr__(self, "_closed", None)
        object.__setattr__(self, "_faces32", None)
        object.__setattr__(self, "_cura", None)
        object.__setattr__(self, "_zcorners", None)
        object.__setattr__(self, "_adaptive", None)

    def __getstate__(self) -> tuple[Any, ...]:
        # the cached topology is not pickled: cheaper to rebuild than to ship;
        # the model's z range is, as a mesh read by CuraEngine's rules sets it
        # (see _corner_zrange)
        return (self.vertices, self.faces, self.load_info, self._zcorners)

    def __setstate__(self, state: tuple[Any, ...]) -> None:
        v, f, info = state[:3]
        self._set(v, f, info)
        if len(state) > 3:
            object.__setattr__(self, "_zcorners", state[3])

    def _half_edge_twins(self) -> NDArray[np.int32]:
        """Twin of every half-edge (-1 where none), int32, built once per mesh.

        ``twin[3 * f + j]`` is the half-edge that runs the other way along the edge
        from ``faces[f, j]`` to ``faces[f, (j + 1) % 3]`` when exactly two
        half-edges share that edge (see ``half_edge_twins``). The first call builds
        it and caches it on the mesh; threads that race on the first call may each
        build it (the results are equal), never a wrong one.

        Raises
        ------
        InputValueError
            If the mesh has too many faces for int32 half-edge ids (3 × faces must
            stay below 2**31: at most 715,827,882 faces).
        """
        twins = self._twins
        if twins is None:
            from vecslice._kernels import topology
            from vecslice._threads import run_chunks

            if 3 * self.n_faces >= topology.TWIN_LIMIT:
                raise InputValueError(
                    f"`mesh` has {self.n_faces:,} faces; slicing takes at most "
                    f"{(topology.TWIN_LIMIT - 1) // 3:,} (its half-edges are "
                    "numbered in int32)"
                )
            n = self.vertices.shape[0]
            twins = _freeze(topology.half_edge_twins(self.faces, n, run=run_chunks))
            object.__setattr__(self, "_twins", twins)
        return twins

    def _twins_closed(self) -> bool:
        """Whether every half-edge has its twin, found once per mesh and cached.

        True for a closed, consistently wound, manifold mesh: slicing then looks
        for no open ends, and ``vecslice.staircase`` measures the mesh as given.
        """
        closed = self._closed
        if closed is None:
            twins = self._half_edge_twins()
            closed = bool(twins.shape[0] == 0 or twins.min() >= 0)
            object.__setattr__(self, "_closed", closed)
        return closed

    def _narrow_faces(self) -> NDArray[np.int32]:
        """``faces`` as int32, built once per mesh and cached like the twins.

        The contour kernels read the faces at every step of a loop; in int32
        they read half the bytes (on five Benchies the closed loops are traced
        in about a tenth less time). 12 bytes per face.

        Raises
        ------
        InputValueError
            If the mesh has more than 2**31 vertices (face indices must fit int32).
        """
        f32 = self._faces32
        if f32 is None:
            from vecslice._kernels import contours
            from vecslice._threads import run_chunks

            n = self.vertices.shape[0]
            if n > contours.NARROW_LIMIT:
                raise InputValueError(
                    f"`mesh` has {n:,} vertices; slicing takes at most "
                    f"{contours.NARROW_LIMIT:,} (its face indices are read as int32)"
                )
            f32 = _freeze(contours.narrow_faces(self.faces, run_chunks))
            object.__setattr__(self, "_faces32", f32)
        return f32

    def _cura_topology(self) -> tuple[NDArray[np.int64], ...]:
        """CuraEngine's ``(faces, vf_offsets, vf_faces, neighbours)``, built once.

        ``faces`` are this mesh's faces without those that repeat a vertex index
        (CuraEngine's ``addFace`` drops them; ``Mesh(vertices, faces)`` keeps
        them), the same array when there are none. Then the faces of each vertex
        (:func:`vertex_faces`) and the face across each face edge
        (:func:`face_neighbours`, which also reads the vertices: a moved copy
        builds its own). Cached like :meth:`_half_edge_twins`.
        """
        cura = self._cura
        if cura is None:
            from vecslice._kernels.cura_mesh import face_neighbours, vertex_faces
            from vecslice._threads import run_chunks

            f = self.faces
            a, b, c = f[:, 0], f[:, 1], f[:, 2]
            repeated = (a == b) | (b == c) | (a == c)
            if repeated.any():
                f = _freeze(np.ascontiguousarray(f[~repeated]))
            vf_offsets, vf_faces = vertex_faces(f, self.vertices.shape[0])
            neighbours = face_neighbours(self.vertices, f, vf_offsets, vf_faces,
                                         run_chunks)
            cura = (f, _freeze(vf_offsets), _freeze(vf_faces), _freeze(neighbours))
            object.__setattr__(self, "_cura", cura)
        return cura

    @classmethod
    def _trusted(
        cls, v: NDArray[np.int64], f: NDArray[np.int64], info: LoadInfo | None
    ) -> Mesh:
        m = object.__new__(cls)
        m._set(v, f, info)
        return m

    @classmethod
    @keyboard_interrupts
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
            face uses. ``False`` stores the arrays as given. Must be a bool.
        load_info : LoadInfo, optional
            Counts from an earlier stage to add to (used by :func:`load_mesh`).

        Returns
        -------
        Mesh

        Raises
        ------
        InputTypeError
            If an array is not integer (float vertices get a hint), or ``merge``
            is not a bool, or ``load_info`` not a LoadInfo.
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
        check_bool(merge, "merge")
        _check_load_info(load_info)
        v = _as_vertices(vertices_um)  # private copies, checked: what the merge
        f = _as_faces(faces, v.shape[0])  # kernels read (and no other copy)
        base = load_info if load_info is not None else LoadInfo(
            "arrays", int(f.shape[0]), int(v.shape[0]))
        if not merge:
            return cls._trusted(v, f, base)
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
        mesh = cls._trusted(v2, f2, info)
        # every vertex is a face corner now (unused ones were dropped): the
        # corners' z range is the vertices', two reductions instead of a gather
        object.__setattr__(mesh, "_zcorners", mesh.zrange)
        return mesh

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

    def _corner_zrange(self) -> tuple[int, int]:
        """The model's lowest and highest z in µm, computed once.

        What the layer schedules, the adaptive ``model_max_z``, the on-plane
        limit of ``compat="cura"`` and the staircase metric measure from. A
        vertex that no face uses (``Mesh(vertices, faces)`` keeps them) is not
        part of the model: the z range of the faces' corners, as in CuraEngine,
        whose vertex list holds only vertices that came with faces. A mesh read
        by CuraEngine's rules (``load_mesh(..., compat="cura")``) sets it to its
        vertices' range instead: each of them came with a face, and CuraEngine's
        bounding box keeps the vertices of the faces its 30 µm melding then
        drops. The vertex range for a mesh without faces.
        """
        zr = self._zcorners
        if zr is None:
            if self.faces.shape[0] == 0:
                zr = self.zrange
            else:  # numpy (10 ms for a million faces): no kernel to compile
                z = self.vertices[:, 2][self.faces]
                zr = (int(z.min()), int(z.max()))
            object.__setattr__(self, "_zcorners", zr)
        return zr

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
        out = Mesh._trusted(moved, self.faces, self.load_info)
        object.__setattr__(out, "_twins", self._twins)  # same faces, same topology
        object.__setattr__(out, "_closed", self._closed)
        object.__setattr__(out, "_faces32", self._faces32)
        zmin, zmax = self._corner_zrange()  # the model moves with its vertices
        object.__setattr__(out, "_zcorners", (zmin + d[2], zmax + d[2]))
        return out

    @keyboard_interrupts
    def repaired(self) -> Mesh:
        """Remove duplicate faces; orient every shell consistently and the right way.

        1. **Duplicate faces**: faces with the same three vertices are grouped and
           their windings summed (+1 / -1). A non-zero sum keeps one face with the
           majority winding; a zero sum — a face and its reversed twin, i.e. a
           zero-thickness wall such as the shared face of two touching boxes —
           keeps none.
        2. **Winding**: faces joined across edges used by exactly two faces form a
           shell; each orientable shell is made consistent (neighbours traverse
           their shared edge in opposite directions).
        3. **Facing**: each outermost closed shell (its edge uses cancel, and no
           other closed shell contains it — decided by exact ray parity of its
           vertices; shells that cross each other are not nested) faces outward
           (positive signed volume), and the closed shells nested in it are turned
           with it: a nested shell keeps its winding relative to the shell around
           it. Wound opposite to it, it is a cavity (the void of a hollow part
           stays a void); wound the same way, it is a body overlapping it (merged
           by the NonZero union); an inside-out part is turned over as a whole.
           An open shell keeps the orientation most of its faces had.
           Non-orientable shells are left as they are.

        Vertices no face uses any more are dropped. Non-manifold edges, holes and
        self-intersections are not changed (:func:`check_mesh` reports them). The
        result's ``load_info`` adds up removed and flipped faces and reversed
        shells, and gives the number of cavities (inward closed shells).

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
        >>> li = inside_out.repaired().load_info
        >>> li.faces_flipped, li.shells_reversed, li.cavities_kept
        (4, 1, 0)
        """
        f = self.faces
        keep = dedupe_faces(f)
        f = f[keep]
        if f.shape[0] == 0:
            raise InputValueError(
                "`mesh` has no faces left after repair: every face cancels "
                "against a reversed copy of itself"
            )
        turn = orient_faces(self.vertices, f)
        f = np.where(turn.flip[:, None], f[:, [0, 2, 1]], f)
        v, f, _, n_unused, _ = clean_arrays(self.vertices, f, merge=False)
        info = self.load_info if self.load_info is not None else LoadInfo(
            "arrays", self.n_faces, self.n_vertices)
        info = replace(
            info,
            vertices_unused=info.vertices_unused + n_unused,
            faces_duplicate=info.faces_duplicate + int((~keep).sum()),
            faces_flipped=info.faces_flipped + int(turn.flip.sum()),
            shells_reversed=info.shells_reversed + turn.shells_reversed,
            cavities_kept=turn.cavities,
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


@keyboard_interrupts
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


def _check_coords(v: NDArray[np.float64], s: float, source: str) -> NDArray[np.float64]:
    """``v * s`` in mm after checking finiteness and the 2**30 µm range per vertex."""
    bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if bad.size:
        i = int(bad[0])
        raise InputValueError(
            f"`vertices` must be finite; got {[float(x) for x in v[i]]} at vertex "
            f"{i} of {source}"
        )
    with np.errstate(over="ignore"):
        mm = v * s if s != 1.0 else v
        # |round half away from zero| = trunc(|x| + 0.5), as in to_microns
        big = np.flatnonzero((np.trunc(np.abs(mm) * 1000.0 + 0.5) >= COORD_LIMIT)
                             .any(axis=1))
    if big.size:
        i = int(big[0])
        at = ", ".join(f"{float(x):g}" for x in v[i])
        scaled = f" x scale {s:g}" if s != 1.0 else ""
        raise InputValueError(
            f"`vertices` must be below {COORD_LIMIT / 1000:g} mm in magnitude "
            f"(2**30 µm); got ({at}){scaled} mm at vertex {i} of {source}"
        )
    return mm


@keyboard_interrupts
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
        Every 3MF build item and component placement, and every scene node, is
        placed with its transform and concatenated.
    scale : float, default 1.0
        File units to millimetres (25.4 for inches, 1000 for metres). A 3MF
        file's own ``unit`` is applied first, so leave it at 1 for 3MF.
    repair : bool, default True
        Remove duplicate faces and orient every shell consistently: each part
        outward, the shells nested in it turned with it, so cavities (wound
        opposite to the shell around them) stay cavities (see
        :meth:`Mesh.repaired`). ``False`` keeps the file's windings.
        Ignored with ``compat="cura"``.
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
        (an ``OSError``) for a missing file, a symbolic link loop, a directory, an
        unsupported suffix, an empty, unreadable, truncated, corrupt or
        oversized file, one without triangles, or one whose faces all collapse
        at ``scale`` or cancel in the repair (each against a reversed copy).
    InputTypeError
        If ``path_or_trimesh``, ``scale``, or ``repair`` has the wrong type.
    InputValueError
        If ``scale`` is not positive and finite, a vertex is NaN or infinite, or a
        coordinate reaches 2**30 µm.
    SettingsError
        If ``compat`` is not 'vecslice' or 'cura'.

    Notes
    -----
    Limits refuse hostile files before they cost memory: at most
    :data:`vecslice.meshfile.MAX_TRIANGLES` triangles (100 million; also for
    counts a header announces); for 3MF at most
    :data:`vecslice.threemf.MAX_MODEL_BYTES` (1 GiB) of model XML, inflated no
    more than :data:`vecslice.threemf.MAX_COMPRESSION_RATIO` (200) times the
    compressed bytes actually read, at most
    :data:`vecslice.threemf.MAX_BUILD_TRIANGLES` triangles and
    :data:`vecslice.threemf.MAX_BUILD_VERTICES` vertices (30 million each, also
    after expanding components), at most
    :data:`vecslice.threemf.MAX_EXPANDED_TRIANGLES` (2 million) triangles from
    placements that multiply fewer held, :data:`vecslice.threemf.MAX_OBJECTS`
    (100,000) objects and :data:`vecslice.threemf.MAX_INSTANCES` (a million)
    build items and components, and as many object placements.

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
    check_bool(repair, "repair")
    if check_option(compat, ("vecslice", "cura"), "compat") == "cura":
        from vecslice.cura_stl import load_mesh_cura

        return load_mesh_cura(path_or_trimesh, s)  # type: ignore[no-any-return]
    if isinstance(path_or_trimesh, (str, os.PathLike)):
        try:
            path = Path(path_or_trimesh)
        except TypeError as exc:  # a PathLike giving bytes
            raise InputTypeError(
                f"`path_or_trimesh` must be a file path (str); got {exc}") from None
        source = f"'{path}'"
        v, f = read_mesh_file(path)
        f = _freeze(f)  # made by the reader: ours
    elif (arrays := trimesh_arrays(path_or_trimesh)) is not None:
        v, f, source = arrays
        if f.shape[0] == 0:
            raise InputValueError(f"`path_or_trimesh` ({source}) holds no triangles")
    else:
        raise InputTypeError(
            "`path_or_trimesh` must be a file path, trimesh.Trimesh or "
            f"trimesh.Scene; got {type(path_or_trimesh).__name__}"
        )
    um = to_microns(_check_coords(np.asarray(v, dtype=np.float64), s, source),
                    name="vertices")
    info = LoadInfo(source.strip("'"), int(f.shape[0]), int(v.shape[0]))
    try:
        # frozen arrays are handed over without a copy (a trimesh's faces are
        # its own: from_arrays copies them)
        mesh = Mesh.from_arrays(_freeze(um), f, load_info=info)
        if repair:
            mesh = mesh.repaired()
    except InputValueError as exc:
        hint = ""
        if "non-degenerate" in str(exc):
            hint = (f" at scale {s:g} (file units to mm): is the scale right? "
                    "(inches: 25.4, metres: 1000)")
        if source.startswith("trimesh"):
            raise InputValueError(f"{exc}{hint}") from exc
        raise MeshFileError(f"{source}: {exc}{hint}") from exc
    return mesh
